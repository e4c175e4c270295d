//! Spherical volumes from CF NetCDF files written by xarray: the constant shell's axis view
//! against the chord through it (GPU and f64 CPU), a field linear in radius against an f64
//! quadrature along each ray, no seam whichever turn the longitudes are stored from, a regional
//! wedge against its chord, an uneven depth axis, and the one-line errors of bad coordinates.

use crate::common::cf_sphere_file;
use crate::common::session;
use hdrvis::datasets::{load_volume, load_volume_with, LoadOptions};
use hdrvis::gpu::BackendChoice;
use hdrvis::model::{Axis, Camera, Geometry, TransferFunction, Volume};
use hdrvis::render::{FilterMode, Precision, RenderPath, VolumeRenderOptions, VolumeSource};
use std::sync::Arc;

fn render(v: &Volume, opts: &VolumeRenderOptions) -> (Vec<[f32; 4]>, RenderPath) {
    let r = session(BackendChoice::Vulkan)
        .render_volume_detailed(&VolumeSource::Memory(Arc::new(v.clone())), opts)
        .unwrap_or_else(|e| panic!("{e}"));
    (r.image.pixels.clone(), r.path)
}

/// The emission-only axis view from above the North Pole, `n` pixels square.
fn emission_view(v: &Volume, n: u32, step: f64) -> VolumeRenderOptions {
    let mut o = VolumeRenderOptions::new(
        Camera::axis(Axis::Z, &v.bounds()),
        TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
    );
    o.width = n;
    o.height = n;
    o.step = step;
    o.early_exit = 0.0;
    o
}

fn shell_grid(v: &Volume) -> (f64, f64, f64) {
    let Geometry::Spherical(g) = &v.geometry else {
        panic!("{} is not spherical: {:?}", v.name, v.geometry.name());
    };
    (g.radius.lo, g.radius.hi, g.length_scale())
}

/// Distance of pixel (px, py)'s ray from the axis in an orthographic view of [-R, R]².
fn impact(px: u32, py: u32, n: u32, r: f64) -> f64 {
    let x = (2.0 * (px as f64 + 0.5) / n as f64 - 1.0) * r;
    let y = (1.0 - 2.0 * (py as f64 + 0.5) / n as f64) * r;
    (x * x + y * y).sqrt()
}

fn chord(b: f64, r0: f64, r1: f64) -> f64 {
    let half = |r: f64| if b < r { (r * r - b * b).sqrt() } else { 0.0 };
    2.0 * (half(r1) - half(r0))
}

#[test]
fn constant_shell_integrates_to_the_chord_on_gpu_and_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = cf_sphere_file(dir.path(), "shell.nc", &["shell"]) else {
        return;
    };
    let v = load_volume(&path).unwrap();
    assert_eq!(v.geometry.name(), "spherical");
    let (r0, r1, dr) = shell_grid(&v);
    assert!(
        (r1 - 6371.0).abs() < 1e-9 && (r0 - 3480.0).abs() < 1e-9,
        "{r0} {r1}"
    );
    let n = 48;
    let mut opts = emission_view(&v, n, 0.5);
    let (gpu, path_taken) = render(&v, &opts);
    assert!(
        matches!(path_taken, RenderPath::Mapped { .. }),
        "{path_taken:?}"
    );
    opts.precision = Precision::F64;
    let (cpu, cpu_path) = render(&v, &opts);
    assert_eq!(cpu_path, RenderPath::F64Cpu);
    let mut worst = (0.0f64, 0.0f64);
    for py in 0..n {
        for px in 0..n {
            let b = impact(px, py, n, r1);
            let want = chord(b, r0, r1) / dr;
            let i = (py * n + px) as usize;
            let (g, c) = (gpu[i][0] as f64, cpu[i][0] as f64);
            if want == 0.0 {
                assert_eq!((g, c), (0.0, 0.0), "pixel {px},{py} outside the shell");
                continue;
            }
            worst.0 = worst.0.max((g - want).abs() / want);
            worst.1 = worst.1.max((c - want).abs() / want);
        }
    }
    assert!(worst.0 < 1e-3, "GPU relative error {:.2e}", worst.0);
    // The CPU image is f32 at the end: 1e-9 is checked on the f64 pixels below.
    let f64_pixels = hdrvis::render::cpu_reference::render_volume_f64(&v, &opts).unwrap();
    let mut worst64 = 0.0f64;
    for py in 0..n {
        for px in 0..n {
            let want = chord(impact(px, py, n, r1), r0, r1) / dr;
            if want > 0.0 {
                let got = f64_pixels[(py * n + px) as usize][0];
                worst64 = worst64.max((got - want).abs() / want);
            }
        }
    }
    assert!(worst64 < 1e-9, "CPU f64 relative error {worst64:.2e}");
    eprintln!("shell chord: GPU {:.2e}, CPU f64 {worst64:.2e}", worst.0);
}

