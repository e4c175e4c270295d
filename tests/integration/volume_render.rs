//! The volume ray caster against closed forms (GPU f32 and CPU f64), GPU against the CPU
//! reference, hard optical cases and missing values.

use crate::common::{max_rel, render, render_on, renderer};
use hdrvis::gpu::BackendChoice;
use hdrvis::model::{Axis, Camera, LutTransfer, Scale, TransferFunction, Volume};
use hdrvis::render::cpu_reference::render_volume_f64;
use hdrvis::render::volume::GpuVolume;
use hdrvis::render::{FilterMode, RenderPath, VolumeRenderOptions};

fn gpu_render(backend: BackendChoice, vol: &Volume, opts: &VolumeRenderOptions) -> Vec<[f64; 4]> {
    let img = render(backend, vol, opts);
    img.pixels.iter().map(|p| p.map(|v| v as f64)).collect()
}

fn axis_opts(vol: &Volume, axis: Axis, tf: TransferFunction, step: f64) -> VolumeRenderOptions {
    let cam = Camera::axis(axis, &vol.bounds());
    let mut o = VolumeRenderOptions::new(cam, tf);
    let (w, h) = match axis {
        Axis::Z => (vol.dims[0], vol.dims[1]),
        Axis::X => (vol.dims[1], vol.dims[2]),
        Axis::Y => (vol.dims[0], vol.dims[2]),
    };
    o.width = w as u32;
    o.height = h as u32;
    o.step = step;
    o.early_exit = 0.0;
    o
}

fn red(p: &[[f64; 4]]) -> Vec<f64> {
    p.iter().map(|p| p[0]).collect()
}

#[test]
fn homogeneous_slab_matches_closed_form() {
    // I = (e/a)(1 - exp(-a v L)) for a slab of constant value v and thickness L voxels.
    let (e, a, v, l) = (2.0, 0.03, 1.5, 64.0);
    let vol = Volume::from_fn("slab", [8, 8, 64], |_, _, _| v).unwrap();
    let expect = e / a * (1.0 - (-a * v * l).exp());
    let tf = TransferFunction::emission_absorption(e, a).unwrap();
    for step in [1.0, 0.37, 0.1] {
        let o = axis_opts(&vol, Axis::Z, tf.clone(), step);
        let cpu = render_volume_f64(&vol, &o).unwrap();
        assert!(
            max_rel(&red(&cpu), &vec![expect; 64], 0.0) < 1e-9,
            "cpu step {step}"
        );
        let alpha = 1.0 - (-a * v * l).exp();
        assert!(cpu.iter().all(|p| (p[3] - alpha).abs() < 1e-12));
        for backend in crate::common::backends() {
            let gpu = gpu_render(backend, &vol, &o);
            let err = max_rel(&red(&gpu), &vec![expect; 64], 0.0);
            assert!(err < 1e-4, "{backend:?} step {step}: rel err {err}");
            assert!(gpu.iter().all(|p| (p[3] - alpha).abs() < 1e-5));
        }
    }
}

/// Sum of the Gaussian's voxel values along z: the exact integral of the piecewise-linear
/// interpolant the renderer samples, and (trapezoid rule on a Gaussian) the continuous one.
fn gaussian_volume(n: usize, sigma: f64) -> (Volume, impl Fn(f64, f64) -> f64) {
    let c = n as f64 / 2.0 + 0.3;
    let vol = Volume::from_fn("blob", [n, n, n], move |x, y, z| {
        (-((x - c).powi(2) + (y - c).powi(2) + (z - c).powi(2)) / (2.0 * sigma * sigma)).exp()
    })
    .unwrap();
    let column = move |x: f64, y: f64| {
        sigma
            * (2.0 * std::f64::consts::PI).sqrt()
            * (-((x - c).powi(2) + (y - c).powi(2)) / (2.0 * sigma * sigma)).exp()
    };
    (vol, column)
}

