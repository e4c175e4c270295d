//! The pass graph runs only what a change calls for: counted passes for each kind of change,
//! through one session shared by several script runs (as the TUI and sweeps use it), and the
//! `--stats` lines and EXR `passes` metadata that report them.

use hdrvis::gpu::BackendChoice;
use hdrvis::render::passes::{count_ran, PassRecord};
use hdrvis::render::session::RenderSession;
use hdrvis::script::{run_script_source, ScriptOptions};
use std::path::Path;
use std::sync::Arc;

const VOLUME_SCENE: &str = r#"
let v = generate_mantle(#{n: 24, seed: 5});
let tf = tf_lut(#{scale: "symlog", linthresh: 0.01, colormap: param("cmap", "turbo"),
                  opacity: [[0.0, -3.0], [1.0, param("opacity", 0.0)]]});
let img = render_volume(v, #{tf: tf, camera: camera_orbit(param("azimuth", 30.0), 20.0),
                             width: 32, height: 32, tf_sampling: param("sampling", "point")});
let shown = tonemap(img, #{op: param("op", "reinhard"), exposure: param("ev", 0.0)});
save_exr(shown, "shown.exr");
"#;

fn run(
    source: &str,
    session: &Arc<RenderSession>,
    out: &Path,
    sets: &[(&str, &str)],
) -> Vec<PassRecord> {
    let mut opts = ScriptOptions::new(out);
    opts.progress = false;
    opts.session = Some(session.clone());
    opts.sets = sets
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    run_script_source(source, "scene.rhai", out, &opts)
        .unwrap_or_else(|e| panic!("{e}"))
        .passes
}

fn counts(passes: &[PassRecord], names: &[&str]) -> Vec<usize> {
    names.iter().map(|n| count_ran(passes, n)).collect()
}

#[test]
fn each_kind_of_change_reruns_only_its_dependants() {
    let dir = tempfile::tempdir().unwrap();
    let session = Arc::new(RenderSession::new(BackendChoice::Auto, 256 << 20));
    let names = ["generate", "upload", "raycast", "tonemap", "save-exr"];

    let first = run(VOLUME_SCENE, &session, dir.path(), &[]);
    assert_eq!(counts(&first, &names), [1, 1, 1, 1, 1], "{first:?}");

    // Exposure and operator: the post pass only.
    let ev = run(VOLUME_SCENE, &session, dir.path(), &[("ev", "1.5")]);
    assert_eq!(counts(&ev, &names), [0, 0, 0, 1, 1], "{ev:?}");
    assert!(ev.iter().any(|r| r.name == "raycast" && r.is_cached()));
    let op = run(VOLUME_SCENE, &session, dir.path(), &[("op", "aces")]);
    assert_eq!(counts(&op, &names), [0, 0, 0, 1, 1], "{op:?}");

    // Camera and transfer function: the ray cast and what follows, never the upload.
    let cam = run(VOLUME_SCENE, &session, dir.path(), &[("azimuth", "75.0")]);
    assert_eq!(counts(&cam, &names), [0, 0, 1, 1, 1], "{cam:?}");
    let tf = run(VOLUME_SCENE, &session, dir.path(), &[("opacity", "-1.0")]);
    assert_eq!(counts(&tf, &names), [0, 0, 1, 1, 1], "{tf:?}");
    let cmap = run(VOLUME_SCENE, &session, dir.path(), &[("cmap", "viridis")]);
    assert_eq!(counts(&cmap, &names), [0, 0, 1, 1, 1], "{cmap:?}");

    // Transfer-function sampling: a ray cast of its own, recorded in the file.
    let pre = run(
        VOLUME_SCENE,
        &session,
        dir.path(),
        &[("opacity", "-1.0"), ("sampling", "preintegrated")],
    );
    assert_eq!(counts(&pre, &names), [0, 0, 1, 1, 1], "{pre:?}");
    let img = hdrvis::io::exr::read_exr(&dir.path().join("shown.exr")).unwrap();
    assert_eq!(img.meta("tf_sampling"), Some("preintegrated"));

    // Nothing changed: nothing but the sink runs.
    let same = run(VOLUME_SCENE, &session, dir.path(), &[("opacity", "-1.0")]);
    assert_eq!(counts(&same, &names), [0, 0, 0, 0, 1], "{same:?}");

    // The file records how its image was made.
    let img = hdrvis::io::exr::read_exr(&dir.path().join("shown.exr")).unwrap();
    let passes = img.meta("passes").unwrap_or_default();
    // Which passes and effects, not how long they took: the same work writes the same bytes.
    assert!(
        passes.starts_with("raycast") && passes.contains("; tonemap [") && !passes.contains(" ms"),
        "{passes}"
    );
}

#[test]
fn ten_exposures_of_one_render_run_one_ray_cast() {
    let dir = tempfile::tempdir().unwrap();
    let session = Arc::new(RenderSession::new(BackendChoice::Auto, 256 << 20));
    // Both ways of writing a sweep: exposures of one image, and a render call per exposure.
    let script = r#"
        let v = generate_mantle(#{n: 20, seed: 2});
        let o = #{tf: tf_lut(#{scale: "symlog", linthresh: 0.01}), width: 24, height: 24};
        let img = render_volume(v, o);
        for i in 0..10 { save_png(exposure(img, i - 5.0), `a${i}.png`); }
        for i in 0..10 { save_png(exposure(render_volume(v, o), i - 5.0), `b${i}.png`); }
    "#;
    let passes = run(script, &session, dir.path(), &[]);
    assert_eq!(count_ran(&passes, "raycast"), 1, "{passes:?}");
    assert_eq!(count_ran(&passes, "upload"), 1);
    assert_eq!(
        count_ran(&passes, "exposure"),
        10,
        "second loop reuses the exposures"
    );
    assert_eq!(count_ran(&passes, "save-png"), 20);
    let a = std::fs::read(dir.path().join("a3.png")).unwrap();
    let b = std::fs::read(dir.path().join("b3.png")).unwrap();
    assert_eq!(a, b);
}

#[test]
fn a_nu_change_reruns_only_the_fringe_pass() {
    let dir = tempfile::tempdir().unwrap();
    let session = Arc::new(RenderSession::new(BackendChoice::Auto, 256 << 20));
    let script = r#"
        let g = load_grid(generate("okada", #{n: 41}));
        let img = render_surface(g, #{nu: param("nu", 8.0), mode: param("mode", "cyclic"),
                                      property: "uz"});
        save_exr(img, "s.exr");
    "#;
    let names = ["surface-data", "fringe"];
    let first = run(script, &session, dir.path(), &[]);
    assert_eq!(counts(&first, &names), [1, 1], "{first:?}");
    let nu = run(script, &session, dir.path(), &[("nu", "16.0")]);
    assert_eq!(counts(&nu, &names), [0, 1], "{nu:?}");
    let mode = run(script, &session, dir.path(), &[("mode", "modulated")]);
    assert_eq!(counts(&mode, &names), [0, 1], "{mode:?}");
    let same = run(script, &session, dir.path(), &[("mode", "modulated")]);
    assert_eq!(counts(&same, &names), [0, 0], "{same:?}");
}

#[test]
fn a_small_budget_evicts_and_recomputes() {
    let dir = tempfile::tempdir().unwrap();
    // 24³ f32 is 55 KiB, a 32² image 16 KiB: a 100 KiB budget cannot keep both images.
    let session = Arc::new(RenderSession::new(BackendChoice::Auto, 100 << 10));
    let script = r#"
        let v = generate_mantle(#{n: 24, seed: 5});
        let o = #{tf: tf_lut(#{scale: "symlog", linthresh: 0.01}), width: 32, height: 32};
        let a = render_volume(v, o);
        o.camera = camera_axis("x");
        let b = render_volume(v, o);
        o.camera = camera_axis("y");
        let c = render_volume(v, o);
        o.remove("camera");
        let d = render_volume(v, o);
    "#;
    let passes = run(script, &session, dir.path(), &[]);
    assert_eq!(
        count_ran(&passes, "raycast"),
        4,
        "the first image was evicted: {passes:?}"
    );
    assert!(session.cache().counters().evictions > 0);
    assert!(session.cache().counters().bytes <= 100 << 10);
}

/// With nothing cached, each render still reads the cells and classifies them once: the grid
/// the routing classified to decide on skipping is the one the ray cast uses.
#[test]
fn a_render_with_nothing_cached_classifies_its_cells_once() {
    let dir = tempfile::tempdir().unwrap();
    let session = Arc::new(RenderSession::new(BackendChoice::Auto, 0));
    let script = r#"
        let v = generate_mantle(#{n: 33, seed: 5});
        let o = #{tf: tf_lut(#{scale: "symlog", linthresh: 0.01}), width: 16, height: 16};
        let a = render_volume(v, o);
        o.camera = camera_axis("x");
        let b = render_volume(v, o);
    "#;
    let passes = run(script, &session, dir.path(), &[]);
    let counts: Vec<usize> = ["cell-ranges", "skip-grid", "upload", "raycast"]
        .iter()
        .map(|name| count_ran(&passes, name))
        .collect();
    assert_eq!(counts, [2, 2, 2, 2], "{passes:?}");
    assert!(
        passes.iter().any(|p| p.detail == "empty-space skipping"),
        "{passes:?}"
    );
}

#[test]
fn stats_flag_prints_one_line_per_pass() {
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("s.rhai");
    std::fs::write(&script, VOLUME_SCENE).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(["run", "--stats", "--out"])
        .arg(dir.path().join("out"))
        .arg(&script)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = stdout.lines().filter(|l| l.starts_with("pass ")).collect();
    let names: Vec<&str> = lines.iter().map(|l| l.split(' ').nth(1).unwrap()).collect();
    assert_eq!(
        names,
        [
            "generate",
            "cell-ranges",
            "skip-grid",
            "upload",
            "raycast",
            "tonemap",
            "save-exr"
        ],
        "{stdout}"
    );
    for l in &lines {
        let rest: Vec<&str> = l.split(' ').collect();
        assert_eq!(rest[2], "ran", "{l}");
        let ms: f64 = rest[3].parse().unwrap();
        assert!(ms >= 0.0 && rest[4] == "ms", "{l}");
    }
}

#[test]
fn the_pipeline_cache_is_saved_where_the_backend_has_one() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let hdrvis = |args: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_hdrvis"))
            .args(args)
            .env("HDRVIS_CACHE", &cache)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).to_string()
    };
    let doctor = hdrvis(&["doctor"]);
    let line = doctor
        .lines()
        .find(|l| l.starts_with("pipeline cache: "))
        .expect("doctor reports the pipeline cache");
    let script = dir.path().join("s.rhai");
    std::fs::write(&script, VOLUME_SCENE).unwrap();
    let out = dir.path().join("out");
    hdrvis(&[
        "run",
        script.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let files: Vec<_> = std::fs::read_dir(cache.join("pipelines"))
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    if line.starts_with("pipeline cache: yes") {
        assert_eq!(files.len(), 1, "{files:?}");
        let bytes = std::fs::metadata(&files[0]).unwrap().len();
        assert!(bytes > 0, "an empty cache file");
        // A second run loads it (a corrupt or foreign file would be rejected, not crash).
        hdrvis(&[
            "run",
            script.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        std::fs::write(&files[0], b"not a pipeline cache").unwrap();
        hdrvis(&[
            "run",
            script.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
    } else {
        assert!(files.is_empty(), "{files:?}");
    }
}

#[test]
fn effects_benchmark_counts_one_ray_cast_for_the_sweep_and_ten_without_the_cache() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args([
            "bench", "effects", "--n", "24", "--size", "32", "--runs", "1",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8_lossy(&out.stdout);
    let raycasts = |prefix: &str| -> usize {
        let line = table
            .lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("{table}"));
        line.split_whitespace().last().unwrap().parse().unwrap()
    };
    assert_eq!(raycasts("10 exposures, one render"), 1, "{table}");
    assert_eq!(raycasts("10 exposures, 10 full renders"), 10, "{table}");
    assert!(table.contains("ray cast + shading"), "{table}");
}
