//! Spherical shells rendered natively against the paper's way, the shell resampled onto a
//! regular box. `hdrvis bench spherical` times one spherical sample against one Cartesian sample
//! (the mantle's native shell and its resampled box, the same camera, transfer function and step
//! length in the world, no empty-space skipping and no early exit, runs alternating), counting
//! the samples each ray takes analytically. The accuracy report's `shell` scene
//! (`super::accuracy`) builds on the shell, views and transfer-function rescaling here.

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::model::{
    Camera, CoordAxis, Geometry, LutTransfer, SphericalGrid, TransferFunction, Volume,
};
use crate::render::{VolumeRenderOptions, VolumeSource};
use std::sync::Arc;

/// The mantle's temperature fluctuation on its own spherical grid, fine enough for an `n`³ box
/// (seed 7, as the other mantle scenes).
pub fn native_mantle(n: usize) -> Result<Volume> {
    use crate::datasets::mantle::{generate_native, MantleField, MantleFields, MantleOptions};
    let field = MantleField::Fluctuation;
    let m = generate_native(
        &MantleOptions {
            n,
            seed: 7,
            fields: MantleFields::only(field),
            ..Default::default()
        },
        &mut |_| Ok(()),
    )?;
    m.volume(field, 7)?
        .ok_or_else(|| Error::invalid("field", "the fluctuation was not generated"))
}

/// A global tomography-like model on its own (depth, latitude, longitude) grid: `n` levels from
/// the core–mantle boundary (2891 km) to the surface, 180/2n° in latitude and longitude, dVs in
/// %: a ring of fast slabs dipping under the Pacific's rim to 1200 km, four slow plumes through
/// the whole mantle, two slow provinces above the core and a weak smooth background, so that a
/// transfer function showing the slabs leaves most of the mantle transparent.
pub fn tomography_shell(n: usize) -> Result<Volume> {
    const R: f64 = 6371.0;
    let radius = CoordAxis::uniform_cells(R - 2891.0, 2891.0 / n as f64, n);
    let step = 90.0 / n as f64;
    let (lat, lon) = (
        CoordAxis::uniform_cells(-90.0, step, 2 * n),
        CoordAxis::uniform_cells(-180.0, step, 4 * n),
    );
    // Angular distance (degrees) and bearing (degrees from north) from a to b.
    let arc = |a: [f64; 2], b: [f64; 2]| {
        let (p1, p2, dl) = (
            a[0].to_radians(),
            b[0].to_radians(),
            (b[1] - a[1]).to_radians(),
        );
        let c = p1.sin() * p2.sin() + p1.cos() * p2.cos() * dl.cos();
        let az = (dl.sin() * p2.cos()).atan2(p1.cos() * p2.sin() - p1.sin() * p2.cos() * dl.cos());
        (
            c.clamp(-1.0, 1.0).acos().to_degrees(),
            az.to_degrees().rem_euclid(360.0),
        )
    };
    let pacific = [5.0, -160.0];
    let segments = [[0.0, 70.0], [100.0, 160.0], [200.0, 250.0], [280.0, 340.0]];
    let plumes = [
        [-20.0, 20.0],
        [-15.0, -150.0],
        [20.0, -155.0],
        [64.0, -17.0],
    ];
    let provinces = [[-10.0, 20.0], [-10.0, -160.0]];
    let field = |depth: f64, la: f64, lo: f64| {
        let p = [la, lo];
        let mut v = 0.3
            * (3.0 * la.to_radians()).sin()
            * (2.0 * lo.to_radians()).cos()
            * (std::f64::consts::PI * depth / 2891.0).cos();
        let (theta, az) = arc(pacific, p);
        if depth < 1200.0 && segments.iter().any(|s| az >= s[0] && az <= s[1]) {
            // The slab's surface moves outward from the trench at 62° as it dips at 50°.
            let at = 62.0 + (depth / 50f64.to_radians().tan() / R).to_degrees();
            let across = (theta - at).to_radians() * R;
            v += 2.5 * (-(across / 60.0).powi(2)).exp();
        }
        for c in plumes {
            v -= 2.0 * (-(arc(c, p).0 / 2.5).powi(2)).exp();
        }
        for c in provinces {
            v -= 1.8
                * (-(arc(c, p).0 / 22.0).powi(2)).exp()
                * ((depth - 2000.0) / 600.0).clamp(0.0, 1.0);
        }
        v
    };
    let mut data = Vec::with_capacity(n * 8 * n * n);
    for r in &radius.centres {
        for la in &lat.centres {
            for lo in &lon.centres {
                data.push(field(R - r, *la, *lo) as f32);
            }
        }
    }
    let g = SphericalGrid {
        axis_of: [2, 1, 0],
        radius,
        latitude: lat,
        longitude: lon,
        lon_wraps: true,
        planet_radius: R,
        length_unit: "km".into(),
        vertical: "depth".into(),
        rotated_pole: None,
    };
    Volume::new("dvs", [4 * n, 2 * n, n], [1.0; 3], [0.0; 3], data)?
        .with_geometry(Geometry::Spherical(Box::new(g)))
}

