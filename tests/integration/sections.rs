//! Looking inside volumes: a great-circle section of a CF model written by xarray against its
//! closed form, drawn with interference fringes (the fringe at each node against
//! (1 + cos 2πν·value)/2), saved by `save_grid` and read back by xarray, netCDF4 and `load_grid`;
//! and the one-line errors of bad sections, slices and grid files.

use crate::cli::{hdrvis, python_check};
use crate::common::cf_sphere_file;
use crate::common::{at_nodes, renderer};
use hdrvis::datasets::load_volume;
use hdrvis::model::section::{great_circle_section, SectionSpec};
use hdrvis::model::{Grid, Missing};
use hdrvis::render::surface::{fringe_f64, SurfaceOptions, SurfaceRenderer};
use std::path::Path;

const SECTION: &str =
    "#{ from: [10.0, -40.0], to: [50.0, 60.0], depth: [100.0, 2800.0], n: [41, 28] }";

fn spec() -> SectionSpec {
    SectionSpec {
        from: [10.0, -40.0],
        to: [50.0, 60.0],
        depth: [100.0, 2800.0],
        n: [41, 28],
        missing: Missing::Strict,
    }
}

/// The section's fringes on every backend: depth runs downward, so in map view pixel (i, r)
/// shows node (i, r) — the top row is the shallowest depth — whose fringe is
/// (1 + cos 2πν·value)/2.
fn check_fringes(g: &Grid, nu: f64) {
    let values = g.property("dvs").unwrap();
    for backend in crate::common::backends() {
        let r = SurfaceRenderer::new(renderer(backend).context().clone());
        let o = SurfaceOptions {
            nu: vec![nu],
            ..Default::default()
        };
        let img = r.render(g, &at_nodes(g, &o)).unwrap().remove(0);
        assert_eq!(img.meta("map_y_direction"), Some("down"));
        let fringe = &img
            .extra_channels
            .iter()
            .find(|(n, _)| n == "fringe")
            .expect("a fringe channel")
            .1;
        for row in 0..g.ny() {
            for i in 0..g.nx() {
                let node = row * g.nx() + i;
                let want = fringe_f64(nu, values[node]);
                let got = fringe[row * g.nx() + i] as f64;
                assert!(
                    (got - want).abs() < 1e-5,
                    "{backend:?} node {node}: {got} vs {want}"
                );
            }
        }
    }
}

fn write_f64(path: &Path, shape: &[usize], data: &[f64]) -> String {
    hdrvis::datasets::npy::write_npy::<f64>(path, shape, data).unwrap();
    path.display().to_string()
}

#[test]
fn a_section_with_fringes_saves_as_cf_netcdf_that_xarray_and_load_grid_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // value = 6371 − depth (km): linear in depth, so every node has a closed form.
    let Some(model) = cf_sphere_file(d, "model.nc", &["radial"]) else {
        return;
    };
    let script = format!(
        "let s = section(load_volume(\"model.nc\"), {SECTION});\nsave_grid(s, \"section.nc\");\nprint(s.nx);"
    );
    std::fs::write(d.join("s.rhai"), script).unwrap();
    let (code, out, err) = hdrvis(&["run", "s.rhai", "-o", "out"], d);
    assert_eq!(code, 0, "{out}{err}");
    let g = great_circle_section(&load_volume(&model).unwrap(), &spec()).unwrap();
    let (values, depth) = (g.property("dvs").unwrap(), &g.y().values);
    for (k, v) in values.iter().enumerate() {
        let want = 6371.0 - depth[k / g.nx()];
        assert!(((v - want) / want).abs() < 1e-5, "node {k}: {v} vs {want}");
    }
    check_fringes(&g, 0.01);

    let saved = d.join("out/section.nc");
    let back = hdrvis::datasets::load_grid(&saved, None).unwrap();
    assert_eq!(back.property("dvs").unwrap(), values);
    assert_eq!(back.x().values, g.x().values);
    assert_eq!(back.y().values, g.y().values);
    assert_eq!(
        (back.x().name.as_str(), back.y().name.as_str()),
        ("distance", "depth")
    );
    assert_eq!((back.x().units.as_str(), back.units(0)), ("km", "percent"));
    // The depth axis comes back as a depth (drawn downward), the columns' latitude and longitude
    // as properties, exactly.
    assert!(back.y_down() && g.y_down());
    assert_eq!(back.y().units, "km");
    for name in ["latitude", "longitude"] {
        assert_eq!(
            back.property(name).unwrap(),
            g.property(name).unwrap(),
            "{name}"
        );
    }

    let (nx, ny) = (g.nx(), g.ny());
    let expect = write_f64(&d.join("v.npy"), &[ny, nx], values);
    let coord = |name: &str, c: &[f64]| {
        format!(
            "{name}={}",
            write_f64(&d.join(format!("{name}.npy")), &[c.len()], c)
        )
    };
    let aux = |name: &str| {
        let column: Vec<f64> = g.property(name).unwrap()[..nx].to_vec();
        format!(
            "{name}:distance={}",
            write_f64(&d.join(format!("{name}.npy")), &[nx], &column)
        )
    };
    let (c_depth, c_dist) = (
        coord("depth", &g.y().values),
        coord("distance", &g.x().values),
    );
    let (lat, lon) = (aux("latitude"), aux("longitude"));
    let args = [
        saved.to_str().unwrap(),
        "--var",
        "dvs",
        "--expect",
        &expect,
        "--units",
        "percent",
        "--coord",
        &c_depth,
        "--coord",
        &c_dist,
        "--aux",
        &lat,
        "--aux",
        &lon,
        "--coord-attr",
        "depth:positive=down",
        "--coord-attr",
        "depth:units=km",
        "--rtol",
        "0",
        "--atol",
        "0",
    ];
    if let Some(report) = python_check("check_netcdf.py", &args) {
        assert!(report.starts_with("exit 0"), "{report}");
    }
}