#[test]
fn longitudes_from_minus_180_and_from_0_give_one_image() {
    let dir = tempfile::tempdir().unwrap();
    let Some(a) = cf_sphere_file(dir.path(), "a.nc", &["lonfield", "--lon0", "-180"]) else {
        return;
    };
    let b = cf_sphere_file(dir.path(), "b.nc", &["lonfield", "--lon0", "0"]).unwrap();
    let (va, vb) = (load_volume(&a).unwrap(), load_volume(&b).unwrap());
    for cam in [
        Camera::axis(Axis::Z, &va.bounds()),
        Camera::orbit(&va.bounds(), 180.0, 20.0, 40.0).unwrap(),
    ] {
        // The shader's own filter wraps the longitude by selecting texels; the texture unit
        // (where `auto` takes it: its weights exact in f32) by a repeating sampler axis.
        let mut by_filter = Vec::new();
        for filter in [FilterMode::Exact, FilterMode::Auto] {
            let mut o = emission_view(&va, 64, 0.5);
            o.camera = cam;
            o.filter = filter;
            let (ia, _) = render(&va, &o);
            let (ib, _) = render(&vb, &o);
            let diff = max_red_diff(&ia, &ib);
            let peak = ia.iter().map(|p| p[0]).fold(0.0f32, f32::max);
            assert!(
                peak > 1.0 && diff <= 1e-4 * peak,
                "{filter:?}: diff {diff} of peak {peak}"
            );
            by_filter.push((ia, peak));
        }
        let (exact, peak) = &by_filter[0];
        let diff = max_red_diff(exact, &by_filter[1].0);
        assert!(diff <= 1e-5 * peak, "exact against auto: {diff} of {peak}");
    }
}

fn max_red_diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(p, q)| (p[0] - q[0]).abs())
        .fold(0.0f32, f32::max)
}

#[test]
fn regional_wedge_and_uneven_depths_match_their_chords() {
    let dir = tempfile::tempdir().unwrap();
    // A wedge of latitudes 0..60 and longitudes 0..90 seen from above the pole: the rays
    // along z at (x, y) with x, y > 0 cross latitudes from 0 up to the outer sphere or to 60°.
    let Some(path) = cf_sphere_file(
        dir.path(),
        "wedge.nc",
        &[
            "shell", "--wedge", "0", "60", "0", "90", "--nlat", "12", "--nlon", "18", "--uneven",
        ],
    ) else {
        return;
    };
    let v = load_volume(&path).unwrap();
    let Geometry::Spherical(g) = &v.geometry else {
        panic!("not spherical")
    };
    assert!(!g.lon_wraps && g.radius.uniform_step().is_none());
    let n = 40;
    let opts = emission_view(&v, n, 0.5);
    let (img, _) = render(&v, &opts);
    let bounds = v.bounds();
    let (r0, r1, dr) = shell_grid(&v);
    let t60 = 60f64.to_radians().tan();
    let mut worst = 0.0f64;
    let mut inside = 0;
    for py in 0..n {
        for px in 0..n {
            // The orthographic view frames the wedge's bounding box.
            let x = bounds.lo[0] + (px as f64 + 0.5) / n as f64 * (bounds.hi[0] - bounds.lo[0]);
            let y = bounds.hi[1] - (py as f64 + 0.5) / n as f64 * (bounds.hi[1] - bounds.lo[1]);
            let rho = (x * x + y * y).sqrt();
            // z from 0 (equator) to where the ray leaves the outer sphere or the 60° cone,
            // minus the part inside the inner sphere.
            let z_top = |r: f64| {
                if rho < r {
                    (r * r - rho * rho).sqrt()
                } else {
                    0.0
                }
            };
            let cone = rho * t60;
            let len = if x > 0.0 && y > 0.0 && rho < r1 {
                let top = z_top(r1).min(cone);
                let bottom = z_top(r0).min(cone);
                // Between the inner sphere's top and the cone or outer sphere.
                if rho < r0 {
                    top - bottom
                } else {
                    top
                }
            } else {
                0.0
            };
            let got = img[(py * n + px) as usize][0] as f64;
            let want = len / dr;
            if want > 0.5 {
                inside += 1;
                worst = worst.max((got - want).abs() / want);
            } else if want == 0.0 {
                assert!(got.abs() < 1e-3, "pixel {px},{py}: {got} outside the wedge");
            }
        }
    }
    assert!(inside > 200, "{inside} pixels inside");
    assert!(worst < 1e-3, "wedge chord relative error {worst:.2e}");
}

