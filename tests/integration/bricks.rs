//! Bricked rendering against the plain ray caster: the same image (bit for bit on the exact
//! filter) when bricked in core, with empty-space skipping, and out of core through a small brick
//! cache in several passes; a transfer-function change re-reads no brick; a memory-mapped `.npy` renders
//! like the loaded volume.

use crate::common::renderer;
use hdrvis::gpu::BackendChoice;
use hdrvis::model::bricks::BrickedVolume;
use hdrvis::model::{Axis, Camera, LutTransfer, Scale, TransferFunction, Volume};
use hdrvis::render::bricked::BrickedStats;
use hdrvis::render::session::RenderSession;
use hdrvis::render::{Bricking, FilterMode, Precision, VolumeRenderOptions, VolumeSource};
use std::sync::Arc;

/// Blobs over a zero floor, a NaN hole and a region of negative values: much of the volume is
/// transparent under a log10 transfer function with a transparent low end.
fn scene_volume() -> Volume {
    Volume::from_fn("bricks test", [70, 60, 50], |x, y, z| {
        let g = |cx: f64, cy: f64, cz: f64, s: f64, a: f64| {
            a * (-((x - cx).powi(2) + (y - cy).powi(2) + (z - cz).powi(2)) / (2.0 * s * s)).exp()
        };
        if (x - 60.0).abs() < 3.0 && (y - 10.0).abs() < 3.0 {
            return f64::NAN;
        }
        if z > 44.0 {
            return -1.0;
        }
        g(25.0, 30.0, 20.0, 6.0, 10.0)
            + g(50.0, 35.0, 30.0, 4.0, 0.5)
            + g(40.0, 15.0, 12.0, 3.0, 0.02)
    })
    .unwrap()
}

fn scene_tf(transparent_below: f64) -> TransferFunction {
    TransferFunction::Lut(LutTransfer {
        scale: Scale::Log10,
        domain: Some([1e-4, 10.0]),
        colormap: "inferno".into(),
        emission: vec![[0.0, -1.0], [1.0, 1.0]],
        opacity: vec![[0.0, -3.0], [1.0, -0.5]],
        transparent_below,
        ..Default::default()
    })
}

fn options(
    vol: &Volume,
    camera: Camera,
    tf: TransferFunction,
    filter: FilterMode,
) -> VolumeRenderOptions {
    let mut o = VolumeRenderOptions::new(camera, tf);
    o.width = 96;
    o.height = 80;
    o.step = 0.7;
    o.filter = filter;
    let _ = vol;
    o
}

/// A session of its own on the shared Vulkan context, so tests do not share cached results.
fn session() -> RenderSession {
    RenderSession::with_context(renderer(BackendChoice::Vulkan).context().clone(), 1 << 30)
}

fn plain(vol: &Volume, o: &VolumeRenderOptions) -> Vec<[f32; 4]> {
    let source = VolumeSource::Memory(Arc::new(vol.clone()));
    let r = session().render_volume_detailed(&source, o).unwrap();
    assert!(matches!(r.path, hdrvis::render::RenderPath::InCore { .. }));
    r.image.pixels.clone()
}

fn bricked_in(
    session: &RenderSession,
    bv: &Arc<BrickedVolume>,
    o: &VolumeRenderOptions,
    budget: Option<u64>,
    skip: bool,
) -> hdrvis::Result<(Vec<[f32; 4]>, BrickedStats)> {
    let mut o = o.clone();
    o.empty_space_skipping = skip;
    o.bricking = Bricking {
        memory_budget: budget,
        ..Default::default()
    };
    let r = session.render_volume_detailed(&VolumeSource::Bricked(bv.clone()), &o)?;
    Ok((
        r.image.pixels.clone(),
        r.bricks.clone().expect("bricked stats"),
    ))
}

fn bricked(
    bv: &Arc<BrickedVolume>,
    o: &VolumeRenderOptions,
    budget: Option<u64>,
    skip: bool,
) -> (Vec<[f32; 4]>, BrickedStats) {
    bricked_in(&session(), bv, o, budget, skip).unwrap()
}