#[test]
fn bad_sections_slices_and_grid_files_are_one_line_errors_writing_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let small = ["shell", "--nlat", "6", "--nlon", "12", "--ndepth", "3"];
    let Some(_) = cf_sphere_file(d, "shell.nc", &small) else {
        return;
    };
    let shell = "load_volume(\"shell.nc\")";
    let cases = [
        (
            format!("section({shell}, #{{ from: [10.0, 20.0], to: [10.0, 20.0] }})"),
            "the same point",
        ),
        (
            format!("section({shell}, #{{ from: [10.0, 20.0], to: [-10.0, -160.0] }})"),
            "antipodal",
        ),
        (
            format!("section({shell}, #{{ from: [0, 0], to: [0, 90], depth: [0, 3000] }})"),
            "section depth: [0, 3000] km reaches outside the volume",
        ),
        (
            format!("section({shell}, #{{ from: [0, 0], to: [0, 90], n: [0, 5] }})"),
            "section n: [0, 5]",
        ),
        (
            format!("section({shell}, #{{ from: [0, 0], to: [0, 90], colour: 1 }})"),
            "unknown option colour",
        ),
        (
            "section(generate_mantle(#{ n: 4 }), #{ from: [0, 0], to: [0, 90] })".into(),
            "cartesian volume (a box)",
        ),
        (
            format!("slice({shell}, #{{ axis: \"x\", at: 0.0 }})"),
            "spherical volume; slices are planes of boxes",
        ),
        (
            "slice(generate_mantle(#{ n: 4 }), #{ axis: \"z\", at: 2.0 })".into(),
            "slice at: 2 lies outside the volume",
        ),
        (
            "save_grid(slice(generate_mantle(#{ n: 4 }), #{ axis: \"z\", at: 0.0 }), \"g.png\")"
                .into(),
            "expected a NetCDF file name",
        ),
    ];
    for (call, needle) in cases {
        let script = format!("let g = {call};\nsave_grid(g, \"g.nc\");\n");
        std::fs::write(d.join("bad.rhai"), &script).unwrap();
        let (code, _, err) = hdrvis(&["run", "bad.rhai", "-o", "out"], d);
        assert_ne!(code, 0, "{call}");
        let first = err.lines().next().unwrap_or("");
        assert!(first.contains(needle), "{call}: {err}");
        assert!(
            !d.join("out/g.nc").exists() && !d.join("out/g.png").exists(),
            "{call}"
        );
    }
}

/// `missing: "renormalise"` in a render: the f64 CPU reference and the mapped GPU ray caster (the
/// paths that take it) of a constant field with one missing voxel see the constant everywhere,
/// so their images equal the whole field's; the strict rule loses the hole's 2×2×2
/// neighbourhood. Bricks refuse it in one line.
#[test]
fn a_renormalised_render_of_a_constant_field_with_a_hole_is_the_whole_field() {
    use hdrvis::model::{Axis, Camera, TransferFunction, Volume};
    use hdrvis::render::{Precision, RenderPath, VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let clean = Volume::from_fn("c", [12, 12, 24], |_, _, _| 1.0).unwrap();
    let mut holed = clean.clone();
    let hole = holed.index(5, 6, 10);
    holed.data[hole] = f32::NAN;
    let tf = TransferFunction::emission_absorption(1.0, 0.0).unwrap();
    let mut o = VolumeRenderOptions::new(Camera::axis(Axis::Z, &clean.bounds()), tf);
    // Pixel centres off the voxel centres: no sample has all its weight on the hole.
    (o.width, o.height, o.early_exit) = (25, 25, 0.0);
    o.precision = Precision::F64;
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    let render = |v: &Volume, o: &VolumeRenderOptions| {
        let r = session
            .render_volume_detailed(&VolumeSource::Memory(Arc::new(v.clone())), o)
            .unwrap_or_else(|e| panic!("{e}"));
        (r.image.pixels.clone(), r.path)
    };
    let (whole, _) = render(&clean, &o);
    let (strict, _) = render(&holed, &o);
    o.missing = Missing::Renormalise;
    let (renorm, path) = render(&holed, &o);
    assert_eq!(path, RenderPath::F64Cpu);
    let mut lost = 0;
    for k in 0..whole.len() {
        assert!(
            (renorm[k][0] - whole[k][0]).abs() < 1e-6 * whole[k][0],
            "pixel {k}"
        );
        if (strict[k][0] - whole[k][0]).abs() > 0.5 {
            lost += 1;
        }
    }
    // The rays through the hole's neighbourhood (two voxels wide: about 4 pixels a side).
    assert!((4..=36).contains(&lost), "{lost} pixels lost emission");
    o.precision = Precision::F32;
    let (gpu, path) = render(&holed, &o);
    assert_eq!(path, RenderPath::Mapped { skipping: false });
    for k in 0..whole.len() {
        assert!(
            (gpu[k][0] - whole[k][0]).abs() < 1e-5 * whole[k][0],
            "pixel {k}: {} against {}",
            gpu[k][0],
            whole[k][0]
        );
    }
    o.bricking.brick = Some(8);
    let e = session
        .render_volume(&VolumeSource::Memory(Arc::new(holed)), &o)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("brick: "), "{e}");
}