#[test]
fn radial_field_matches_a_quadrature_along_each_ray() {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = cf_sphere_file(dir.path(), "radial.nc", &["radial", "--ndepth", "12"]) else {
        return;
    };
    let v = load_volume(&path).unwrap();
    let (r0, r1, dr) = shell_grid(&v);
    let n = 32;
    let mut o = emission_view(&v, n, 0.25);
    o.camera = Camera::orbit(&v.bounds(), 30.0, 25.0, 35.0).unwrap();
    let (img, _) = render(&v, &o);
    let mut worst = 0.0f64;
    for py in 0..n {
        for px in 0..n {
            let (orig, d) = o.camera.ray(px, py, n, n);
            // Composite Simpson over each part of the ray inside the shell, value = radius.
            let mut want = 0.0;
            let Geometry::Spherical(g) = &v.geometry else {
                unreachable!()
            };
            for (a, b) in g.ray_intervals(orig, d) {
                let m = 2000;
                let h = (b - a) / m as f64;
                let f = |t: f64| {
                    let p = [0, 1, 2].map(|k| orig[k] + d[k] * t);
                    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
                };
                let mut s = f(a) + f(b);
                for i in 1..m {
                    s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
                }
                want += s * h / 3.0 / dr;
            }
            let got = img[(py * n + px) as usize][0] as f64;
            if want > 0.0 {
                worst = worst.max((got - want).abs() / want);
            }
        }
    }
    assert!(r0 > 0.0 && r1 > r0);
    assert!(worst < 1e-3, "radial field relative error {worst:.2e}");
}

#[test]
fn cartesian_option_keeps_the_coordinate_box() {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = cf_sphere_file(
        dir.path(),
        "box.nc",
        &["shell", "--nlat", "6", "--nlon", "12", "--ndepth", "4"],
    ) else {
        return;
    };
    let opts = LoadOptions {
        cartesian: true,
        ..LoadOptions::default()
    };
    let v = load_volume_with(&path, &opts).unwrap();
    assert_eq!(v.geometry.name(), "cartesian");
    assert_eq!(v.dims, [12, 6, 4]);
    let text = v.to_string();
    assert!(text.contains("cartesian 12x6x4"), "{text}");
    let s = load_volume(&path).unwrap().to_string();
    assert!(
        s.contains("spherical") && s.contains("radius 3480–6371 km"),
        "{s}"
    );
}

#[test]
fn bad_coordinates_are_one_line_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let Some(no_units) = cf_sphere_file(
        dir.path(),
        "nounits.nc",
        &[
            "shell",
            "--no-units",
            "--nlat",
            "4",
            "--nlon",
            "8",
            "--ndepth",
            "3",
        ],
    ) else {
        return;
    };
    let e = load_volume(&no_units).unwrap_err().to_string();
    assert!(
        e.contains("nounits.nc") && e.contains("'depth' has no units"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1);
    let deep = cf_sphere_file(
        dir.path(),
        "deep.nc",
        &[
            "shell",
            "--depth-bottom",
            "7000",
            "--nlat",
            "4",
            "--nlon",
            "8",
            "--ndepth",
            "3",
        ],
    )
    .unwrap();
    let e = load_volume(&deep).unwrap_err().to_string();
    assert!(
        e.contains("deep.nc") && e.contains("deeper than the planet"),
        "{e}"
    );
    // The same file with a larger planet loads.
    let opts = LoadOptions {
        planet_radius: Some(8000.0),
        ..LoadOptions::default()
    };
    assert!(load_volume_with(&deep, &opts).is_ok());
}