/// How far renders that take the same samples, texels and weights may differ, relative to the
/// peak: not at all on a CPU rasterizer (lavapipe compiles both shaders alike), 1e-6 on a GPU,
/// whose compiler fuses multiplies and adds (FMA) differently in the bricked and plain shaders
/// (3.3e-7 seen on an NVIDIA H200).
fn same_samples_tolerance() -> f64 {
    if renderer(BackendChoice::Vulkan).context().info.device_type == wgpu::DeviceType::Cpu {
        0.0
    } else {
        1e-6
    }
}

/// Largest difference over all channels relative to the image's peak colour.
fn diff(a: &[[f32; 4]], b: &[[f32; 4]]) -> f64 {
    let peak = b
        .iter()
        .flat_map(|p| p[..3].iter().map(|&v| v as f64))
        .fold(0.0, f64::max);
    assert!(peak > 0.0, "empty image");
    a.iter()
        .zip(b)
        .flat_map(|(p, q)| (0..4).map(move |c| (p[c] as f64 - q[c] as f64).abs()))
        .fold(0.0, f64::max)
        / peak
}

fn cameras(vol: &Volume) -> Vec<(&'static str, Camera)> {
    let b = vol.bounds();
    vec![
        ("axis z", Camera::axis(Axis::Z, &b)),
        ("axis x", Camera::axis(Axis::X, &b)),
        ("orbit", Camera::orbit(&b, 35.0, 25.0, 30.0).unwrap()),
        (
            "inside",
            Camera::look_at(
                [30.0, 28.0, 22.0],
                [60.0, 40.0, 10.0],
                [0.0, 0.0, 1.0],
                70.0,
            )
            .unwrap(),
        ),
    ]
}

#[test]
fn bricked_and_skipped_renders_equal_the_plain_render() {
    let vol = scene_volume();
    let bv = Arc::new(BrickedVolume::from_volume(Arc::new(vol.clone()), 16).unwrap());
    let mut filters = vec![FilterMode::Exact, FilterMode::Auto];
    if renderer(BackendChoice::Vulkan)
        .context()
        .caps
        .float32_filterable
    {
        filters.push(FilterMode::Hardware);
    }
    for (name, cam) in cameras(&vol) {
        for &filter in &filters {
            let o = options(&vol, cam, scene_tf(0.35), filter);
            let reference = plain(&vol, &o);
            let (img, st) = bricked(&bv, &o, None, false);
            assert_eq!((st.passes, st.skipped), (1, 0));
            // The exact path takes the same samples, texels and weights and sums them alike;
            // the texture unit's filter sees atlas coordinates instead of volume ones and may
            // round its weights differently.
            let tol = if filter == FilterMode::Exact {
                same_samples_tolerance() + f64::MIN_POSITIVE
            } else {
                1e-3
            };
            let d = diff(&img, &reference);
            eprintln!("{name} {filter:?} bricked: {d}");
            assert!(d < tol, "{name} {filter:?} bricked: {d}");
            let (img, st) = bricked(&bv, &o, None, true);
            assert!(st.skipped > st.needed / 2, "{name}: {st:?}");
            let d = diff(&img, &reference);
            assert!(d < tol, "{name} {filter:?} skipped: {d}");
        }
    }
}

#[test]
fn out_of_core_renders_equal_the_plain_render() {
    let vol = scene_volume();
    let bv = Arc::new(BrickedVolume::from_volume(Arc::new(vol.clone()), 16).unwrap());
    let slot = bv.layout.stored_bytes();
    for (name, cam) in cameras(&vol) {
        let mut o = options(&vol, cam, scene_tf(0.0), FilterMode::Exact);
        let reference = plain(&vol, &o);
        // Room for the image buffers and 7 bricks of the 80: many passes.
        let fixed = 8 * 80 + 2 * 96 * 80 * 16 + 96 * 80 * 52 + (1 << 17);
        let (img, st) = bricked(&bv, &o, Some(fixed + 7 * slot + slot / 2), false);
        assert_eq!(st.capacity, 7);
        assert!(st.passes >= 80 / 7, "{name}: {st:?}");
        let d = diff(&img, &reference);
        assert!(
            d <= same_samples_tolerance(),
            "{name} out of core: {d} ({st:?})"
        );
        // With skipping and early termination on an opaque transfer function, and f16.
        o.tf = scene_tf(0.35);
        o.early_exit = 1e-2;
        o.precision = Precision::F16;
        let reference = plain(&vol, &o);
        let (img, st) = bricked(&bv, &o, Some(fixed + 7 * slot + slot / 2), true);
        assert!(st.skipped > 0 && st.passes > 1, "{name}: {st:?}");
        let d = diff(&img, &reference);
        assert!(d < 1e-3, "{name} out of core, skipped, f16: {d}");
    }
}