/// Only [`tomography_shell`]'s fast anomalies above +0.8 % (its slabs), red to blue.
pub fn tomography_slabs_tf() -> TransferFunction {
    TransferFunction::Lut(LutTransfer {
        domain: Some([-3.0, 3.0]),
        colormap: "rd_bu".into(),
        emission: vec![[0.0, -0.5], [0.5, -2.0], [1.0, -0.5]],
        opacity: vec![[0.0, -1.0], [0.5, -2.5], [1.0, -1.0]],
        transparent_below: 3.8 / 6.0,
        ..Default::default()
    })
}

/// The shell's view: the Fig. 5 transfer function, an orbit view of the planet, `size`² pixels,
/// a step of half the smallest radial spacing.
pub fn shell_options(shell: &Volume, size: u32) -> Result<VolumeRenderOptions> {
    let tf = TransferFunction::Lut(super::mantle_fig5_tf());
    let mut o = VolumeRenderOptions::new(Camera::orbit(&shell.bounds(), 35.0, 20.0, 25.0)?, tf);
    o.width = size;
    o.height = size;
    o.step = 0.5;
    Ok(o)
}

/// `tf` with emission and extinction per length `k` times longer: what a transfer function
/// written for one voxel length gives for another, so a resampled box (whose voxel is its own
/// side, not the shell's radial spacing) renders the same picture.
pub(crate) fn per_longer_voxel(tf: &TransferFunction, k: f64) -> TransferFunction {
    tf.with_factors(k, k)
}

/// `options` for `boxed`, the resampling of a shell whose voxel length is `shell_voxel`: the
/// transfer function per the box's voxel and the step `step_world` in the world.
pub(crate) fn box_options(
    options: &VolumeRenderOptions,
    boxed: &Volume,
    shell_voxel: f64,
    step_world: f64,
) -> VolumeRenderOptions {
    let h = boxed.voxel_length();
    let mut o = options.clone();
    o.tf = per_longer_voxel(&options.tf, h / shell_voxel);
    o.step = step_world / h;
    o
}

/// Samples the rays of `o` take through `v` in all: each ray's length inside the domain (the
/// shell's parts, or the box) over the step length.
pub(crate) fn sample_count(v: &Volume, o: &VolumeRenderOptions) -> f64 {
    let ds = o.step * v.voxel_length();
    let bounds = v.bounds();
    let mut total = 0.0;
    for py in 0..o.height {
        for px in 0..o.width {
            let (orig, d) = o.camera.ray(px, py, o.width, o.height);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let t: f64 = match &v.geometry {
                Geometry::Spherical(g) => g.ray_intervals(orig, d).iter().map(|(a, b)| b - a).sum(),
                _ => bounds
                    .intersect(orig, d)
                    .map_or(0.0, |(a, b)| (b - a.max(0.0)).max(0.0)),
            };
            total += t * len / ds;
        }
    }
    total
}