#[test]
fn gaussian_blob_emission_absorption_closed_forms() {
    // 64 voxels and sigma 4.5: the tails beyond the box are below 1e-11 of the column.
    let n = 64;
    let (vol, column) = gaussian_volume(n, 4.5);
    let pixel_centre = |i: usize| i as f64 + 0.5;
    let cols: Vec<f64> = (0..n * n)
        .map(|k| column(pixel_centre(k % n), pixel_centre(n - 1 - k / n)))
        .collect();
    // Emission only: I = e ∫v. Absorption only, over a background b: I = b exp(-a ∫v).
    // Both: with emission e·v and extinction a·v, I = (e/a)(1 - exp(-a ∫v)).
    let (e, a, b) = (3.0, 0.2, 0.7);
    let cases: Vec<(&str, TransferFunction, [f64; 3], Vec<f64>)> = vec![
        (
            "emission",
            TransferFunction::emission_absorption(e, 0.0).unwrap(),
            [0.0; 3],
            cols.iter().map(|t| e * t).collect(),
        ),
        (
            "absorption",
            TransferFunction::emission_absorption(0.0, a).unwrap(),
            [b; 3],
            cols.iter().map(|t| b * (-a * t).exp()).collect(),
        ),
        (
            "both",
            TransferFunction::emission_absorption(e, a).unwrap(),
            [0.0; 3],
            cols.iter()
                .map(|t| e / a * (1.0 - (-a * t).exp()))
                .collect(),
        ),
    ];
    for (name, tf, bg, expect) in cases {
        let mut o = axis_opts(&vol, Axis::Z, tf, 0.1);
        o.background = bg;
        let floor = 1e-3 * expect.iter().cloned().fold(0.0, f64::max);
        for backend in crate::common::backends() {
            let gpu = gpu_render(backend, &vol, &o);
            let err = max_rel(&red(&gpu), &expect, floor);
            assert!(err < 1e-4, "{name} {backend:?}: rel err {err}");
        }
        // The CPU reference converges to the closed form as the step shrinks; at 2^-10 voxels
        // (segment ends then fall exactly on the voxel centres, the interpolant's knots) it is
        // within 1e-9 on a row of pixels through the blob's centre.
        let mut fine = o.clone();
        fine.step = 1.0 / 1024.0;
        fine.height = 1;
        // A row through voxel centres (y = 32.5), so only the z interpolation is exercised.
        fine.camera = Camera::ortho_look_at(
            [32.0, 32.5, 100.0],
            [32.0, 32.5, 0.0],
            [0.0, 1.0, 0.0],
            32.0,
            0.5,
        )
        .unwrap();
        // Voxels hold f32, so the exact column integral is the sum of the stored values (the
        // analytic Gaussian differs from it by f32 rounding, ~1e-8).
        let row: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|k| vol.data[vol.index(i, 32, k)] as f64).sum())
            .collect();
        let analytic = column(32.5, 32.5);
        assert!((row[32] - analytic).abs() / analytic < 1e-7);
        let expect_row: Vec<f64> = match name {
            "emission" => row.iter().map(|t| e * t).collect(),
            "absorption" => row.iter().map(|t| b * (-a * t).exp()).collect(),
            _ => row.iter().map(|t| e / a * (1.0 - (-a * t).exp())).collect(),
        };
        let cpu = render_volume_f64(&vol, &fine).unwrap();
        let floor = 1e-3 * expect_row.iter().cloned().fold(0.0, f64::max);
        let err = max_rel(&red(&cpu), &expect_row, floor);
        assert!(err < 1e-9, "{name} cpu: rel err {err}");
    }
}

#[test]
fn tiny_extinction_accumulates_over_ten_thousand_steps() {
    // Per-step optical depth 1e-11: 1 - exp(-1e-11) is 0 in f32, yet 10^4 steps must add up.
    let (e, a) = (1.0, 1e-9);
    let vol = Volume::from_fn("thin", [4, 4, 100], |_, _, _| 1.0).unwrap();
    let o = axis_opts(
        &vol,
        Axis::Z,
        TransferFunction::emission_absorption(e, a).unwrap(),
        0.01,
    );
    let tau: f64 = a * 100.0;
    let expect_i = e / a * (-(-tau).exp_m1());
    let expect_alpha = -(-tau).exp_m1();
    for backend in crate::common::backends() {
        let gpu = gpu_render(backend, &vol, &o);
        for p in &gpu {
            assert!(
                (p[0] - expect_i).abs() / expect_i < 1e-4,
                "{backend:?} I {}",
                p[0]
            );
            assert!(
                (p[3] - expect_alpha).abs() / expect_alpha < 1e-3,
                "{backend:?} alpha {} vs {expect_alpha}",
                p[3]
            );
        }
    }
}