#[test]
fn a_transfer_function_change_rereads_no_brick() {
    let vol = scene_volume();
    let bv = Arc::new(BrickedVolume::from_volume(Arc::new(vol.clone()), 16).unwrap());
    let session = session();
    let cam = Camera::orbit(&vol.bounds(), 120.0, -20.0, 30.0).unwrap();
    let o1 = options(&vol, cam, scene_tf(0.6), FilterMode::Exact);
    let (_, s1) = bricked_in(&session, &bv, &o1, None, true).unwrap();
    let read = bv.bricks_read();
    assert_eq!(read, 80);
    let o2 = options(&vol, cam, scene_tf(0.1), FilterMode::Exact);
    let (img, s2) = bricked_in(&session, &bv, &o2, None, true).unwrap();
    assert_eq!(bv.bricks_read(), read, "bricks were read again");
    assert!(s2.skipped < s1.skipped, "{s1:?} {s2:?}");
    assert!(diff(&img, &plain(&vol, &o2)) < 1e-5);
}

#[test]
fn memory_mapped_npy_renders_like_the_loaded_volume() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("v.npy");
    let vol = scene_volume();
    hdrvis::datasets::npy::write_npy(&path, &[50, 60, 70], &vol.data).unwrap();
    let bv = Arc::new(hdrvis::datasets::bricked::open_bricked(&path, None, 32).unwrap());
    assert_eq!(bv.stats, vol.stats());
    let o = options(
        &vol,
        Camera::orbit(&vol.bounds(), 200.0, 40.0, 30.0).unwrap(),
        scene_tf(0.3),
        FilterMode::Exact,
    );
    let slot = bv.layout.stored_bytes();
    let fixed = 8 * 12 + 2 * 96 * 80 * 16 + 96 * 80 * 52 + (1 << 17);
    let (img, st) = bricked(&bv, &o, Some(fixed + 3 * slot), true);
    assert!(st.passes > 1, "{st:?}");
    // The bricked shader is compiled apart from the plain one, and a GPU's compiler may
    // contract their f32 arithmetic differently (NVIDIA's H100: 1.5e-5 after three passes).
    let d = diff(&img, &plain(&vol, &o));
    assert!(d < 3e-5, "out of core in {} passes: {d:.2e}", st.passes);
}

#[test]
fn a_budget_too_small_for_one_brick_is_a_one_line_error() {
    let vol = scene_volume();
    let bv = Arc::new(BrickedVolume::from_volume(Arc::new(vol), 16).unwrap());
    let cam = Camera::axis(Axis::Z, &bv.bounds());
    let mut o = options(&scene_volume(), cam, scene_tf(0.0), FilterMode::Exact);
    (o.width, o.height) = (512, 512);
    let err = bricked_in(&session(), &bv, &o, Some(1 << 20), true)
        .expect_err("1 MiB cannot hold a 512x512 image and a brick")
        .to_string();
    assert!(
        err.starts_with("memory_budget: 1 MiB is too small") && !err.contains('\n'),
        "{err}"
    );
}

#[test]
fn scripts_refuse_shading_on_the_bricked_path_and_shade_the_plain_one() {
    let dir = tempfile::tempdir().unwrap();
    let opts = hdrvis::script::ScriptOptions::new(dir.path().join("out"));
    let run = |extra: &str| {
        let src = format!(
            "let v = generate_mantle(#{{n: 24}});\n\
             let tf = tf_lut(#{{scale: \"log10\", colormap: \"viridis\"}});\n\
             render_volume(v, #{{tf: tf, width: 16, height: 16, shading: true{extra}}});"
        );
        hdrvis::script::run_script_source(&src, "t.rhai", dir.path(), &opts)
    };
    run("").expect("shading on the plain path");
    let err = run(", brick: 8").unwrap_err().to_string();
    let first = err.lines().next().unwrap();
    assert!(
        first.contains("Runtime error: shading:") && first.contains("bricked"),
        "{err}"
    );
}