/// The mapped GPU ray caster renormalises as the f64 CPU reference does on a shell and on a box
/// with holes in a varying field (every 37th voxel missing; point-sampled and pre-integrated):
/// within 1e-4 relative RMS, the f32 ray caster's own distance from f64 on shells (the strict
/// rule would lose most of the picture).
#[test]
fn renormalised_gpu_renders_equal_the_f64_reference_on_shells_and_boxes() {
    use hdrvis::model::{Camera, Missing, TransferFunction, Volume};
    use hdrvis::render::cpu_reference::render_volume_f64;
    use hdrvis::render::{Precision, RenderPath, TfSampling, VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let holes = |v: &mut Volume| {
        let n = v.data.len();
        for k in (0..n).step_by(37) {
            v.data[k] = f32::NAN;
        }
        for (k, x) in v.data.iter_mut().enumerate() {
            if x.is_finite() {
                *x = 1.0 + 0.5 * ((k % 17) as f32 / 17.0);
            }
        }
    };
    let mut shell = constant_shell();
    holes(&mut shell);
    let mut boxed = Volume::from_fn("b", [20, 16, 12], |_, _, _| 1.0).unwrap();
    holes(&mut boxed);
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    let tf = TransferFunction::emission_absorption(0.02, 0.01).unwrap();
    for v in [shell, boxed] {
        let v = Arc::new(v);
        let camera = Camera::orbit(&v.bounds(), 35.0, 25.0, 30.0).unwrap();
        let mut o = VolumeRenderOptions::new(camera, tf.clone());
        (o.width, o.height, o.missing) = (40, 40, Missing::Renormalise);
        for sampling in [TfSampling::Point, TfSampling::PreIntegrated] {
            o.tf_sampling = sampling;
            o.precision = Precision::F32;
            let r = session
                .render_volume_detailed(&VolumeSource::Memory(v.clone()), &o)
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(r.path, RenderPath::Mapped { skipping: false });
            o.precision = Precision::F64;
            let want = render_volume_f64(&v, &o).unwrap();
            let (mut num, mut den) = (0.0, 0.0);
            for (g, w) in r.image.pixels.iter().zip(&want) {
                for c in 0..3 {
                    num += (g[c] as f64 - w[c]).powi(2);
                    den += w[c].powi(2);
                }
            }
            let rel = (num / den).sqrt();
            eprintln!("{} {sampling:?}: GPU against f64 {rel:.2e}", v.name);
            assert!(den > 0.0 && rel < 1e-4, "{} {sampling:?}: {rel:e}", v.name);
        }
    }
}

/// A constant global shell (radii 3480–6371 km, 4° cells), value 1.
fn constant_shell() -> hdrvis::model::Volume {
    use hdrvis::model::{CoordAxis, Geometry, SphericalGrid, Volume};
    let g = SphericalGrid {
        axis_of: [2, 1, 0],
        radius: CoordAxis::uniform_cells(3480.0, (6371.0 - 3480.0) / 8.0, 8),
        latitude: CoordAxis::uniform_cells(-90.0, 4.0, 45),
        longitude: CoordAxis::uniform_cells(-180.0, 4.0, 90),
        lon_wraps: true,
        planet_radius: 6371.0,
        length_unit: "km".into(),
        vertical: "depth".into(),
        rotated_pole: None,
    };
    Volume::new(
        "shell",
        [90, 45, 8],
        [1.0; 3],
        [0.0; 3],
        vec![1.0; 90 * 45 * 8],
    )
    .unwrap()
    .with_geometry(Geometry::Spherical(Box::new(g)))
    .unwrap()
}

/// The pixel a cut-away leaves at (x, y) in the view from above the pole.
type Expected<'a> = &'a dyn Fn(f64, f64) -> f64;

/// Cut-aways seen from above the North Pole (emission only, so a pixel is the length of its ray
/// inside what is left, in radial cells): `lon: [0, 180]` empties the half y > 0 and leaves the
/// chord elsewhere; the wedge `lat: [0, 90], lon: [0, 90]` leaves half the chord (the southern
/// half) where x, y > 0. GPU (mapped) within 1e-3, the f64 CPU reference within 1e-9.
#[test]
fn cut_away_shells_leave_the_chord_outside_the_cut() {
    use hdrvis::model::{Axis, Camera, Cut, TransferFunction};
    use hdrvis::render::cpu_reference::render_volume_f64;
    use hdrvis::render::{Precision, RenderPath, VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let v = constant_shell();
    let (r0, r1, dr) = (3480.0, 6371.0, (6371.0 - 3480.0) / 8.0);
    let n = 48u32;
    let chord = |b: f64| {
        let half = |r: f64| if b < r { (r * r - b * b).sqrt() } else { 0.0 };
        2.0 * (half(r1) - half(r0)) / dr
    };
    let half_plane = Cut {
        lon: Some([0.0, 180.0]),
        ..Default::default()
    };
    let wedge = Cut {
        lat: Some([0.0, 90.0]),
        lon: Some([0.0, 90.0]),
        ..Default::default()
    };
    let cases: [(Cut, Expected); 2] = [
        (half_plane, &|x, y| {
            if y > 0.0 {
                0.0
            } else {
                chord(x.hypot(y))
            }
        }),
        (wedge, &|x, y| {
            let c = chord(x.hypot(y));
            if x > 0.0 && y > 0.0 {
                0.5 * c
            } else {
                c
            }
        }),
    ];
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    let source = VolumeSource::Memory(Arc::new(v.clone()));
    for (cut, expect) in cases {
        let mut o = VolumeRenderOptions::new(
            Camera::axis(Axis::Z, &v.bounds()),
            TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
        );
        (o.width, o.height, o.step, o.early_exit) = (n, n, 0.5, 0.0);
        o.cut = Some(cut.clone());
        let r = session
            .render_volume_detailed(&source, &o)
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(matches!(r.path, RenderPath::Mapped { .. }), "{:?}", r.path);
        o.precision = Precision::F64;
        let cpu = render_volume_f64(&v, &o).unwrap();
        let (mut gpu_worst, mut cpu_worst) = (0.0f64, 0.0f64);
        for py in 0..n {
            for px in 0..n {
                let x = (2.0 * (px as f64 + 0.5) / n as f64 - 1.0) * r1;
                let y = (1.0 - 2.0 * (py as f64 + 0.5) / n as f64) * r1;
                let want = expect(x, y);
                let k = (py * n + px) as usize;
                let (g, c) = (r.image.pixels[k][0] as f64, cpu[k][0]);
                if want == 0.0 {
                    assert_eq!(
                        (g, c),
                        (0.0, 0.0),
                        "{cut:?}: pixel {px},{py} should be empty"
                    );
                    continue;
                }
                gpu_worst = gpu_worst.max((g - want).abs() / want);
                cpu_worst = cpu_worst.max((c - want).abs() / want);
            }
        }
        assert!(
            gpu_worst < 1e-3,
            "{cut:?}: GPU relative error {gpu_worst:.2e}"
        );
        assert!(
            cpu_worst < 1e-9,
            "{cut:?}: CPU f64 relative error {cpu_worst:.2e}"
        );
        eprintln!("{cut:?}: GPU {gpu_worst:.2e}, CPU f64 {cpu_worst:.2e}");
    }
    // A cut that removes everything, and one of a box, are one-line errors.
    let mut o = VolumeRenderOptions::new(
        Camera::axis(Axis::Z, &v.bounds()),
        TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
    );
    o.cut = Some(Cut {
        lat: Some([-90.0, 90.0]),
        ..Default::default()
    });
    let e = session.render_volume(&source, &o).unwrap_err().to_string();
    assert!(e.starts_with("cut: removes the whole volume"), "{e}");
    let boxed = hdrvis::model::Volume::from_fn("b", [4, 4, 4], |x, _, _| x).unwrap();
    o.cut = Some(Cut {
        lon: Some([0.0, 180.0]),
        ..Default::default()
    });
    let e = session
        .render_volume(&VolumeSource::Memory(Arc::new(boxed)), &o)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("cut: b is a box; its cut takes world ranges x, y, z"),
        "{e}"
    );
}

/// A constant box (regular, and rectilinear with the same cells) with the half x < mid cut away,
/// seen along z (emission only, so a pixel is its ray's length inside what is left, in voxels):
/// pixels over the removed half are 0, the rest the chord, on the f64 CPU reference within 1e-9
/// and on the GPU within 1e-5 of it; a cut removing everything is refused.
#[test]
fn cut_away_boxes_leave_the_chord_outside_the_cut() {
    use hdrvis::model::{Axis, Camera, CoordAxis, Cut, Geometry, TransferFunction, Volume};
    use hdrvis::render::cpu_reference::render_volume_f64;
    use hdrvis::render::{Precision, VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let regular = Volume::new("box", [8, 8, 6], [1.0; 3], [0.0; 3], vec![1.0; 384]).unwrap();
    let axes = [8, 8, 6].map(|n| CoordAxis::uniform_cells(0.0, 1.0, n));
    let rectilinear = Volume::new("rbox", [8, 8, 6], [1.0; 3], [0.0; 3], vec![1.0; 384])
        .unwrap()
        .with_geometry(Geometry::Rectilinear(Box::new(axes)))
        .unwrap();
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    let n = 16u32;
    for v in [regular, rectilinear] {
        let b = v.bounds();
        let mid = 0.5 * (b.lo[0] + b.hi[0]);
        let chord = b.hi[2] - b.lo[2];
        let mut o = VolumeRenderOptions::new(
            Camera::axis(Axis::Z, &b),
            TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
        );
        (o.width, o.height, o.step, o.early_exit) = (n, n, 0.5, 0.0);
        o.cut = Some(Cut {
            x: Some([b.lo[0] - 1.0, mid]),
            ..Default::default()
        });
        o.precision = Precision::F64;
        let source = VolumeSource::Memory(Arc::new(v.clone()));
        let img = session
            .render_volume(&source, &o)
            .unwrap_or_else(|e| panic!("{e}"));
        let cpu = render_volume_f64(&v, &o).unwrap();
        let mut worst = 0.0f64;
        for py in 0..n {
            for px in 0..n {
                let k = (py * n + px) as usize;
                let (got, reference) = (img.pixels[k][0] as f64, cpu[k][0]);
                if px < n / 2 {
                    assert_eq!((got, reference), (0.0, 0.0), "{}: pixel {px},{py}", v.name);
                } else {
                    worst = worst.max((reference - chord).abs() / chord);
                    assert!(
                        (got - chord).abs() / chord < 1e-6,
                        "{}: {got} vs {chord}",
                        v.name
                    );
                }
            }
        }
        assert!(
            worst < 1e-9,
            "{}: CPU f64 relative error {worst:.2e}",
            v.name
        );
        // The GPU (the mapped ray caster, regular boxes too) clips the same pieces in f32.
        o.precision = Precision::F32;
        let gpu = session
            .render_volume(&source, &o)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut gpu_worst = 0.0f64;
        for (k, (g, c)) in gpu.pixels.iter().zip(&cpu).enumerate() {
            let (g, c) = (g[0] as f64, c[0]);
            if c == 0.0 {
                assert_eq!(g, 0.0, "{}: GPU pixel {k}", v.name);
            } else {
                gpu_worst = gpu_worst.max((g - c).abs() / c);
            }
        }
        assert!(
            gpu_worst < 1e-5,
            "{}: GPU relative error {gpu_worst:.2e}",
            v.name
        );
        o.precision = Precision::F64;
        o.cut = Some(Cut {
            x: Some([b.lo[0], b.hi[0]]),
            ..Default::default()
        });
        let e = session.render_volume(&source, &o).unwrap_err().to_string();
        assert!(e.starts_with("cut: removes the whole volume"), "{e}");
    }
}

/// A constant 8 × 8 × 6 box seen along z (emission only: a pixel is its ray's length in what is
/// left) cut by planes through its centre (4, 4, 3): the plane with normal (1, 0, 1) removes
/// z ≥ 7 − x, leaving clamp(7 − x, 0, 6) of each ray; two planes with normals (±1, 0, 1) remove
/// the wedge z ≥ 3 + |x − 4|, leaving min(6, 3 + |x − 4|). The f64 CPU reference within 1e-9 of
/// these, the GPU (f32 mapped ray caster, and the f64 shader for the regular box) within 1e-5; a
/// plane that removes the whole box, a zero normal and four planes are one-line errors.
#[test]
fn plane_cuts_of_boxes_leave_the_chord_on_the_kept_side() {
    use hdrvis::model::{
        Axis, Camera, CoordAxis, Cut, CutPlane, Geometry, TransferFunction, Volume,
    };
    use hdrvis::render::cpu_reference::render_volume_f64;
    use hdrvis::render::{Precision, VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let regular = Volume::new("box", [8, 8, 6], [1.0; 3], [0.0; 3], vec![1.0; 384]).unwrap();
    let axes = [8, 8, 6].map(|n| CoordAxis::uniform_cells(0.0, 1.0, n));
    let rectilinear = Volume::new("rbox", [8, 8, 6], [1.0; 3], [0.0; 3], vec![1.0; 384])
        .unwrap()
        .with_geometry(Geometry::Rectilinear(Box::new(axes)))
        .unwrap();
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    let n = 16u32;
    let plane = |normal: [f64; 3]| CutPlane {
        point: [4.0, 4.0, 3.0],
        normal,
    };
    // Each cut with the length of the ray it keeps at x.
    type Kept = fn(f64) -> f64;
    let cases: [(Cut, Kept); 2] = [
        (
            Cut {
                planes: vec![plane([1.0, 0.0, 1.0])],
                ..Default::default()
            },
            |x| (7.0 - x).clamp(0.0, 6.0),
        ),
        (
            Cut {
                planes: vec![plane([1.0, 0.0, 1.0]), plane([-1.0, 0.0, 1.0])],
                ..Default::default()
            },
            |x| (3.0 + (x - 4.0).abs()).min(6.0),
        ),
    ];
    for v in [regular, rectilinear] {
        let source = VolumeSource::Memory(Arc::new(v.clone()));
        for (cut, kept) in &cases {
            let mut o = VolumeRenderOptions::new(
                Camera::axis(Axis::Z, &v.bounds()),
                TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
            );
            (o.width, o.height, o.step, o.early_exit) = (n, n, 0.5, 0.0);
            o.cut = Some(cut.clone());
            o.precision = Precision::F64;
            let cpu = render_volume_f64(&v, &o).unwrap();
            let expected = |k: usize| kept((k % n as usize) as f64 * 8.0 / n as f64 + 0.25);
            let worst = (0..cpu.len())
                .map(|k| (cpu[k][0] - expected(k)).abs() / 6.0)
                .fold(0.0, f64::max);
            eprintln!(
                "{} {} planes: CPU f64 {worst:.2e}",
                v.name,
                cut.planes.len()
            );
            assert!(worst < 1e-9, "{}: CPU f64 error {worst:.2e}", v.name);
            for precision in [Precision::F32, Precision::F64] {
                o.precision = precision;
                let r = session
                    .render_volume_detailed(&source, &o)
                    .unwrap_or_else(|e| panic!("{e}"));
                let worst = r
                    .image
                    .pixels
                    .iter()
                    .enumerate()
                    .map(|(k, p)| (p[0] as f64 - expected(k)).abs() / 6.0)
                    .fold(0.0, f64::max);
                eprintln!("  {:?}: {worst:.2e}", r.path);
                assert!(worst < 1e-5, "{} {:?}: error {worst:.2e}", v.name, r.path);
            }
        }
        let refused = |cut: Cut| {
            let mut o = VolumeRenderOptions::new(
                Camera::axis(Axis::Z, &v.bounds()),
                TransferFunction::emission_absorption(1.0, 0.0).unwrap(),
            );
            o.cut = Some(cut);
            session.render_volume(&source, &o).unwrap_err().to_string()
        };
        let e = refused(Cut {
            planes: vec![CutPlane {
                point: [0.0, 0.0, -1.0],
                normal: [0.0, 0.0, 1.0],
            }],
            ..Default::default()
        });
        assert!(e.starts_with("cut: removes the whole volume"), "{e}");
        let e = refused(Cut {
            planes: vec![plane([0.0; 3])],
            ..Default::default()
        });
        assert!(e.starts_with("cut plane: point [4.0, 4.0, 3.0], normal [0.0, 0.0, 0.0]; expected a finite point and a finite non-zero normal"), "{e}");
        let e = refused(Cut {
            planes: vec![plane([1.0, 0.0, 0.0]); 4],
            ..Default::default()
        });
        assert_eq!(e, "cut plane: 4 planes; expected at most 3");
    }
}

/// A varying field in a box — regular, and rectilinear on uneven axes — seen from an oblique
/// orbit with a quarter (two ranges) or a corner (an oblique plane and a range) cut away: the GPU's clipped render equals the f64 CPU
/// reference's within 1e-5 relative RMS, and the cut changes the image by far more than that.
#[test]
fn cut_away_boxes_on_the_gpu_match_the_f64_reference_from_an_oblique_view() {
    use hdrvis::bench::relative_rms;
    use hdrvis::model::{Camera, CoordAxis, Cut, CutPlane, Geometry, TransferFunction, Volume};
    use hdrvis::render::cpu_reference::render_volume_f64;
    use hdrvis::render::{Precision, VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let dims = [12, 10, 8];
    let field = |x: f64, y: f64, z: f64| 0.7 + 0.5 * (0.6 * x).sin() * (0.5 * y).cos() + 0.03 * z;
    let regular = Volume::from_fn("box", dims, field).unwrap();
    // Cells that widen along each axis: centres 0.5 i + 0.05 i², the same field at them.
    let uneven = |n: usize| {
        let centres: Vec<f64> = (0..n)
            .map(|i| 0.5 * i as f64 + 0.05 * (i * i) as f64)
            .collect();
        let bounds = (centres[0] - 0.25, centres[n - 1] + 0.5);
        CoordAxis::new(centres, Some(bounds), "axis").unwrap()
    };
    let axes = dims.map(uneven);
    let data: Vec<f32> = (0..dims[2])
        .flat_map(|k| (0..dims[1]).flat_map(move |j| (0..dims[0]).map(move |i| (i, j, k))))
        .map(|(i, j, k)| field(axes[0].centres[i], axes[1].centres[j], axes[2].centres[k]) as f32)
        .collect();
    let rectilinear = Volume::new("rbox", dims, [1.0; 3], [0.0; 3], data)
        .unwrap()
        .with_geometry(Geometry::Rectilinear(Box::new(axes.clone())))
        .unwrap();
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    for v in [regular, rectilinear] {
        let b = v.bounds();
        let mid = [0, 1, 2].map(|a| 0.5 * (b.lo[a] + b.hi[a]));
        let mut o = VolumeRenderOptions::new(
            Camera::orbit(&b, 35.0, 25.0, 30.0).unwrap(),
            TransferFunction::emission_absorption(1.0, 0.4).unwrap(),
        );
        (o.width, o.height, o.step, o.early_exit) = (48, 40, 0.25, 0.0);
        let source = VolumeSource::Memory(Arc::new(v.clone()));
        let uncut = render_volume_f64(&v, &o).unwrap();
        // A quarter by two ranges, and a corner by an oblique plane with one range.
        let quarter = Cut {
            x: Some([mid[0], b.hi[0] + 1.0]),
            y: Some([b.lo[1] - 1.0, mid[1]]),
            ..Default::default()
        };
        let corner = Cut {
            z: Some([b.lo[2] - 1.0, mid[2]]),
            planes: vec![CutPlane {
                point: mid,
                normal: [1.0, -0.6, 0.3],
            }],
            ..Default::default()
        };
        for cut in [quarter, corner] {
            o.cut = Some(cut);
            o.precision = Precision::F64;
            let reference = render_volume_f64(&v, &o).unwrap();
            o.precision = Precision::F32;
            let gpu = session
                .render_volume(&source, &o)
                .unwrap_or_else(|e| panic!("{e}"));
            let gpu: Vec<[f64; 4]> = gpu.pixels.iter().map(|p| p.map(f64::from)).collect();
            let (err, change) = (
                relative_rms(&gpu, &reference),
                relative_rms(&uncut, &reference),
            );
            eprintln!(
                "{}: GPU {err:.2e} from the f64 cut render, cut against uncut {change:.2e}",
                v.name
            );
            assert!(err < 1e-5, "{}: GPU relative RMS {err:.2e}", v.name);
            assert!(
                change > 0.05,
                "{}: the cut changed the image by {change:.2e}",
                v.name
            );
            // In f64 a regular box's cut runs where its uncut render would: the f64 GPU shader on
            // adapters with shader f64 (lavapipe has it), equal to the CPU reference to the f32
            // the image is stored in.
            o.precision = Precision::F64;
            let r = session.render_volume_detailed(&source, &o).unwrap();
            if v.is_regular() {
                assert_eq!(r.path, hdrvis::render::RenderPath::F64Gpu, "{}", v.name);
            }
            let f64s: Vec<[f64; 4]> = r.image.pixels.iter().map(|p| p.map(f64::from)).collect();
            let err = relative_rms(&f64s, &reference);
            eprintln!(
                "{}: {:?} {err:.2e} from the f64 CPU reference",
                v.name, r.path
            );
            assert!(err < 1e-7, "{}: f64 relative RMS {err:.2e}", v.name);
        }
    }
}

/// Cut faces drawn as opaque surfaces, against closed forms. A constant shell with the half
/// y < 0 cut away, seen along +y (from the removed side): where a ray meets the face in the shell
/// the pixel is the transfer function's emission over extinction (alpha 1); through the core it
/// meets no face and is the emission–absorption integral over the far half's chord. A box whose
/// value is linear across the face x = mid, seen along −x with the half x > mid removed: every
/// pixel is e/σ times the fringes 1 + cos(2πν·value), and likewise on an oblique plane's face.
/// GPU within 1e-3, f64 CPU within 1e-9; no faces without a cut, ν ≤ 0, one-line errors.
#[test]
fn cut_faces_show_the_field_as_an_opaque_surface() {
    use hdrvis::model::{Axis, Camera, Cut, CutFaces, DepthRings, TransferFunction, Volume};
    use hdrvis::render::cpu_reference::render_volume_f64;
    use hdrvis::render::{Precision, VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    let (ke, ka) = (1.0, 0.1);
    let tf = TransferFunction::emission_absorption(ke, ka).unwrap();
    let check = |v: &Volume, o: &VolumeRenderOptions, want: &dyn Fn(u32, u32) -> Option<f64>| {
        let img = session
            .render_volume(&VolumeSource::Memory(Arc::new(v.clone())), o)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut o64 = o.clone();
        o64.precision = Precision::F64;
        let cpu = render_volume_f64(v, &o64).unwrap();
        let (mut gpu_worst, mut cpu_worst, mut checked) = (0.0f64, 0.0f64, 0);
        for py in 0..o.height {
            for px in 0..o.width {
                let Some(w) = want(px, py) else { continue };
                let k = (py * o.width + px) as usize;
                gpu_worst = gpu_worst.max((img.pixels[k][0] as f64 - w).abs() / w.max(1.0));
                cpu_worst = cpu_worst.max((cpu[k][0] - w).abs() / w.max(1.0));
                checked += 1;
            }
        }
        assert!(checked > 100, "{checked} pixels checked");
        assert!(gpu_worst < 1e-3, "GPU error {gpu_worst:.2e}");
        assert!(cpu_worst < 1e-9, "CPU f64 error {cpu_worst:.2e}");
        eprintln!("cut faces: GPU {gpu_worst:.2e}, CPU f64 {cpu_worst:.2e} over {checked} pixels");
    };
    // The shell: faces on the plane y = 0 where the shell is, the far half's chord in the core.
    let shell = constant_shell();
    let shell_bounds = shell.bounds();
    let (r0, r1, dr) = (3480.0, 6371.0, (6371.0 - 3480.0) / 8.0);
    let n = 48u32;
    let mut o = VolumeRenderOptions::new(Camera::axis(Axis::Y, &shell.bounds()), tf.clone());
    (o.width, o.height, o.step) = (n, n, 0.5);
    o.cut = Some(Cut {
        lon: Some([180.0, 360.0]),
        ..Default::default()
    });
    // Rings at 1000 and 2000 km depth: black lines 1.5 px wide on the face.
    o.cut_faces = Some(CutFaces {
        nu: None,
        depth_rings: Some(DepthRings::Depths(vec![1000.0, 2000.0])),
    });
    let pixel = 2.0 * r1 / n as f64;
    check(&shell, &o, &|px, py| {
        let x = (2.0 * (px as f64 + 0.5) / n as f64 - 1.0) * r1;
        let z = (1.0 - 2.0 * (py as f64 + 0.5) / n as f64) * r1;
        let rho = x.hypot(z);
        if rho > r1 * (1.0 - 1e-3) || (rho - r0).abs() < 1e-3 * r1 {
            return None;
        }
        let ring = [r1 - 1000.0, r1 - 2000.0]
            .iter()
            .map(|r| (rho - r).abs() / pixel)
            .fold(f64::INFINITY, f64::min);
        if (ring - 0.75).abs() < 0.05 {
            return None;
        }
        if ring < 0.75 {
            return Some(0.0);
        }
        if rho > r0 {
            return Some(ke / ka);
        }
        let len = ((r1 * r1 - rho * rho).sqrt() - (r0 * r0 - rho * rho).sqrt()) / dr;
        Some(ke / ka * (1.0 - (-ka * len).exp()))
    });
    // The box: value 1 + y + z/2 across the face x = 8 (interpolated between voxel centres,
    // clamped outside them), fringes.
    let m = 16usize;
    let boxed = Volume::from_fn("ramp", [m, m, m], |_, y, z| 1.0 + y + 0.5 * z).unwrap();
    let nu = 0.3;
    let mut o = VolumeRenderOptions::new(Camera::axis(Axis::X, &boxed.bounds()), tf.clone());
    (o.width, o.height, o.step) = (64, 64, 0.5);
    o.cut = Some(Cut {
        x: Some([8.0, 20.0]),
        ..Default::default()
    });
    o.cut_faces = Some(CutFaces {
        nu: Some(nu),
        depth_rings: None,
    });
    check(&boxed, &o, &|px, py| {
        let y = 16.0 * (px as f64 + 0.5) / 64.0;
        let z = 16.0 * (1.0 - (py as f64 + 0.5) / 64.0);
        if !(0.5..=15.5).contains(&y) || !(0.5..=15.5).contains(&z) {
            return None;
        }
        let v = 1.0 + y + 0.5 * z;
        Some(ke / ka * (1.0 + (std::f64::consts::TAU * nu * v).cos()))
    });
    // An oblique plane's face: with (x − 8) + (z − 8)/2 ≥ 0 removed, the ray at (y, z) meets
    // the face at x = 8 − (z − 8)/2, where a field that also rises with x takes its value.
    let ramp_x =
        Volume::from_fn("ramp_x", [m, m, m], |x, y, z| 1.0 + 0.25 * x + y + 0.5 * z).unwrap();
    o.cut = Some(Cut {
        planes: vec![hdrvis::model::CutPlane {
            point: [8.0; 3],
            normal: [1.0, 0.0, 0.5],
        }],
        ..Default::default()
    });
    check(&ramp_x, &o, &|px, py| {
        let y = 16.0 * (px as f64 + 0.5) / 64.0;
        let z = 16.0 * (1.0 - (py as f64 + 0.5) / 64.0);
        if !(0.5..=15.5).contains(&y) || !(0.5..=15.5).contains(&z) {
            return None;
        }
        let v = 1.0 + 0.25 * (8.0 - 0.5 * (z - 8.0)) + y + 0.5 * z;
        Some(ke / ka * (1.0 + (std::f64::consts::TAU * nu * v).cos()))
    });
    // Faces without a cut, and fringes of no width, are refused in one line.
    let source = VolumeSource::Memory(Arc::new(boxed));
    o.cut = None;
    let e = session.render_volume(&source, &o).unwrap_err().to_string();
    assert!(
        e.starts_with("cut_faces: draws the faces a cut-away opens"),
        "{e}"
    );
    o.cut = Some(Cut {
        x: Some([8.0, 20.0]),
        ..Default::default()
    });
    o.cut_faces = Some(CutFaces {
        nu: Some(0.0),
        depth_rings: None,
    });
    let e = session.render_volume(&source, &o).unwrap_err().to_string();
    assert!(e.starts_with("cut_faces nu: expected fringes"), "{e}");
    assert_eq!(e.lines().count(), 1);
    // Rings are at depths of spherical volumes, inside the planet, four at most.
    o.cut_faces = Some(CutFaces {
        nu: None,
        depth_rings: Some(DepthRings::Earth),
    });
    let e = session.render_volume(&source, &o).unwrap_err().to_string();
    assert!(
        e.starts_with(
            "cut_faces depth_rings: rings are drawn at depths of spherical volumes; ramp is a box"
        ),
        "{e}"
    );
    let shell_source = VolumeSource::Memory(Arc::new(shell));
    let mut so = VolumeRenderOptions::new(Camera::axis(Axis::Y, &shell_bounds), tf.clone());
    so.cut = Some(Cut {
        lon: Some([180.0, 360.0]),
        ..Default::default()
    });
    for (depths, want) in [
        (
            vec![7000.0],
            "depth 7000 is not inside the planet (0 to 6371 km)",
        ),
        (vec![1.0; 5], "expected 1 to 4 depths, got 5"),
    ] {
        so.cut_faces = Some(CutFaces {
            nu: None,
            depth_rings: Some(DepthRings::Depths(depths)),
        });
        let e = session
            .render_volume(&shell_source, &so)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("cut_faces depth_rings: {want}")),
            "{e}"
        );
    }
}

/// Coastlines on a spherical volume's render: every pixel they change lies within a line width of
/// a coast point on the near hemisphere (projected by the render's camera at the outer radius),
/// coast points on the far side far from any near one are untouched, the Cape of Good Hope is
/// drawn in exactly the line's colour (its pixel fully covered); where a wedge is cut away the
/// outer surface is gone and so are its coasts (India), while the rest stay; a box refuses them
/// in one line.
#[test]
fn coastlines_lie_on_the_outer_surface_of_a_spherical_render() {
    use hdrvis::datasets::coastlines::{coastlines, CoastResolution};
    use hdrvis::model::{Camera, Cut, SphericalGrid, TransferFunction};
    use hdrvis::render::surface::CoastlineStyle;
    use hdrvis::render::{VolumeRenderOptions, VolumeSource};
    use std::sync::Arc;
    let session = crate::common::session(hdrvis::gpu::BackendChoice::Vulkan);
    let shell = Arc::new(constant_shell());
    let r1 = 6371.0;
    let camera = Camera::geo([0.0; 3], 0.0, 40.0, 3.0 * r1, 40.0).unwrap();
    let (w, h) = (160u32, 160u32);
    let mut o = VolumeRenderOptions::new(
        camera,
        TransferFunction::emission_absorption(0.2, 0.05).unwrap(),
    );
    (o.width, o.height) = (w, h);
    let source = VolumeSource::Memory(shell.clone());
    let plain = session.render_volume(&source, &o).unwrap();
    let style = CoastlineStyle {
        colour: "red".into(),
        linear: [1.0, 0.0, 0.0],
        width: 3.0,
        resolution: Some(CoastResolution::Coarse),
    };
    o.coastlines = Some(style);
    let lined = session.render_volume(&source, &o).unwrap();
    assert!(lined
        .meta("coastlines")
        .is_some_and(|m| m.contains("Natural Earth")));
    let changed = |img: &hdrvis::model::HdrImage| -> Vec<(f64, f64)> {
        (0..(w * h) as usize)
            .filter(|&k| img.pixels[k] != plain.pixels[k])
            .map(|k| ((k as u32 % w) as f64 + 0.5, (k as u32 / w) as f64 + 0.5))
            .collect()
    };
    let eye = camera.eye;
    let points: Vec<[f64; 2]> = coastlines(CoastResolution::Coarse)
        .iter()
        .flatten()
        .copied()
        .collect();
    let world = |p: &[f64; 2]| SphericalGrid::to_world(r1, p[1], p[0]);
    let faces = |p: &[f64; 2]| {
        let q = world(p);
        (0..3).map(|a| q[a] * (eye[a] - q[a])).sum::<f64>() > 0.0
    };
    let near: Vec<[f64; 2]> = points
        .iter()
        .filter(|p| faces(p))
        .filter_map(|p| camera.project(world(p), w, h))
        .collect();
    let close = |set: &[(f64, f64)], x: f64, y: f64, r: f64| {
        set.iter().any(|&(a, b)| (a - x).hypot(b - y) <= r)
    };
    let drawn = changed(&lined);
    assert!(drawn.len() > 200, "{} pixels drawn", drawn.len());
    // Pieces of 0.5° between the points: a pixel may lie between two of them.
    let near_pixels: Vec<(f64, f64)> = near.iter().map(|p| (p[0], p[1])).collect();
    for &(x, y) in &drawn {
        assert!(
            close(&near_pixels, x, y, 6.0),
            "pixel ({x}, {y}) is not on a near-side coast"
        );
    }
    let mut far_checked = 0;
    for p in points.iter().filter(|p| !faces(p)) {
        let Some([x, y]) = camera.project(world(p), w, h) else {
            continue;
        };
        if !close(&near_pixels, x, y, 8.0) {
            far_checked += 1;
            assert!(!close(&drawn, x, y, 1.0), "far-side {p:?} drawn");
        }
    }
    assert!(far_checked > 20, "{far_checked} far-side points checked");
    let cape = camera.project(world(&[18.47, -34.36]), w, h).unwrap();
    let k = (cape[1] as u32 * w + cape[0] as u32) as usize;
    assert_eq!(&lined.pixels[k][..3], &[1.0, 0.0, 0.0], "the Cape's pixel");
    // A wedge cut away over India: its coast goes with the surface, Africa's stays.
    o.cut = Some(Cut {
        lat: Some([0.0, 90.0]),
        lon: Some([60.0, 100.0]),
        ..Default::default()
    });
    let cut = session.render_volume(&source, &o).unwrap();
    let cut_plain = {
        let mut p = o.clone();
        p.coastlines = None;
        session.render_volume(&source, &p).unwrap()
    };
    let india = camera.project(world(&[77.5, 8.1]), w, h).unwrap();
    let drawn_cut: Vec<(f64, f64)> = (0..(w * h) as usize)
        .filter(|&k| cut.pixels[k] != cut_plain.pixels[k])
        .map(|k| ((k as u32 % w) as f64 + 0.5, (k as u32 / w) as f64 + 0.5))
        .collect();
    assert!(close(&drawn, india[0], india[1], 2.0), "India drawn uncut");
    assert!(
        !close(&drawn_cut, india[0], india[1], 3.0),
        "India drawn on the cut"
    );
    assert!(close(&drawn_cut, cape[0], cape[1], 1.0), "the Cape lost");
    // A box has no outer sphere.
    let boxed = hdrvis::model::Volume::from_fn("b", [4, 4, 4], |x, _, _| x).unwrap();
    o.cut = None;
    let e = session
        .render_volume(&VolumeSource::Memory(Arc::new(boxed)), &o)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(
            "coastlines: lines are drawn on the outer surface of spherical volumes; b is a box"
        ),
        "{e}"
    );
}

/// Depth rings across a section's map: a ring at a node's depth blackens that row exactly (its
/// centre on the line: coverage 1), the rows beside it a quarter (centres 1 px from a 1.5-px
/// line), and leaves every other row as it was; the Earth's rings keep those within the
/// section's depths; a depth outside it and rings with coastlines
/// are one-line errors.
#[test]
fn depth_rings_cross_a_section_at_their_depths() {
    use hdrvis::model::DepthRings;
    let g = great_circle_section(&constant_shell(), &spec()).unwrap();
    let r = SurfaceRenderer::new(
        renderer(hdrvis::gpu::BackendChoice::Vulkan)
            .context()
            .clone(),
    );
    let plain = r
        .render(&g, &at_nodes(&g, &SurfaceOptions::default()))
        .unwrap()
        .remove(0);
    let (w, h) = (plain.width as usize, plain.height as usize);
    assert_eq!((w, h), (41, 28));
    let ringed = |rings: DepthRings| {
        let o = SurfaceOptions {
            depth_rings: Some(rings),
            ..Default::default()
        };
        r.render(&g, &at_nodes(&g, &o))
    };
    // Node row k lies at depth 100 + 100 k km.
    let img = ringed(DepthRings::Depths(vec![1000.0, 2000.0]))
        .unwrap()
        .remove(0);
    assert_eq!(img.meta("depth_rings"), Some("1000, 2000 km"));
    for row in 0..h {
        let cover = match row {
            9 | 19 => 1.0,
            8 | 10 | 18 | 20 => 0.25,
            _ => 0.0,
        };
        for x in 0..w {
            let (p, q) = (img.pixels[row * w + x], plain.pixels[row * w + x]);
            for c in 0..3 {
                let want = q[c] * (1.0 - cover);
                assert!(
                    (p[c] - want).abs() <= 1e-6 * q[c].abs().max(1e-3),
                    "row {row} x {x} channel {c}: {} vs {want}",
                    p[c]
                );
            }
        }
    }
    let earth = ringed(DepthRings::Earth).unwrap().remove(0);
    assert_eq!(earth.meta("depth_rings"), Some("410, 660 km"));
    let e = ringed(DepthRings::Depths(vec![3000.0]))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("depth_rings: depth 3000 is outside the section's depths 50 to 2850"),
        "{e}"
    );
    let o = SurfaceOptions {
        depth_rings: Some(DepthRings::Earth),
        coastlines: Some(Default::default()),
        ..Default::default()
    };
    let e = r.render(&g, &at_nodes(&g, &o)).unwrap_err().to_string();
    assert!(
        e.starts_with("coastlines:") || e.starts_with("depth_rings:"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 1);
}

/// `camera_orbit` frames what is drawn: a whole globe fills the frame (its silhouette spans
/// sin(fov/2) / 1.05 of the view's half-angle sine, 94.8 % of the height at fov 35°), where
/// framing its box (which circumscribes it by √3) left it at 53 %.
#[test]
fn camera_orbit_frames_a_whole_globe() {
    let dir = tempfile::tempdir().unwrap();
    let script = r#"
        let v = load_volume(generate("mantle", #{ n: 16, native: true }));
        let img = render_volume(v, #{ tf: tf_emission_absorption(1.0, 1.0),
                                      camera: camera_orbit(30.0, 20.0), width: 129, height: 129 });
        save_exr(img, "globe.exr");
    "#;
    std::fs::write(dir.path().join("g.rhai"), script).unwrap();
    let (rc, out, err) = hdrvis(&["run", "g.rhai", "--out", "o"], dir.path());
    assert_eq!(rc, 0, "{out} {err}");
    let img = hdrvis::io::exr::read_exr(&dir.path().join("o/globe.exr")).unwrap();
    let lit = |x: u32, y: u32| img.pixel(x, y).iter().take(3).any(|&c| c > 0.0);
    let rows: Vec<u32> = (0..img.height)
        .filter(|&y| (0..img.width).any(|x| lit(x, y)))
        .collect();
    let cols: Vec<u32> = (0..img.width)
        .filter(|&x| (0..img.height).any(|y| lit(x, y)))
        .collect();
    let half = 17.5f64.to_radians();
    let angle = (half.sin() / 1.05).asin();
    let expected = angle.tan() / half.tan() * img.height as f64;
    for (what, span) in [("rows", &rows), ("columns", &cols)] {
        let across = (span[span.len() - 1] - span[0] + 1) as f64;
        assert!(
            (across - expected).abs() <= 3.0,
            "{what}: the globe spans {across} px, expected {expected:.1}"
        );
    }
}