#[test]
fn saturation_within_one_step_gives_e_over_a() {
    let (e, a) = (5.0, 1e6);
    let vol = Volume::from_fn("opaque", [4, 4, 16], |_, _, _| 1.0).unwrap();
    let o = axis_opts(
        &vol,
        Axis::Z,
        TransferFunction::emission_absorption(e, a).unwrap(),
        1.0,
    );
    for backend in crate::common::backends() {
        for p in gpu_render(backend, &vol, &o) {
            assert!(
                (p[0] - e / a).abs() / (e / a) < 1e-5,
                "{backend:?}: {}",
                p[0]
            );
            assert!((p[3] - 1.0).abs() < 1e-6);
        }
    }
}

fn log_tf() -> TransferFunction {
    TransferFunction::Lut(LutTransfer {
        scale: Scale::Log10,
        domain: Some([1e-4, 10.0]),
        colormap: "magma".into(),
        emission: vec![[0.0, -1.0], [1.0, 1.0]],
        opacity: vec![[0.0, -4.0], [0.6, -2.0], [1.0, -0.5]],
        ..Default::default()
    })
}

/// Blobs spanning five decades on a faint background: a non-trivial HDR volume.
pub fn hdr_blobs(n: usize) -> Volume {
    let f = n as f64;
    Volume::from_fn("hdr-blobs", [n, n, n], move |x, y, z| {
        let g = |cx: f64, cy: f64, cz: f64, s: f64, amp: f64| {
            amp * (-((x - cx * f).powi(2) + (y - cy * f).powi(2) + (z - cz * f).powi(2))
                / (2.0 * (s * f).powi(2)))
            .exp()
        };
        1e-4 + g(0.3, 0.4, 0.5, 0.08, 10.0)
            + g(0.7, 0.6, 0.4, 0.12, 0.05)
            + g(0.5, 0.3, 0.7, 0.05, 1e-3)
    })
    .unwrap()
}

#[test]
fn gpu_matches_cpu_reference_with_log_opacity_transfer() {
    let vol = hdr_blobs(40);
    let cam = Camera::orbit(&vol.bounds(), 35.0, 25.0, 40.0).unwrap();
    let mut o = VolumeRenderOptions::new(cam, log_tf());
    o.width = 48;
    o.height = 40;
    o.step = 0.5;
    o.filter = FilterMode::Exact;
    let cpu = render_volume_f64(&vol, &o).unwrap();
    let peak = cpu
        .iter()
        .map(|p| p[0].max(p[1]).max(p[2]))
        .fold(0.0, f64::max);
    for backend in crate::common::backends() {
        for filter in [FilterMode::Exact, FilterMode::Auto] {
            o.filter = filter;
            let gpu = gpu_render(backend, &vol, &o);
            // Stated tolerance: 1e-3 relative per channel, measured against 1e-3 of the image's
            // peak where a pixel is darker than that (f32 rounding of positions and the table).
            let mut worst = 0.0f64;
            for (g, c) in gpu.iter().zip(&cpu) {
                for ch in 0..4 {
                    let scale = if ch == 3 {
                        1.0
                    } else {
                        c[ch].abs().max(1e-3 * peak)
                    };
                    worst = worst.max((g[ch] - c[ch]).abs() / scale);
                }
            }
            assert!(
                worst < 1e-3,
                "{backend:?} {filter:?}: worst relative difference {worst}"
            );
        }
    }
    // Jitter: the same per-pixel offsets on the GPU and the CPU (one hash), so the same match.
    o.jitter = true;
    o.seed = 3;
    o.filter = FilterMode::Exact;
    let cpu_j = render_volume_f64(&vol, &o).unwrap();
    assert!(
        cpu_j.iter().zip(&cpu).any(|(a, b)| a[0] != b[0]),
        "jitter changed nothing"
    );
    for backend in crate::common::backends() {
        let gpu = gpu_render(backend, &vol, &o);
        let worst = gpu
            .iter()
            .zip(&cpu_j)
            .flat_map(|(g, c)| {
                (0..3).map(move |ch| (g[ch] - c[ch]).abs() / c[ch].abs().max(1e-3 * peak))
            })
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-3,
            "{backend:?} jittered: worst relative difference {worst}"
        );
    }
}