/// A bricked and an out-of-core render go through the session like every render: their passes
/// show in `--stats` (the bricking, the GPU brick cache, the ray cast with what it did), and a
/// repeated bricked render is answered from the cache.
#[test]
fn bricked_and_out_of_core_renders_report_their_passes_and_repeat_from_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("s.rhai");
    std::fs::write(
        &script,
        r#"
let v = generate_mantle(#{n: 40, seed: 2});
let tf = tf_lut(#{scale: "symlog", linthresh: 0.01, colormap: "turbo", transparent_below: 0.3});
let o = #{tf: tf, camera: camera_orbit(30.0, 20.0), width: 32, height: 32, brick: 8};
let a = render_volume(v, o);
let b = render_volume(v, o);
o.memory_budget = 0.25;
save_exr(render_volume(v, o), "c.exr");
"#,
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(["run", "--stats", "--out"])
        .arg(dir.path().join("out"))
        .arg(&script)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with("pass ")).collect();
    let passes: Vec<String> = lines
        .iter()
        .map(|l| l.split(' ').take(3).collect::<Vec<_>>().join(" "))
        .collect();
    assert_eq!(
        passes,
        [
            "pass generate ran",
            "pass bricks ran",
            "pass brick-cache ran",
            "pass raycast ran",
            "pass raycast cached",
            "pass bricks cached",
            "pass brick-cache ran",
            "pass raycast ran",
            "pass save-exr ran",
        ],
        "{stdout}"
    );
    assert!(lines[1].contains("[125 bricks of 8³]"), "{}", lines[1]);
    assert!(lines[3].contains("[bricked 8³ skipping: "), "{}", lines[3]);
    assert!(lines[3].contains(" 1 pass]"), "{}", lines[3]);
    assert!(
        lines[7].contains("[out-of-core 8³ skipping: "),
        "{}",
        lines[7]
    );
    let passes: usize = lines[7]
        .rsplit(", ")
        .next()
        .and_then(|p| p.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{}", lines[7]));
    assert!(passes > 1, "{}", lines[7]);
}

/// The routing decisions of `render_volume`, each with the path it takes or the one-line error
/// that says what to do instead.
#[test]
fn render_volume_chooses_the_path_from_the_source_and_the_options() {
    let vol = Arc::new(scene_volume());
    let session = session();
    let cam = Camera::axis(Axis::Z, &vol.bounds());
    let o = options(&vol, cam, scene_tf(0.35), FilterMode::Exact);
    let memory = VolumeSource::Memory(vol.clone());
    let path_skipping = |source: &VolumeSource, b: Bricking, skipping: bool| {
        let mut o = o.clone();
        o.bricking = b;
        o.empty_space_skipping = skipping;
        session.render_volume_detailed(source, &o).map(|r| r.path)
    };
    let path = |source: &VolumeSource, b: Bricking| path_skipping(source, b, true);
    let bricked = |brick, skip| hdrvis::render::RenderPath::Bricked { brick, skip };
    let in_core = |skipping| hdrvis::render::RenderPath::InCore { skipping };
    // In memory and within the budget: the plain ray caster, skipping the empty space the
    // transfer function leaves (its lower 35 % is transparent), unless told not to.
    assert_eq!(path(&memory, Bricking::default()).unwrap(), in_core(true));
    assert_eq!(
        path_skipping(&memory, Bricking::default(), false).unwrap(),
        in_core(false)
    );
    // A budget that the volume (70·60·50 f32, 840 kB) and the image's buffers (246 kB) do not fit
    // sends it to bricks of the default edge, streamed out of core.
    let small = Bricking {
        memory_budget: Some(1_000_000),
        ..Default::default()
    };
    assert_eq!(path(&memory, small).unwrap(), bricked(32, true));
    let brick16 = Bricking {
        brick: Some(16),
        ..Default::default()
    };
    assert_eq!(
        path_skipping(&memory, brick16, false).unwrap(),
        bricked(16, false)
    );

    let bv = Arc::new(BrickedVolume::from_volume(vol.clone(), 16).unwrap());
    let opened = VolumeSource::Bricked(bv);
    assert_eq!(
        path(&opened, Bricking::default()).unwrap(),
        bricked(16, true)
    );
    let err = path(
        &opened,
        Bricking {
            brick: Some(8),
            ..Default::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert_eq!(
        err,
        "brick: bricks test was opened with bricks of 16; give brick: 8 to open_volume instead"
    );
    let mut f64_opts = o.clone();
    f64_opts.precision = Precision::F64;
    let err = session
        .render_volume(&opened, &f64_opts)
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("precision: f64 runs on the CPU reference"),
        "{err}"
    );
    let err = path(
        &memory,
        Bricking {
            level: 5,
            ..Default::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert_eq!(err, "level: expected 0 (full resolution) to 4, got 5");
}

/// A quick-look level renders a coarser copy, built once and then answered from the cache.
#[test]
fn a_level_renders_a_coarser_copy_built_once() {
    let vol = Arc::new(scene_volume());
    let session = session();
    let cam = Camera::axis(Axis::Z, &vol.bounds());
    let mut o = options(&vol, cam, scene_tf(0.0), FilterMode::Exact);
    o.bricking.level = 1;
    let source = VolumeSource::Memory(vol.clone());
    let first = session.render_volume_detailed(&source, &o).unwrap();
    assert!(matches!(
        first.path,
        hdrvis::render::RenderPath::InCore { .. }
    ));
    assert!(first
        .image
        .meta("dataset")
        .unwrap()
        .contains("(level 1) 35x30x25"));
    o.step = 0.5;
    session.render_volume(&source, &o).unwrap();
    let log = session.take_passes();
    let level: Vec<bool> = log
        .iter()
        .filter(|r| r.name == "level")
        .map(|r| r.is_cached())
        .collect();
    assert_eq!(level, [false, true], "{log:?}");
    // The coarse image is close to the full-resolution one (same bounds, half the voxels).
    o.bricking.level = 0;
    let full = session.render_volume(&source, &o).unwrap();
    let coarse = session.render_volume(&source, &{
        let mut c = o.clone();
        c.bricking.level = 1;
        c
    });
    let d = diff(&coarse.unwrap().pixels, &full.pixels);
    assert!(d > 0.0 && d < 0.5, "{d}");
}

/// A sample that falls on a voxel boundary beside a missing voxel is missing or not depending on
/// the last bit of its position (the missing voxel's weight is zero, but NaN times zero is NaN).
/// The bricked march places its samples and sums their contributions as the in-core march does
/// (f32: in blocks of 64 segments, also across jumps over empty bricks), so on the mantle's shell
/// edges the two agree bit for bit: bricked in core with skipping and out of core in several
/// passes, in f32 and f32c, at one and two samples per voxel.
#[test]
fn bricked_renders_of_the_mantle_equal_the_in_core_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let opts = hdrvis::script::ScriptOptions::new(dir.path().join("out"));
    let src = r#"
let v = generate_mantle(#{n: 65, field: "fluctuation"});
let tf = tf_lut(#{scale: "symlog", linthresh: 1e-3, domain: [-0.3, 0.45], colormap: "spectral",
   emission: [[0.0, -1.0], [0.45, -3.0], [0.55, -3.0], [1.0, -0.5]],
   opacity: [[0.0, -1.5], [0.4, -3.5], [0.6, -3.5], [1.0, -1.0]]});
for step in [1.0, 0.5] {
    for p in ["f32", "f32c"] {
        let name = p + "_" + step + ".exr";
        let o = #{tf: tf, camera: camera_orbit(35.0, 20.0, 25.0), width: 128, height: 128,
                  step: step, filter: "exact", precision: p};
        save_exr(render_volume(v, o), "plain_" + name);
        o.brick = 8;
        save_exr(render_volume(v, o), "bricked_" + name);
        o.brick = 16;
        o.memory_budget = 1.5;
        save_exr(render_volume(v, o), "out_of_core_" + name);
    }
}
"#;
    hdrvis::script::run_script_source(src, "t.rhai", dir.path(), &opts).unwrap();
    let read = |name: &str| hdrvis::io::exr::read_exr(&dir.path().join("out").join(name)).unwrap();
    for step in ["1.0", "0.5"] {
        for p in ["f32", "f32c"] {
            let plain = read(&format!("plain_{p}_{step}.exr")).pixels;
            for kind in ["bricked", "out_of_core"] {
                let img = read(&format!("{kind}_{p}_{step}.exr")).pixels;
                let d = diff(&img, &plain);
                assert!(
                    d <= same_samples_tolerance(),
                    "{kind} {p} step {step}: {d} of the peak"
                );
            }
        }
    }
}