#[test]
fn stretched_ocean_levels_render_in_their_true_geometry() {
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = cf_sphere_file(
        dir.path(),
        "ocean.nc",
        &["ocean", "--ndepth", "9", "--nlat", "2"],
    ) else {
        return;
    };
    let v = load_volume(&path).unwrap();
    let Geometry::Rectilinear(axes) = &v.geometry else {
        panic!("expected rectilinear, got {}", v.geometry.name())
    };
    // Depths 5, 15, 45, ..., 495, 645 m: cells reach half a spacing beyond the ends.
    assert_eq!((axes[2].lo, axes[2].hi), (0.0, 645.0 + 75.0));
    let b = v.bounds();
    // Seen along x: each pixel integrates value = depth over the box's x extent.
    let (w, h) = (20u32, 120u32);
    let mut o = VolumeRenderOptions::new(
        Camera::axis(Axis::X, &b),
        TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
    );
    o.width = w;
    o.height = h;
    o.step = 0.25;
    o.early_exit = 0.0;
    let (img, path_taken) = render(&v, &o);
    assert!(
        matches!(path_taken, RenderPath::Mapped { .. }),
        "{path_taken:?}"
    );
    o.precision = Precision::F64;
    let cpu = hdrvis::render::cpu_reference::render_volume_f64(&v, &o).unwrap();
    let voxel = 10.0; // the smallest spacing (depth 5 to 15 m)
    let (lx, z_hi) = (b.hi[0] - b.lo[0], b.hi[2]);
    let mut checked = 0;
    for py in 0..h {
        let z = z_hi - (py as f64 + 0.5) / h as f64 * (b.hi[2] - b.lo[2]);
        if !(5.0..=645.0).contains(&z) {
            continue;
        }
        let want = z * lx / voxel;
        let i = (py * w + w / 2) as usize;
        let got = img[i][0] as f64;
        assert!(
            (got - want).abs() <= 1e-3 * want,
            "z {z}: GPU {got} want {want}"
        );
        assert!(
            (cpu[i][0] - want).abs() <= 1e-9 * want,
            "z {z}: CPU {} want {want}",
            cpu[i][0]
        );
        checked += 1;
    }
    assert!(checked > 80, "{checked}");
}