#[test]
fn missing_voxels_stay_local() {
    let clean = hdr_blobs(24);
    let mut dirty = clean.clone();
    let (bi, bj) = (10usize, 13usize);
    let idx = dirty.index(bi, bj, 12);
    dirty.data[idx] = f32::NAN;
    let idx = dirty.index(3, 4, 5);
    dirty.data[idx] = f32::INFINITY;
    let o = axis_opts(&clean, Axis::Z, log_tf(), 0.5);
    for backend in crate::common::backends() {
        let a = gpu_render(backend, &clean, &o);
        let b = gpu_render(backend, &dirty, &o);
        assert!(b.iter().all(|p| p.iter().all(|v| v.is_finite())));
        for (k, (pa, pb)) in a.iter().zip(&b).enumerate() {
            let (i, j) = (k % 24, 23 - k / 24);
            let near = |ci: usize, cj: usize| {
                (i as i64 - ci as i64).abs() <= 1 && (j as i64 - cj as i64).abs() <= 1
            };
            if !near(bi, bj) && !near(3, 4) {
                assert_eq!(pa, pb, "{backend:?} pixel ({i},{j}) changed");
            }
        }
    }
}

/// Largest per-channel difference relative to the pixel (or 1e-3 of the peak where darker).
fn worst_rel(gpu: &[[f64; 4]], cpu: &[[f64; 4]]) -> f64 {
    let peak = cpu
        .iter()
        .map(|p| p[0].max(p[1]).max(p[2]))
        .fold(0.0, f64::max);
    gpu.iter()
        .zip(cpu)
        .flat_map(|(g, c)| {
            (0..3).map(move |ch| (g[ch] - c[ch]).abs() / c[ch].abs().max(1e-3 * peak))
        })
        .fold(0.0, f64::max)
}

#[test]
fn gradient_shading_matches_the_cpu_reference_and_is_absent_when_off() {
    use hdrvis::render::Shading;
    let vol = hdr_blobs(40);
    let cam = Camera::orbit(&vol.bounds(), 35.0, 25.0, 40.0).unwrap();
    let mut o = VolumeRenderOptions::new(cam, log_tf());
    (o.width, o.height, o.step, o.filter) = (48, 40, 0.5, FilterMode::Exact);
    let plain = render_volume_f64(&vol, &o).unwrap();
    o.shading = Some(Shading::default());
    let shaded = render_volume_f64(&vol, &o).unwrap();
    // Shading changes the picture, by at most the largest factor (0.3 + 0.7 + 0.3).
    let changed = shaded
        .iter()
        .zip(&plain)
        .filter(|(s, p)| (s[0] - p[0]).abs() > 1e-3 * p[0].abs())
        .count();
    assert!(
        changed > plain.len() / 4,
        "shading changed only {changed} pixels"
    );
    for (s, p) in shaded.iter().zip(&plain) {
        assert!(s[0] <= 1.3 * p[0] + 1e-12 && s[3] == p[3], "{s:?} {p:?}");
    }
    for backend in crate::common::backends() {
        let gpu = gpu_render(backend, &vol, &o);
        // Where the gradient nearly vanishes (blob centres) its direction comes from differences
        // that cancel to a few f32 ulps of the value, so the factor carries more rounding than
        // the plain render (1e-3 above): measured 4.9e-3 (lavapipe) and 3.7e-3 (GL).
        let worst = worst_rel(&gpu, &shaded);
        assert!(
            worst < 1e-2,
            "{backend:?}: worst relative difference {worst}"
        );
    }
    // Pure ambient 1 is the unshaded render: the factor is exactly 1 everywhere.
    o.shading = Some(Shading {
        ambient: 1.0,
        diffuse: 0.0,
        specular: 0.0,
        shininess: 1.0,
    });
    let gpu = gpu_render(BackendChoice::Auto, &vol, &o);
    assert!(worst_rel(&gpu, &plain) < 1e-3);
    // Without shading, the shader source holds no shading code at all.
    let off = hdrvis::gpu::shader::load("volume.wgsl", &[]).unwrap();
    let on = hdrvis::gpu::shader::load("volume.wgsl", &["SHADING"]).unwrap();
    assert!(!off.contains("shading_factor") && on.contains("shading_factor"));
}