/// One row of `hdrvis bench spherical`.
#[derive(Clone, Debug)]
pub struct SphericalRow {
    pub variant: String,
    pub median_ms: f64,
    pub samples: f64,
    pub voxels: usize,
    /// The median ray-casting pass on the GPU's own clock, where the adapter has timestamps.
    pub gpu_median_ms: Option<f64>,
}

impl SphericalRow {
    pub(crate) fn ns_per_sample(&self) -> f64 {
        self.median_ms * 1e6 / self.samples.max(1.0)
    }

    /// Nanoseconds per sample on the GPU's own clock: on a real GPU the wall clock is mostly
    /// readback, and only this measures the samples.
    pub(crate) fn gpu_ns_per_sample(&self) -> Option<f64> {
        self.gpu_median_ms
            .map(|ms| ms * 1e6 / self.samples.max(1.0))
    }
}

/// The native shell of [`native_mantle`]`(n)` and its `n`³ box at the same step in the world
/// (half the shell's radial spacing), `size`² pixels, f32, no skipping, no early exit; renders
/// alternate, `runs` each after a warm-up. The box is also timed with the shader's own
/// trilinear filter (eight texel loads, as the shell's samples take) and with empty-space
/// skipping (its core and corners are missing), the way a user would render it.
pub fn bench_spherical(
    ctx: Arc<GpuContext>,
    n: usize,
    size: u32,
    runs: usize,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<SphericalRow>> {
    log(&format!("shell for an {n}^3 box: generating ..."));
    let shell = Arc::new(native_mantle(n)?);
    let boxed = Arc::new(crate::model::resample_to_box(&shell, n)?);
    let mut o = shell_options(&shell, size)?;
    o.early_exit = 0.0;
    o.empty_space_skipping = false;
    let step_world = o.step * shell.voxel_length();
    let ob = box_options(&o, &boxed, shell.voxel_length(), step_world);
    // The shell's samples load eight texels and weigh them in the shader; so may the box's.
    let mut ob_exact = ob.clone();
    ob_exact.filter = crate::render::FilterMode::Exact;
    let mut ob_skip = ob.clone();
    ob_skip.empty_space_skipping = true;
    let session = super::timing_session(ctx);
    let cases = [
        (
            "spherical (native shell)",
            VolumeSource::Memory(shell.clone()),
            &o,
        ),
        ("cartesian (box)", VolumeSource::Memory(boxed.clone()), &ob),
        (
            "cartesian (box, exact filter)",
            VolumeSource::Memory(boxed.clone()),
            &ob_exact,
        ),
        (
            "cartesian (box, skipping)",
            VolumeSource::Memory(boxed.clone()),
            &ob_skip,
        ),
    ];
    let mut ms = vec![Vec::new(); cases.len()];
    let mut gpu_ms = vec![Vec::new(); cases.len()];
    super::warm_up(|| {
        for (_, source, opts) in &cases {
            session.render_volume_detailed(source, opts)?;
        }
        Ok(())
    })?;
    for run in 0..runs.max(1) {
        for (i, (name, source, opts)) in cases.iter().enumerate() {
            let r = session.render_volume_detailed(source, opts)?;
            log(&format!("run {run}: {name} {:.1} ms", r.seconds * 1e3));
            ms[i].push(r.seconds * 1e3);
            gpu_ms[i].extend(r.gpu_seconds.map(|g| g * 1e3));
        }
    }
    let shell_samples = sample_count(&shell, &o);
    let box_samples = sample_count(&boxed, &ob);
    Ok(cases
        .iter()
        .zip(ms.into_iter().zip(gpu_ms))
        .enumerate()
        .map(|(i, ((name, _, _), (ms, gpu)))| SphericalRow {
            variant: name.to_string(),
            median_ms: super::median(&ms),
            gpu_median_ms: (!gpu.is_empty()).then(|| super::median(&gpu)),
            samples: if i == 0 { shell_samples } else { box_samples },
            voxels: if i == 0 {
                shell.voxel_count()
            } else {
                boxed.voxel_count()
            },
        })
        .collect())
}

pub fn format_spherical_table(adapter: &str, n: usize, size: u32, rows: &[SphericalRow]) -> String {
    let mut s = format!(
        "adapter: {adapter}\nmantle shell for an {n}^3 box and that box, {size}^2 px, f32, the same step in the world, no early exit; skipping off unless named\n"
    );
    s.push_str(&format!(
        "{:<30} {:>12} {:>10} {:>12} {:>11} {:>10} {:>13}\n",
        "variant", "voxels", "median ms", "samples", "ns/sample", "GPU ms", "GPU ns/sample"
    ));
    let opt =
        |v: Option<f64>, digits: usize| v.map_or("-".to_string(), |v| format!("{v:.digits$}"));
    for r in rows {
        s.push_str(&format!(
            "{:<30} {:>12} {:>10.1} {:>12.0} {:>11.3} {:>10} {:>13}\n",
            r.variant,
            r.voxels,
            r.median_ms,
            r.samples,
            r.ns_per_sample(),
            opt(r.gpu_median_ms, 2),
            opt(r.gpu_ns_per_sample(), 4),
        ));
    }
    if let [shell, boxed, exact, skipping, ..] = rows {
        // On the GPU's own clock where every row has it, else the wall clock.
        let on_gpu = rows.iter().all(|r| r.gpu_median_ms.is_some());
        let ns = |r: &SphericalRow| {
            if on_gpu {
                r.gpu_ns_per_sample().unwrap_or(f64::NAN)
            } else {
                r.ns_per_sample()
            }
        };
        let ms = |r: &SphericalRow| {
            if on_gpu {
                r.gpu_median_ms.unwrap_or(f64::NAN)
            } else {
                r.median_ms
            }
        };
        s.push_str(&format!(
            "{}: a spherical sample costs {:.2}x a Cartesian one ({:.2}x one filtered in the shader); the shell renders in {:.2}x the box's time ({:.2}x with the box skipping)\n",
            if on_gpu { "GPU clock" } else { "wall clock" },
            ns(shell) / ns(boxed),
            ns(shell) / ns(exact),
            ms(shell) / ms(boxed),
            ms(shell) / ms(skipping)
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_transfer_function_per_longer_voxel_scales_emission_and_extinction() {
        let ea = TransferFunction::emission_absorption(2.0, 0.5).unwrap();
        assert_eq!(
            per_longer_voxel(&ea, 4.0),
            TransferFunction::EmissionAbsorption {
                emission: 8.0,
                absorption: 2.0
            }
        );
        let TransferFunction::Lut(l) = per_longer_voxel(
            &TransferFunction::Lut(super::super::mantle_fig5_tf()),
            100.0,
        ) else {
            panic!("a table stays a table");
        };
        let base = super::super::mantle_fig5_tf();
        assert!((l.opacity[0][1] - (base.opacity[0][1] + 2.0)).abs() < 1e-12);
        assert!((l.emission[3][1] - (base.emission[3][1] + 2.0)).abs() < 1e-12);
        assert_eq!(l.opacity[0][0], base.opacity[0][0]);
    }

    #[test]
    fn sample_counts_are_chords_over_the_step() {
        let shell = native_mantle(16).unwrap();
        let mut o = shell_options(&shell, 8).unwrap();
        o.camera = Camera::axis(crate::model::Axis::Z, &shell.bounds());
        // Orthographic along z: each ray's length in the shell is its chord.
        let Geometry::Spherical(g) = &shell.geometry else {
            panic!()
        };
        let (r0, r1) = (g.radius.lo, g.radius.hi);
        let ds = o.step * shell.voxel_length();
        let mut want = 0.0;
        for py in 0..8 {
            for px in 0..8 {
                let x = (2.0 * (px as f64 + 0.5) / 8.0 - 1.0) * r1;
                let y = (1.0 - 2.0 * (py as f64 + 0.5) / 8.0) * r1;
                let b = (x * x + y * y).sqrt();
                let half = |r: f64| if b < r { (r * r - b * b).sqrt() } else { 0.0 };
                want += 2.0 * (half(r1) - half(r0)) / ds;
            }
        }
        let got = sample_count(&shell, &o);
        assert!((got - want).abs() < 1e-6 * want, "{got} {want}");
    }
}