#[test]
fn scripts_print_render_and_info_reports_a_shell() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let Some(_) = cf_sphere_file(
        d,
        "shell.nc",
        &["shell", "--nlat", "18", "--nlon", "36", "--ndepth", "6"],
    ) else {
        return;
    };
    let script = r#"
        let v = load_volume("shell.nc");
        print(v);
        print(v.geometry);
        let tf = tf_emission_absorption(1.0, 0.0);
        let img = render_volume(v, #{ tf: tf, camera: camera_geo(30.0, 45.0, 3.0), width: 48, height: 48 });
        save_exr(img, "geo.exr");
        let top = render_volume(v, #{ tf: tf, camera: camera_axis("z"), width: 40 });
        print(`${top.width}x${top.height}`);
        let flat = load_volume("shell.nc", #{ geometry: "cartesian" });
        print(flat.geometry);
    "#;
    std::fs::write(d.join("s.rhai"), script).unwrap();
    let (code, stdout, stderr) = crate::cli::hdrvis(&["run", "s.rhai", "-o", "o"], d);
    assert_eq!(code, 0, "{stderr}");
    let lines: Vec<&str> = stdout
        .lines()
        .filter(|l| !l.starts_with("wrote "))
        .collect();
    assert!(
        lines[0].starts_with("Volume \"dvs\" spherical 36x18x6, units percent"),
        "{stdout}"
    );
    assert!(
        lines[0].contains("latitude -90° to 90°") && lines[0].contains("longitude all round"),
        "{stdout}"
    );
    assert_eq!(lines[1], "spherical");
    assert_eq!(lines[2], "40x40", "the axis view of a shell is square");
    assert_eq!(lines[3], "cartesian");
    let img = hdrvis::io::exr::read_exr(&d.join("o/geo.exr")).unwrap();
    // The planet fills the middle of the view and not the corners.
    let at = |x: u32, y: u32| img.pixels[(y * img.width + x) as usize][0];
    assert!(
        at(24, 24) > 1.0 && at(0, 0) == 0.0,
        "{} {}",
        at(24, 24),
        at(0, 0)
    );

    let (code, out, err) = crate::cli::hdrvis(&["info", "shell.nc"], d);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains(
            "geometry: spherical: radius 3480–6371 km (from depth; planet radius 6371 km)"
        ),
        "{out}"
    );
    // Opening it as bricks is refused with what to do.
    std::fs::write(d.join("b.rhai"), r#"open_volume("shell.nc");"#).unwrap();
    let (code, _, err) = crate::cli::hdrvis(&["run", "b.rhai", "-o", "o"], d);
    assert_ne!(code, 0);
    let first = err.lines().next().unwrap_or("");
    assert!(
        first.contains("geographic coordinates") && first.contains("load_volume"),
        "{err}"
    );
}

#[test]
fn preintegrated_shaded_lut_renders_match_the_f64_reference() {
    use hdrvis::model::{LutTransfer, Scale};
    use hdrvis::render::{Shading, TfSampling};
    let dir = tempfile::tempdir().unwrap();
    let Some(path) = cf_sphere_file(
        dir.path(),
        "f.nc",
        &["lonfield", "--nlat", "18", "--nlon", "36", "--ndepth", "6"],
    ) else {
        return;
    };
    let v = load_volume(&path).unwrap();
    let tf = TransferFunction::Lut(LutTransfer {
        scale: Scale::Log10,
        colormap: "viridis".into(),
        emission: vec![[0.0, 0.0], [1.0, 1.0]],
        opacity: vec![[0.0, -2.0], [1.0, -0.5]],
        ..Default::default()
    });
    for (sampling, shading) in [
        (TfSampling::Point, None),
        (TfSampling::PreIntegrated, None),
        (TfSampling::Point, Some(Shading::default())),
    ] {
        let mut o = VolumeRenderOptions::new(
            Camera::orbit(&v.bounds(), 40.0, 30.0, 35.0).unwrap(),
            tf.clone(),
        );
        o.width = 40;
        o.height = 40;
        o.tf_sampling = sampling;
        o.shading = shading;
        o.jitter = true;
        let (gpu, _) = render(&v, &o);
        let cpu = hdrvis::render::cpu_reference::render_volume_f64(&v, &o).unwrap();
        let peak = cpu
            .iter()
            .map(|p| p[0].max(p[1]).max(p[2]))
            .fold(0.0, f64::max);
        let worst = gpu
            .iter()
            .zip(&cpu)
            .map(|(g, c)| {
                (0..3)
                    .map(|k| (g[k] as f64 - c[k]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        assert!(
            peak > 0.05 && worst < 2e-3 * peak,
            "{sampling:?} {shading:?}: {worst:.2e} of peak {peak:.3}"
        );
    }
}

#[test]
fn bad_geographic_files_fail_in_one_line_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let small = ["--nlat", "4", "--nlon", "8", "--ndepth", "3"];
    let cases: [(&str, &[&str], &str); 4] = [
        ("lat.nc", &["--bad-lat"], "beyond ±90"),
        ("dup.nc", &["--dup-depth"], "duplicate coordinates"),
        ("units.nc", &["--no-units"], "has no units"),
        (
            "deep.nc",
            &["--depth-bottom", "9000"],
            "deeper than the planet",
        ),
    ];
    for (name, extra, needle) in cases {
        let mut args = vec!["shell"];
        args.extend_from_slice(&small);
        args.extend_from_slice(extra);
        let Some(_) = cf_sphere_file(d, name, &args) else {
            return;
        };
        let script = format!(
            "let v = load_volume(\"{name}\");\nsave_exr(render_volume(v, #{{ tf: tf_emission_absorption(1.0, 0.0), width: 8, height: 8 }}), \"x.exr\");"
        );
        std::fs::write(d.join("bad.rhai"), script).unwrap();
        let (code, _, err) = crate::cli::hdrvis(&["run", "bad.rhai", "-o", "out"], d);
        assert_ne!(code, 0, "{name}");
        let first = err.lines().next().unwrap_or("");
        assert!(
            first.contains(name) && first.contains(needle),
            "{name}: {err}"
        );
        assert!(
            first.contains("dvs") || first.contains("depth") || first.contains("latitude"),
            "{err}"
        );
        assert!(
            !d.join("out/x.exr").exists(),
            "{name}: an output was written"
        );
        let (code, _, err) = crate::cli::hdrvis(&["info", name], d);
        assert_ne!(code, 0, "info {name}");
        assert!(
            err.trim().lines().count() == 1 && err.contains(needle),
            "info {name}: {err}"
        );
    }
}