#[test]
fn gpu_f64_matches_the_cpu_reference_to_1e_9() {
    // The kernel's own f64 output is compared (an image stores f32); `render_volume` must
    // route precision f64 to it and round its result once.
    use hdrvis::render::volume_f64::F64RayCaster;
    let r = renderer(BackendChoice::Vulkan);
    let f64_caster = F64RayCaster::new(r.context().clone());
    if !f64_caster.available() {
        eprintln!("skipped: this adapter has no shader f64");
        return;
    }
    let mut vol = hdr_blobs(32);
    // Missing voxels take the same path on both.
    vol.data[5000] = f32::NAN;
    let gv = GpuVolume::upload(r.context(), &vol).unwrap();
    let cams = [
        Camera::orbit(&vol.bounds(), 35.0, 25.0, 40.0).unwrap(),
        Camera::axis(Axis::X, &vol.bounds()),
    ];
    let ea = TransferFunction::emission_absorption(3.0, 0.7).unwrap();
    for (cam, tf, jitter) in [
        (cams[0], log_tf(), false),
        (cams[1], log_tf(), true),
        (cams[0], ea, false),
    ] {
        let mut o = VolumeRenderOptions::new(cam, tf);
        (o.width, o.height, o.step, o.jitter, o.seed) = (40, 36, 0.5, jitter, 9);
        let cpu = render_volume_f64(&vol, &o).unwrap();
        let gpu = f64_caster.render(&gv, &o).unwrap();
        o.precision = hdrvis::render::Precision::F64;
        let routed = render_on(BackendChoice::Vulkan, &vol, &o, RenderPath::F64Gpu);
        assert_eq!(routed.meta("precision"), Some("f64 (GPU)"));
        let rounded: Vec<[f32; 4]> = gpu.iter().map(|p| p.map(|v| v as f32)).collect();
        assert_eq!(routed.pixels, rounded);
        let peak = cpu
            .iter()
            .map(|p| p[0].max(p[1]).max(p[2]))
            .fold(0.0, f64::max);
        let worst = gpu
            .iter()
            .zip(&cpu)
            .flat_map(|(g, c)| {
                (0..4).map(move |ch| (g[ch] - c[ch]).abs() / c[ch].abs().max(1e-9 * peak.max(1.0)))
            })
            .fold(0.0, f64::max);
        assert!(
            worst < 1e-9,
            "{}: worst relative difference {worst}",
            o.tf.describe()
        );
    }
}

/// A ramp along z, v = z / (n·s) at the cell centres, and a table with one narrow opacity peak
/// at t = 0.5 (extinction 1 per voxel, seven decades down within 0.05) and no emission.
fn ramp_and_peak(n: usize) -> (Volume, TransferFunction) {
    let vol = Volume::from_fn("ramp", [8, 8, n], move |_, _, z| z / n as f64).unwrap();
    let tf = TransferFunction::Lut(LutTransfer {
        domain: Some([0.0, 1.0]),
        emission: vec![[0.0, -30.0], [1.0, -30.0]],
        opacity: vec![
            [0.0, -7.0],
            [0.45, -7.0],
            [0.5, 0.0],
            [0.55, -7.0],
            [1.0, -7.0],
        ],
        ..Default::default()
    });
    (vol, tf)
}

#[test]
fn preintegration_keeps_a_narrow_opacity_peak_at_large_steps() {
    use hdrvis::render::TfSampling;
    let n = 64;
    let (vol, tf) = ramp_and_peak(n);
    // The exact optical depth along z: the table's integral over the coordinate the ramp sweeps
    // (dx/du = (N - 1)/n entries per voxel), plus the clamped half voxels at both faces.
    let rt = tf.resolve(&vol.stats()).unwrap();
    let integral = rt.table_integral();
    let entries = (hdrvis::model::transfer::LUT_SIZE - 1) as f64;
    let c = |x: f64| {
        let i = (x.floor() as usize).min(integral.len() - 2);
        let f = x - i as f64;
        let (a, b) = (rt.lut[i][3], rt.lut[i + 1][3]);
        integral[i][3] + f * a + 0.5 * f * f * (b - a)
    };
    let (x_lo, x_hi) = (
        rt.table_coord(0.5 / n as f64),
        rt.table_coord((n as f64 - 0.5) / n as f64),
    );
    let tau = (c(x_hi) - c(x_lo)) * n as f64 / entries
        + 0.5 * (rt.table_at(x_lo).1 + rt.table_at(x_hi).1);
    let alpha = -(-tau).exp_m1();
    assert!(alpha > 0.1 && alpha < 0.9, "peak optical depth {tau}");
    let mut report = Vec::new();
    for step in [1.0, 2.5, 4.0] {
        let mut o = axis_opts(&vol, Axis::Z, tf.clone(), step);
        o.filter = FilterMode::Exact;
        o.tf_sampling = TfSampling::PreIntegrated;
        let cpu = render_volume_f64(&vol, &o).unwrap();
        let cpu_err = (cpu[0][3] - alpha).abs() / alpha;
        assert!(
            cpu_err < 1e-6,
            "CPU pre-integrated at step {step}: {cpu_err}"
        );
        for backend in crate::common::backends() {
            let gpu = gpu_render(backend, &vol, &o);
            let err = gpu
                .iter()
                .map(|p| (p[3] - alpha).abs() / alpha)
                .fold(0.0, f64::max);
            assert!(
                err < 1e-4,
                "{backend:?} pre-integrated at step {step}: {err}"
            );
        }
        o.tf_sampling = TfSampling::Point;
        let point = render_volume_f64(&vol, &o).unwrap();
        let point_err = (point[0][3] - alpha).abs() / alpha;
        report.push((step, cpu_err, point_err));
    }
    eprintln!("alpha {alpha}: (step, pre-integrated CPU error, point-sampled error) {report:?}");
    // Point sampling steps over the peak: off by more than 10 % at steps of 2.5 and 4 voxels.
    assert!(
        report.iter().filter(|r| r.0 > 2.0).all(|r| r.2 > 0.1),
        "point sampling errors {report:?}"
    );
}

#[test]
fn preintegrated_gpu_matches_the_cpu_reference() {
    use hdrvis::render::TfSampling;
    let vol = hdr_blobs(40);
    let cam = Camera::orbit(&vol.bounds(), 35.0, 25.0, 40.0).unwrap();
    let mut o = VolumeRenderOptions::new(cam, log_tf());
    o.width = 48;
    o.height = 40;
    o.step = 2.0;
    o.filter = FilterMode::Exact;
    o.tf_sampling = TfSampling::PreIntegrated;
    let cpu = render_volume_f64(&vol, &o).unwrap();
    o.tf_sampling = TfSampling::Point;
    let point = render_volume_f64(&vol, &o).unwrap();
    assert!(
        worst_rel(&point, &cpu) > 1e-3,
        "pre-integration changed nothing"
    );
    o.tf_sampling = TfSampling::PreIntegrated;
    for backend in crate::common::backends() {
        let worst = worst_rel(&gpu_render(backend, &vol, &o), &cpu);
        assert!(
            worst < 1e-3,
            "{backend:?}: worst relative difference {worst}"
        );
    }
    // Emission–absorption: the mean of a·v over a linear v.
    o.tf = TransferFunction::emission_absorption(0.02, 0.5).unwrap();
    let cpu = render_volume_f64(&vol, &o).unwrap();
    for backend in crate::common::backends() {
        let worst = worst_rel(&gpu_render(backend, &vol, &o), &cpu);
        assert!(worst < 1e-3, "{backend:?} emission–absorption: {worst}");
    }
    // Missing data: a segment with one finite end keeps the half next to it, the same on both.
    let mut holed = vol.clone();
    for z in 10..30 {
        for y in 12..28 {
            for x in 8..20 {
                holed.data[(z * 40 + y) * 40 + x] = f32::NAN;
            }
        }
    }
    o.tf = log_tf();
    let cpu = render_volume_f64(&holed, &o).unwrap();
    assert!(cpu.iter().flatten().all(|v| v.is_finite()));
    for backend in crate::common::backends() {
        let worst = worst_rel(&gpu_render(backend, &holed, &o), &cpu);
        assert!(worst < 1e-3, "{backend:?} with missing voxels: {worst}");
    }
}

/// The stages of `hdrvis bench volume --breakdown` reach the shader: the full stage is the
/// ray caster itself (bit for bit), each stage gives a different image from the one before, and
/// the first stage reads no volume (two different volumes give the same image) while the
/// second does.
#[test]
fn cost_breakdown_stages_do_what_they_say() {
    use hdrvis::bench::{bench_tf, bench_volume};
    use hdrvis::render::volume::SampleWork;
    let r = renderer(BackendChoice::Vulkan);
    let vol = bench_volume(32).unwrap();
    let other = Volume::from_fn("other", [32; 3], |x, y, z| {
        1e-3 * (1.0 + x + 2.0 * y + 3.0 * z)
    })
    .unwrap();
    let opts = axis_opts(&vol, Axis::Z, bench_tf(), 1.0);
    let gv = GpuVolume::upload(r.context(), &vol).unwrap();
    let gother = GpuVolume::upload(r.context(), &other).unwrap();
    let image = |g: &GpuVolume, w: SampleWork| r.render_work(g, &opts, w).unwrap().0.pixels;
    let stages: Vec<_> = SampleWork::ALL.iter().map(|&w| image(&gv, w)).collect();
    // The full stage is, bit for bit, what users get from render_volume.
    assert_eq!(stages[4], render(BackendChoice::Vulkan, &vol, &opts).pixels);
    for (i, pair) in stages.windows(2).enumerate() {
        assert_ne!(
            pair[0],
            pair[1],
            "stages {i} and {} gave the same image",
            i + 1
        );
    }
    assert_eq!(image(&gother, SampleWork::March), stages[0]);
    assert_ne!(image(&gother, SampleWork::Sample), stages[1]);
}

/// The texture unit's filter, measured: its weights at least as exact as 8 fractional bits
/// (1/512 of a texel step), exact in f32 on CPU rasterizers (lavapipe, llvmpipe), and `auto`
/// takes it exactly where the probe finds it exact; a render with `auto` records that choice.
#[test]
fn the_filter_probe_measures_the_texture_units_weights_and_auto_follows_it() {
    for backend in crate::common::backends() {
        let ctx = crate::common::renderer(backend).context().clone();
        let Some(error) = ctx.hardware_filter_error() else {
            assert!(
                !ctx.caps.float32_filterable,
                "{backend:?}: probe did not run"
            );
            continue;
        };
        assert!(error <= 1.0 / 512.0 + 1e-6, "{backend:?}: {error}");
        if ctx.info.device_type == wgpu::DeviceType::Cpu {
            assert!(
                error < 1e-6,
                "{backend:?}: a CPU rasterizer filters in f32: {error}"
            );
        }
        let vol = Volume::from_fn("ramp", [8, 8, 8], |x, _, _| x).unwrap();
        let mut o = VolumeRenderOptions::new(
            Camera::axis(Axis::Z, &vol.bounds()),
            TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
        );
        o.width = 8;
        o.height = 8;
        let img = render_on(backend, &vol, &o, RenderPath::InCore { skipping: false });
        let hardware = error <= 1e-5;
        assert_eq!(
            img.meta("filter")
                .unwrap_or_default()
                .starts_with("hardware"),
            hardware,
            "{backend:?}: error {error}, image filter {:?}",
            img.meta("filter")
        );
    }
}
