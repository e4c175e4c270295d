//! The binary as users run it: scripts producing EXR/PNG read back by independent readers, and
//! bad input answered by a one-line error, a non-zero exit and no output file.

use hdrvis::model::Volume;
use std::path::{Path, PathBuf};
use std::process::Command;

pub fn hdrvis(args: &[&str], cwd: &Path) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run hdrvis");
    let clean = |b: &[u8]| {
        String::from_utf8_lossy(b)
            .lines()
            // Mesa's EGL probe prints this on machines without a Wayland session; it is not ours.
            .filter(|l| !l.contains("XDG_RUNTIME_DIR"))
            .collect::<Vec<_>>()
            .join("\n")
    };
    (
        out.status.code().unwrap_or(-1),
        clean(&out.stdout),
        clean(&out.stderr),
    )
}

fn write_volume(dir: &Path) -> PathBuf {
    let v = Volume::from_fn("blob", [24, 20, 16], |x, y, z| {
        (-((x - 12.0).powi(2) + (y - 10.0).powi(2) + (z - 8.0).powi(2)) / 18.0).exp()
    })
    .unwrap();
    let p = dir.join("blob.npy");
    hdrvis::datasets::npy::write_npy_f32(&p, &[16, 20, 24], &v.data).unwrap();
    p
}

/// Each of `cases` — render_surface options and a part of the one-line error they must give —
/// run on `grid` (a Rhai expression) in `dir`: exit 1, the error's first line holding the
/// part, nothing written.
pub fn surface_options_refused(dir: &Path, grid: &str, cases: &[(&str, &str)]) {
    for (opts, expected) in cases {
        let script =
            format!("let img = render_surface({grid}, #{{ {opts} }}); save_png(img, \"out.png\");");
        std::fs::write(dir.join("bad.rhai"), &script).unwrap();
        let (code, _, err) = hdrvis(&["run", "bad.rhai", "--out", "bad"], dir);
        assert_eq!(code, 1, "{opts}: {err}");
        let line = err.lines().next().unwrap_or("");
        assert!(line.contains(expected), "{opts}: {err}");
        assert!(!dir.join("bad/out.png").exists(), "{opts}");
    }
}

/// Runs a Python cross-check; exit 77 means its modules are missing, which fails the test when
/// HDRVIS_REQUIRE_PYTHON=1 (as in CI) and skips it otherwise.
pub fn python_check(script: &str, args: &[&str]) -> Option<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(script);
    let out = Command::new("python3").arg(&path).args(args).output();
    match out {
        Ok(o) if o.status.code() == Some(77) || o.status.code().is_none() => {
            crate::common::missing(
                "HDRVIS_REQUIRE_PYTHON",
                &format!(
                    "{script}: python modules missing: {}",
                    String::from_utf8_lossy(&o.stderr).trim()
                ),
            )
        }
        Ok(o) => Some(format!(
            "exit {}\n{}{}",
            o.status.code().unwrap_or(-1),
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )),
        Err(e) => crate::common::missing(
            "HDRVIS_REQUIRE_PYTHON",
            &format!("python3 not runnable: {e}"),
        ),
    }
}

#[test]
fn script_renders_and_writes_exr_read_by_openexr() {
    let dir = tempfile::tempdir().unwrap();
    write_volume(dir.path());
    let script = r#"
        let v = load_volume("blob.npy");
        let img = render_volume(v, #{ tf: tf_emission_absorption(2.0, 0.5), camera: camera_axis("z"),
                                      width: 24, height: 20, step: param("step", 0.5) });
        save_exr(img, "blob.exr");
        save_png(img, "views/blob.png", 1);
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let (code, stdout, stderr) = hdrvis(
        &["run", "s.rhai", "--out", "o", "--set", "step=0.25"],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("blob.exr"), "{stdout}");
    let exr = dir.path().join("o/blob.exr");
    let img = hdrvis::io::exr::read_exr(&exr).unwrap();
    assert_eq!((img.width, img.height), (24, 20));
    assert!(
        img.meta("adapter").is_some() && img.meta("tf").unwrap().contains("emission-absorption")
    );
    let png = image::open(dir.path().join("o/views/blob.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 20));
    let centre = img.pixel(12, 10);
    let arg = format!("12,10,R,{}", centre[0]);
    if let Some(report) = python_check(
        "check_exr.py",
        &[exr.to_str().unwrap(), "R", "G", "B", "A", "--pixel", &arg],
    ) {
        assert!(report.starts_with("exit 0"), "{report}");
    }
}

#[test]
fn the_same_script_writes_the_same_exr_bytes_on_every_run() {
    let dir = tempfile::tempdir().unwrap();
    write_volume(dir.path());
    // Many provenance attributes (camera, tf, passes with a tone map, ...) in one file.
    let script = r#"
        let v = load_volume("blob.npy");
        let img = render_volume(v, #{ tf: tf_lut(#{scale: "log"}), camera: camera_orbit(30.0, 20.0),
                                      width: 32, height: 24, shading: true });
        save_exr(tonemap(img, "aces"), "blob.exr");
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let bytes: Vec<Vec<u8>> = ["a", "b", "c"]
        .iter()
        .map(|out| {
            let (code, _, stderr) = hdrvis(&["run", "s.rhai", "--out", out], dir.path());
            assert_eq!(code, 0, "{stderr}");
            std::fs::read(dir.path().join(out).join("blob.exr")).unwrap()
        })
        .collect();
    let img = hdrvis::io::exr::read_exr(&dir.path().join("a/blob.exr")).unwrap();
    assert!(img.metadata.len() >= 6, "{:?}", img.metadata);
    assert!(bytes.iter().all(|b| *b == bytes[0]));
}

fn assert_one_line_error(code: i32, stderr: &str, needle: &str) {
    assert_ne!(code, 0, "expected failure, stderr: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert!(
        lines.first().is_some_and(|l| l.starts_with("error: ")),
        "{stderr}"
    );
    assert!(stderr.contains(needle), "expected {needle:?} in: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn bad_volume_inputs_are_one_line_errors_without_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Header/data size mismatch, malformed header, unsupported dtype, zero and absurd dims.
    std::fs::write(d.join("short.raw"), [0u8; 100]).unwrap();
    std::fs::write(d.join("mismatch.nhdr"), "NRRD0004\ntype: float\ndimension: 3\nsizes: 8 8 8\nendian: little\nencoding: raw\ndata file: short.raw\n").unwrap();
    std::fs::write(d.join("malformed.nhdr"), "NRRD0004\ntype float\n").unwrap();
    std::fs::write(
        d.join("zero.nhdr"),
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 0 8 8\nendian: little\ndata file: short.raw\n",
    )
    .unwrap();
    std::fs::write(d.join("absurd.nhdr"), "NRRD0004\ntype: float\ndimension: 3\nsizes: 60000 60000 60000\nendian: little\ndata file: short.raw\n").unwrap();
    let mut complex = b"\x93NUMPY\x01\x00".to_vec();
    let header = "{'descr': '<c8', 'fortran_order': False, 'shape': (2, 2, 2), }";
    let pad = 64 - (10 + header.len() + 1) % 64;
    let h = format!("{header}{}\n", " ".repeat(pad));
    complex.extend((h.len() as u16).to_le_bytes());
    complex.extend(h.as_bytes());
    complex.extend([0u8; 64]);
    std::fs::write(d.join("complex.npy"), complex).unwrap();
    let cases = [
        ("missing.npy", "missing.npy"),
        ("mismatch.nhdr", "short.raw"),
        ("malformed.nhdr", "malformed.nhdr"),
        ("zero.nhdr", "sizes"),
        ("absurd.nhdr", "sizes"),
        ("complex.npy", "dtype"),
    ];
    for (file, needle) in cases {
        let script = format!(
            "let v = load_volume(\"{file}\");\nlet img = render_volume(v, #{{ tf: tf_emission_absorption(1, 1) }});\nsave_exr(img, \"x.exr\");\n"
        );
        std::fs::write(d.join("s.rhai"), script).unwrap();
        let (code, _, stderr) = hdrvis(&["run", "s.rhai", "--out", "o"], d);
        assert_one_line_error(code, &stderr, needle);
        // The error points at the script line and column with a caret.
        assert!(stderr.contains("s.rhai:1:9"), "{stderr}");
        assert!(!d.join("o/x.exr").exists());
    }
}

#[test]
fn bad_script_calls_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_volume(d);
    let cases = [
        ("render_volume(load_volume(\"blob.npy\"), #{ tf: tf_emission_absorption(1, 1), colour: 3 })", "unknown option colour; known options: tf, camera"),
        ("camera_look_at([0.0/0.0, 0, 0], [1, 1, 1], [0, 0, 1], 30)", "camera.eye"),
        ("render_volume(load_volume(\"blob.npy\"), #{ tf: tf_emission_absorption(1, 1), step: -1 })", "step"),
        ("tf_lut(#{ colormap: \"jet\" })", "viridis"),
        ("load_volume(\"/etc/passwd\")", "outside the folders"),
        ("save_exr(render_volume(load_volume(\"blob.npy\"), #{ tf: tf_emission_absorption(1, 1) }), \"../escape.exr\")", "outside the output folder"),
        ("let x = ;", "s.rhai:1:"),
    ];
    for (line, needle) in cases {
        std::fs::write(d.join("s.rhai"), line).unwrap();
        let (code, _, stderr) = hdrvis(&["run", "s.rhai", "--out", "o"], d);
        assert_one_line_error(code, &stderr, needle);
    }
    assert!(!d.join("escape.exr").exists());
    let (code, _, stderr) = hdrvis(&["run", "s.rhai", "--set", "novalue"], d);
    assert_one_line_error(code, &stderr, "KEY=VALUE");
    std::fs::write(d.join("p.rhai"), "let n = param(\"n\", 3);").unwrap();
    let (code, _, stderr) = hdrvis(&["run", "p.rhai", "--set", "n=three"], d);
    assert_one_line_error(code, &stderr, "expected an integer");
}

/// A detached NRRD header in the script's folder may not name a data file outside the sandbox:
/// not absolutely, not through `..`, not through a symlink; inside it, the header still reads.
#[test]
fn nrrd_data_files_outside_the_sandbox_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("scripts");
    std::fs::create_dir_all(&d).unwrap();
    let secret = dir.path().join("secret.raw");
    std::fs::write(&secret, 7.5f32.to_le_bytes().repeat(8)).unwrap();
    std::fs::write(d.join("ok.raw"), 2.5f32.to_le_bytes().repeat(8)).unwrap();
    std::os::unix::fs::symlink(&secret, d.join("link.raw")).unwrap();
    let header = |data: &str| {
        format!("NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\ndata file: {data}\n")
    };
    let names = [
        ("abs", secret.display().to_string()),
        ("up", "../secret.raw".to_string()),
        ("link", "link.raw".to_string()),
        ("ok", "ok.raw".to_string()),
    ];
    for (name, data) in &names {
        std::fs::write(d.join(format!("{name}.nhdr")), header(data)).unwrap();
    }
    for (name, _) in &names[..3] {
        for call in ["load_volume", "open_volume", "load_grid"] {
            let script = format!("print(volume_stats({call}(\"{name}.nhdr\")));");
            std::fs::write(d.join("s.rhai"), script).unwrap();
            let (code, stdout, stderr) = hdrvis(&["run", "s.rhai", "--out", "o"], &d);
            assert_one_line_error(code, &stderr, "data file");
            assert!(
                stderr.contains("outside the folders"),
                "{name} {call}: {stderr}"
            );
            assert!(!stdout.contains("7.5"), "{stdout}");
        }
    }
    std::fs::write(
        d.join("s.rhai"),
        "print(volume_stats(load_volume(\"ok.nhdr\")).max);",
    )
    .unwrap();
    let (code, stdout, stderr) = hdrvis(&["run", "s.rhai", "--out", "o"], &d);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("2.5"), "{stdout}");
    // The command line is the user's own: it follows the header wherever it points.
    let (code, stdout, stderr) = hdrvis(&["info", "up.nhdr"], &d);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("7.5"), "{stdout}");
}

#[test]
fn doctor_reports_adapter_and_capabilities() {
    let dir = tempfile::tempdir().unwrap();
    for backend in ["vulkan", "gl"] {
        let (code, stdout, stderr) = hdrvis(&["doctor", "--backend", backend], dir.path());
        assert_eq!(code, 0, "{stderr}");
        for key in [
            "cache:",
            "adapter:",
            "backend:",
            "driver:",
            "float32 filtering:",
            "shader f64:",
            "max 3-D texture:",
        ] {
            assert!(stdout.contains(key), "{backend}: {stdout}");
        }
    }
    let (code, _, stderr) = hdrvis(&["doctor", "--backend", "metal2"], dir.path());
    assert_one_line_error(code, &stderr, "expected auto, vulkan or gl");
}

#[test]
fn a_run_on_the_gl_fallback_says_so_once_and_a_vulkan_run_does_not() {
    let dir = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/demo.rhai");
    let run = |backend: &str, extra: &[(&str, &str)]| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_hdrvis"));
        cmd.args(["run", script.to_str().unwrap(), "--out", backend])
            .args(["--set", "n=32", "--set", "size=48"])
            .env("HDRVIS_BACKEND", backend)
            .current_dir(dir.path());
        for (k, v) in extra {
            cmd.env(k, v);
        }
        let out = cmd.output().unwrap();
        assert!(out.status.success(), "{backend}: {out:?}");
        String::from_utf8_lossy(&out.stderr).to_string()
    };
    let gl = run("gl", &[]);
    assert_eq!(gl.matches("note: rendering with OpenGL").count(), 1, "{gl}");
    assert!(gl.contains("leave out --backend gl"), "{gl}");
    // Without a Vulkan driver the line names the package that brings lavapipe.
    let none = [
        ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
        ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
    ];
    let fallback = run("auto", &none);
    assert_eq!(
        fallback.matches("note: rendering with OpenGL").count(),
        1,
        "{fallback}"
    );
    assert!(
        fallback.contains("apt-get install mesa-vulkan-drivers"),
        "{fallback}"
    );
    let vulkan = run("vulkan", &[]);
    assert!(!vulkan.contains("note: rendering"), "{vulkan}");
}

#[test]
fn demo_runs_with_small_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/demo.rhai");
    let (code, stdout, stderr) = hdrvis(
        &[
            "run",
            script.to_str().unwrap(),
            "--out",
            "o",
            "--set",
            "n=32",
            "--set",
            "size=48",
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("demo.exr"));
    let img = hdrvis::io::exr::read_exr(&dir.path().join("o/demo.exr")).unwrap();
    assert!(img.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
    assert!(img.pixels.iter().any(|p| p[0] > 0.0), "demo image is black");
}

#[test]
fn backend_from_environment_and_missing_capability_fallback() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .arg("doctor")
        .env("HDRVIS_BACKEND", "gl")
        .env("HDRVIS_DISABLE_FEATURES", "float32_filterable,shader_f64")
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success());
    assert!(stdout.contains("backend:  GL"), "{stdout}");
    assert!(
        stdout.contains("float32 filtering: no (auto filters exactly in the shader)"),
        "{stdout}"
    );
    assert!(stdout.contains("shader f64: no"), "{stdout}");
    // The GL fallback is a slow path, and says so once, with what to do.
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stdout.contains("path:     slow: rendering with OpenGL"),
        "{stdout}"
    );
    assert_eq!(
        stderr.matches("note: rendering with OpenGL").count(),
        1,
        "{stderr}"
    );
    assert!(stderr.contains("slower than Vulkan's lavapipe"), "{stderr}");
    // No Vulkan driver: one line naming the package to install.
    let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(["doctor", "--backend", "vulkan"])
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .current_dir(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("mesa-vulkan-drivers"), "{stderr}");
}

#[test]
fn sandbox_stops_runaway_scripts_in_bounded_time() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases = [
        ("loop { }", "operations"),
        ("let a = []; a.pad(1000000000, 0);", "array"),
        ("fn f(x) { f(x + 1) } f(0);", "stack overflow"),
        ("let s = \"x\"; loop { s += s; }", "string"),
        ("eval(\"1\")", "eval"),
        ("import \"other\" as m;", "module"),
    ];
    for (src, needle) in cases {
        std::fs::write(d.join("s.rhai"), src).unwrap();
        let start = std::time::Instant::now();
        let (code, _, stderr) = hdrvis(&["run", "s.rhai", "--out", "o"], d);
        assert_ne!(code, 0, "{src}");
        assert!(stderr.to_lowercase().contains(needle), "{src}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            start.elapsed().as_secs() < 60,
            "{src} took {:?}",
            start.elapsed()
        );
    }
}

#[test]
fn wrong_argument_types_name_the_expected_signature() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.rhai"), "let img = render_volume(1, 2);").unwrap();
    let (code, _, stderr) = hdrvis(&["run", "s.rhai"], dir.path());
    assert_ne!(code, 0);
    assert!(
        stderr.contains("render_volume(volume: Volume, options: map) -> Image"),
        "{stderr}"
    );
    assert!(stderr.contains("s.rhai:1:11"), "{stderr}");
}

#[test]
fn sweep_killed_midway_resumes_to_the_same_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_volume(d);
    let sweep = r#"
        let v = load_volume("blob.npy");
        let evs = [-3, -2, -1, 0, 1, 2, 3, 4];
        for i in 0..evs.len() {
            let name = `sweep/a${i}.exr`;
            if !already_done(name) {
                let img = render_volume(v, #{ tf: tf_emission_absorption(0.5 + i, 0.2), camera: camera_orbit(20.0 * i, 15.0),
                                              width: 256, height: 256, step: 0.1 });
                // The file already_done checks is written last, so it means the whole frame is
                // there (docs/cluster.md): a kill between the two writes redoes the frame.
                save_png(img, `sweep/a${i}.png`, evs[i]);
                save_exr(img, name);
            }
            progress(i + 1, evs.len(), "sweep");
        }
    "#;
    std::fs::write(d.join("sweep.rhai"), sweep).unwrap();
    // Reference: an uninterrupted run.
    let (code, _, stderr) = hdrvis(&["run", "sweep.rhai", "--out", "full"], d);
    assert_eq!(code, 0, "{stderr}");
    // Interrupted: kill the process once some outputs exist.
    let mut child = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(["run", "sweep.rhai", "--out", "part"])
        .current_dir(d)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    loop {
        let n = std::fs::read_dir(d.join("part/sweep"))
            .map(|r| r.count())
            .unwrap_or(0);
        if n >= 5 || t0.elapsed().as_secs() > 60 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let finished = std::fs::read_dir(d.join("part/sweep"))
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with('a')
        })
        .count();
    assert!(
        finished < 16,
        "the run finished before it could be interrupted"
    );
    let (code, _, stderr) = hdrvis(&["run", "sweep.rhai", "--out", "part", "--resume"], d);
    assert_eq!(code, 0, "{stderr}");
    let list = |root: &str| {
        let mut v: Vec<String> = std::fs::read_dir(d.join(root).join("sweep"))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .collect();
        v.sort();
        v
    };
    assert_eq!(list("full"), list("part"));
    assert_eq!(list("part").len(), 16);
    for name in list("part").iter().filter(|n| n.ends_with(".exr")) {
        let a = hdrvis::io::exr::read_exr(&d.join("full/sweep").join(name)).unwrap();
        let b = hdrvis::io::exr::read_exr(&d.join("part/sweep").join(name)).unwrap();
        assert_eq!(a.pixels, b.pixels, "{name}");
    }
    for name in list("part").iter().filter(|n| n.ends_with(".png")) {
        image::open(d.join("part/sweep").join(name)).unwrap();
    }
}

#[test]
fn derived_fields_subsets_presets_and_preview() {
    let dir = tempfile::tempdir().unwrap();
    write_volume(dir.path());
    // The script checks its own numbers and throws on a mismatch.
    let script = r#"
        let v = load_volume("blob.npy");
        let s = volume_stats(v);
        let l = volume_stats(volume_log10(v));
        if (l.max - s.max.log()).abs() > 1e-5 { throw `log10 max ${l.max}`; }
        let m = volume_stats(volume_magnitude([v, v, v]));
        if (m.max - s.max * 3.0.sqrt()).abs() > 1e-5 { throw `magnitude max ${m.max}`; }
        let a = volume_stats(volume_abs(v));
        if a.min < 0.0 { throw "abs"; }
        let sub = volume_subset(v, [2, 3, 4], [10, 9, 8]);
        if sub.dims != [8, 6, 4] { throw `subset dims ${sub.dims}`; }
        let img = render_volume(sub, #{ tf: tf_preset("log-inferno"), width: 16, height: 16 });
        preview(img);
        save_exr(img, "sub.exr");
    "#;
    std::fs::write(dir.path().join("d.rhai"), script).unwrap();
    let (code, _, stderr) = hdrvis(&["run", "d.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{stderr}");
    std::fs::write(dir.path().join("e.rhai"), "tf_preset(\"rainbowish\")").unwrap();
    let (code, _, stderr) = hdrvis(&["run", "e.rhai"], dir.path());
    assert_one_line_error(code, &stderr, "log-inferno");
}

#[test]
fn grid_statistics_derived_properties_and_subsets() {
    let dir = tempfile::tempdir().unwrap();
    let script = r#"
        let g = load_grid(generate("okada", #{ n: 41, extent: 200000.0 }));
        let s = grid_stats(g, "uz");
        if s.finite != 41 * 41 || s.missing != 0 { throw `stats ${s}`; }
        let m = grid_magnitude(g, ["ux", "uy", "uz"], "u");
        let ms = grid_stats(m, "u");
        if ms.min < 0.0 || ms.max < s.max || ms.max < -s.min { throw `magnitude ${ms}`; }
        let l = grid_derive(m, "u", "log10", "log_u");
        if (grid_stats(l, "log_u").max - ms.max.log()).abs() > 1e-9 { throw "log10"; }
        let sub = grid_subset(l, [10, 5], [30, 25]);
        if sub.nx != 20 || sub.ny != 20 { throw `subset ${sub.nx} x ${sub.ny}`; }
        if !sub.properties.contains("log_u") { throw "properties"; }
        save_exr(render_surface(sub, #{ property: "u", nu: 4.0 }), "sub.exr");
    "#;
    std::fs::write(dir.path().join("g.rhai"), script).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(["run", "g.rhai", "--out", "o"])
        .env("HDRVIS_CACHE", dir.path().join("cache"))
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let img = hdrvis::io::exr::read_exr(&dir.path().join("o/sub.exr")).unwrap();
    // 20 × 20 nodes drawn at 51 pixels a node (the odd factor nearest a 1000-pixel figure).
    assert_eq!((img.width, img.height), (1020, 1020));
}

/// The accuracy report's CSV in `out`: its text, and its rows (after the header) split at commas.
fn accuracy_csv(out: &Path) -> (String, Vec<Vec<String>>) {
    let csv = std::fs::read_to_string(out.join("accuracy.csv")).unwrap();
    let rows = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (csv, rows)
}

#[test]
fn accuracy_report_writes_table_files_and_chart() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("acc");
    let (code, stdout, stderr) = hdrvis(
        &[
            "bench",
            "accuracy",
            "--runs",
            "1",
            "--size",
            "32",
            "--n",
            "24",
            "--scene",
            "mantle",
            "--out",
            out.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    for variant in [
        "u8",
        "f16",
        "f32",
        "f32c",
        "f32 step 0.5",
        "f32 step 1",
        "f32 step 2",
        "f32 pre step 0.5",
        "f32 pre step 1",
        "f32 pre step 2",
        "f64 (CPU)",
    ] {
        assert!(
            stdout
                .lines()
                .any(|l| l.starts_with(&format!("mantle   {variant} "))),
            "{variant} missing:\n{stdout}"
        );
    }
    let (csv, rows) = accuracy_csv(&out);
    // f64 (GPU) joins where the adapter has shader f64 (lavapipe does), within 1e-12 of the CPU.
    let has_gpu_f64 = rows.iter().any(|r| r[1] == "f64 (GPU)");
    assert_eq!(rows.len(), 12 + has_gpu_f64 as usize, "{csv}");
    let rel = |v: &str| -> f64 { rows.iter().find(|r| r[1] == v).unwrap()[4].parse().unwrap() };
    // The paper's claim on the mantle: 8-bit compositing loses what f32 keeps.
    assert!(rel("u8") > 1e-2 && rel("f32") < 1e-4, "{csv}");
    assert!(rel("f16") > rel("f32"));
    if has_gpu_f64 {
        assert!(rel("f64 (GPU)") < 1e-12, "{csv}");
    }
    let chart = image::open(out.join("accuracy.png")).unwrap();
    assert_eq!((chart.width(), chart.height()), (960, 640));
    let (code, _, stderr) = hdrvis(&["bench", "accuracy", "--scene", "nope"], dir.path());
    assert_ne!(code, 0);
    assert!(
        stderr
            .contains("unknown scene \"nope\"; known: mantle, blobs, band, tsunami, fault, shell"),
        "{stderr}"
    );
    let (code, _, stderr) = hdrvis(&["bench", "volume", "--scenes", "peer,nope"], dir.path());
    assert_one_line_error(
        code,
        &stderr,
        "unknown scene \"nope\": expected ours, peer, all",
    );
}

/// The accuracy report's tone-mapping scenes: the local operators as the GPU runs them (the
/// piecewise-linear grid, the Gaussian pyramid) against their exact definitions (brute-force
/// bilateral filter, full-resolution Gaussians) on lights of 1, 2 and 16 pixels and on noise.
#[test]
fn accuracy_report_scores_local_tone_mapping_against_exact_operators() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("acc");
    let (code, stdout, stderr) = hdrvis(
        &[
            "bench",
            "accuracy",
            "--runs",
            "1",
            "--scene",
            "tonemap",
            "--out",
            out.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    let (csv, rows) = accuracy_csv(&out);
    assert_eq!(rows.len(), 16, "{csv}");
    let rel = |scene: &str, variant: &str| -> f64 {
        let row = rows.iter().find(|r| r[0] == scene && r[1] == variant);
        row.unwrap_or_else(|| panic!("{scene} {variant} missing:\n{stdout}"))[4]
            .parse()
            .unwrap()
    };
    for scene in ["lights1", "lights2", "lights16"] {
        for op in ["durand", "reinhard-local"] {
            let r = rel(scene, &format!("{op} (GPU)"));
            assert!(r < 1e-3, "{scene} {op}: relative RMS {r:.2e}\n{stdout}");
            assert_eq!(rel(scene, &format!("{op} exact (CPU)")), 0.0);
        }
    }
    // Four decades of noise: Durand's levels interpolate linearly in l, Reinhard's scale
    // choice flips on a few pixels.
    assert!(rel("noise", "durand (GPU)") < 2e-2, "{stdout}");
    assert!(rel("noise", "reinhard-local (GPU)") < 1e-2, "{stdout}");
}

/// The accuracy report's shell scene: native steps and resampled boxes scored against the native
/// f64 integral, with the boxes' memory (n³ · 4 bytes) and resampling time; the finer box is the
/// more accurate. And `bench spherical` counts the samples both renders take.
#[test]
fn shell_scene_compares_native_sampling_with_resampled_boxes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("acc");
    let (code, stdout, stderr) = hdrvis(
        &[
            "bench",
            "accuracy",
            "--runs",
            "1",
            "--size",
            "24",
            "--n",
            "24",
            "--scene",
            "shell",
            "--quick",
            "--out",
            out.to_str().unwrap(),
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    let (csv, rows) = accuracy_csv(&out);
    let row = |v: &str| {
        rows.iter()
            .find(|r| r[1] == v)
            .unwrap_or_else(|| panic!("{v}: {csv}"))
    };
    let num = |r: &Vec<String>, c: usize| -> f64 { r[c].parse().unwrap() };
    assert_eq!(rows.len(), 6, "{csv}");
    assert_eq!(num(row("box 32^3"), 8), 0.125);
    assert_eq!(num(row("box 64^3"), 8), 1.0);
    assert!(num(row("box 64^3"), 9) > 0.0);
    assert!(num(row("box 64^3"), 4) < num(row("box 32^3"), 4), "{csv}");
    assert!(
        num(row("native step 0.5"), 4) < num(row("native step 2"), 4),
        "{csv}"
    );
    assert!(num(row("native step 0.5"), 4) < 1e-2, "{csv}");
    assert!(
        stdout.contains("at least as accurate as the box")
            || stdout.contains("more accurate than every native step"),
        "{stdout}"
    );

    let (code, stdout, stderr) = hdrvis(
        &[
            "bench",
            "spherical",
            "--runs",
            "1",
            "--n",
            "16",
            "--size",
            "16",
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    let samples: Vec<f64> = stdout
        .lines()
        .filter(|l| l.starts_with("spherical (") || l.starts_with("cartesian ("))
        // ... samples, ns/sample, GPU ms, GPU ns/sample ("-" without timestamps).
        .map(|l| l.split_whitespace().rev().nth(3).unwrap().parse().unwrap())
        .collect();
    // Native shell, box, box filtered in the shader, box with skipping: the three box renders
    // take the same samples, more than the shell (the box holds the sphere and its corners).
    assert_eq!(samples.len(), 4, "{stdout}");
    assert!(samples[0] > 0.0 && samples[1] > samples[0], "{stdout}");
    assert!(
        samples[1] == samples[2] && samples[2] == samples[3],
        "{stdout}"
    );
    assert!(stdout.contains("a spherical sample costs"), "{stdout}");
}

/// The surface scenes of the accuracy report (the paper's Fig. 3 and Fig. 4 data at large ν·d):
/// the naive f32 phase against the range-reduced one and the f64 fringes, timed, in the table,
/// the CSV and the chart. The naive phase's error is orders of magnitude above the reduced one's.
#[test]
fn accuracy_report_compares_naive_and_reduced_interference_phase() {
    let dir = tempfile::tempdir().unwrap();
    for scene in ["fault", "tsunami"] {
        let out = dir.path().join(scene);
        let (code, stdout, stderr) = hdrvis(
            &[
                "bench",
                "accuracy",
                "--runs",
                "1",
                "--grid",
                "64",
                "--scene",
                scene,
                "--out",
                out.to_str().unwrap(),
            ],
            dir.path(),
        );
        assert_eq!(code, 0, "{stderr}");
        for variant in ["naive f32", "reduced", "f64 (CPU)"] {
            assert!(
                stdout
                    .lines()
                    .any(|l| l.starts_with(&format!("{scene:<8} {variant} "))),
                "{variant} missing:\n{stdout}"
            );
        }
        assert!(
            stdout.contains(&format!("{scene}: the reduced phase has rel RMS")),
            "{stdout}"
        );
        let (csv, rows) = accuracy_csv(&out);
        assert_eq!(rows.len(), 3, "{csv}");
        let field = |v: &str, k: usize| -> f64 {
            rows.iter().find(|r| r[1] == v).unwrap()[k].parse().unwrap()
        };
        let (naive, reduced) = (field("naive f32", 4), field("reduced", 4));
        // ν·d ≈ 4·10⁴ (tsunami) and 8·10⁵ (fault): measured 6e-3 and 7e-2 against 2e-7 and
        // 7e-8 for the reduced phase.
        assert!(naive > 2e-3, "{scene}: naive rel RMS {naive}\n{csv}");
        assert!(reduced < 1e-5, "{scene}: reduced rel RMS {reduced}\n{csv}");
        assert!(naive > 1e3 * reduced, "{csv}");
        // Lost detail: pixels whose fringe intensity is off by more than 1 %.
        assert!(
            field("naive f32", 7) > 0.1 && field("reduced", 7) < 0.01,
            "{csv}"
        );
        assert!(out.join("accuracy.png").is_file());
    }
}

#[test]
fn misspelt_commands_and_options_get_a_suggestion() {
    let dir = tempfile::tempdir().unwrap();
    for (args, tip) in [
        (&["rnu", "s.rhai"][..], "a similar subcommand exists: 'run'"),
        (
            &["run", "s.rhai", "--ouput", "o"][..],
            "a similar argument exists: '--output'",
        ),
        (
            &["info", "f.nc", "--varaible", "T"][..],
            "a similar argument exists: '--variable'",
        ),
    ] {
        let (code, _, stderr) = hdrvis(args, dir.path());
        assert_eq!(code, 2, "{stderr}");
        assert!(stderr.contains(tip), "{args:?}: {stderr}");
    }
}

#[test]
fn info_describes_an_exr_with_plain_metadata() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_volume(d);
    let script = r#"
        let v = load_volume("blob.npy");
        let tf = tf_lut(#{ scale: "LOG10", domain: [0.001, 3], colormap: "viridis" });
        save_exr(render_volume(v, #{ tf: tf, camera: camera_axis("z"), width: 24, height: 30 }), "x.exr");
    "#;
    std::fs::write(d.join("s.rhai"), script).unwrap();
    let (code, _, stderr) = hdrvis(&["run", "s.rhai", "--out", "o"], d);
    assert_eq!(code, 0, "{stderr}");
    let img = hdrvis::io::exr::read_exr(&d.join("o/x.exr")).unwrap();
    let (code, stdout, stderr) = hdrvis(&["info", "o/x.exr"], d);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("image: 24 x 30 pixels"), "{stdout}");
    let max_r = img.pixels.iter().map(|p| p[0]).fold(f32::MIN, f32::max);
    assert!(
        stdout.contains(&format!("max {:.6e}", f64::from(max_r))),
        "{stdout}"
    );
    assert!(stdout.contains("  A: min"), "{stdout}");
    let tf = stdout.lines().find(|l| l.starts_with("  tf: ")).unwrap();
    assert!(
        tf.contains("scale=log10 domain=[0.001, 3] ") && !tf.contains("Some"),
        "{tf}"
    );
    let (code, stdout, stderr) = hdrvis(&["info", "o/x.exr", "--variable", "G"], d);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("channels (1):") && stdout.contains("  G: min"),
        "{stdout}"
    );
}

/// Runs `hdrvis ARGS` under `sh -c 'umask 022; ...'` in `cwd`, so the mode the outputs get is
/// the one a plain `open` would give there.
#[cfg(unix)]
fn hdrvis_under_umask_022(args: &[&str], cwd: &Path) {
    let out = Command::new("sh")
        .arg("-c")
        .arg("umask 022; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_hdrvis"))
        .args(args)
        .env("HDRVIS_CACHE", cwd.join("cache"))
        .current_dir(cwd)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[cfg(unix)]
#[test]
fn outputs_get_the_mode_of_a_plain_open_under_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = r#"
        let v = load_volume("blob.npy");
        let img = render_volume(v, #{ tf: tf_emission_absorption(1, 1), width: 16, height: 12 });
        save_exr(img, "view.exr");
        save_png(img, "view.png");
    "#;
    write_volume(d);
    std::fs::write(d.join("m.rhai"), script).unwrap();
    hdrvis_under_umask_022(&["run", "m.rhai", "--out", "o"], d);
    for ext in ["nc", "npy"] {
        let out = format!("okada.{ext}");
        hdrvis_under_umask_022(&["gen", "okada", "--n", "9", "-o", &out], d);
    }
    for file in ["o/view.exr", "o/view.png", "okada.nc", "okada.npy"] {
        let mode = std::fs::metadata(d.join(file))
            .unwrap()
            .permissions()
            .mode();
        assert_eq!(mode & 0o777, 0o644, "{file}: mode {:o}", mode & 0o777);
    }
}

#[test]
fn runaway_array_growth_ends_within_seconds() {
    let dir = tempfile::tempdir().unwrap();
    let src = "let a = []; for i in 0..1000000000 { a.push(i); }";
    std::fs::write(dir.path().join("grow.rhai"), src).unwrap();
    let start = std::time::Instant::now();
    let (code, _, stderr) = hdrvis(&["run", "grow.rhai", "--out", "o"], dir.path());
    let took = start.elapsed().as_secs_f64();
    assert_one_line_error(code, &stderr, "Size of array/BLOB over the script limit");
    assert!(stderr.starts_with("error: grow.rhai:1:"), "{stderr}");
    assert!(took < 10.0, "the runaway array took {took:.1} s");
}

#[test]
fn timeout_ends_an_endless_loop_on_time() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("spin.rhai"), "loop {}").unwrap();
    let start = std::time::Instant::now();
    let (code, _, stderr) = hdrvis(
        &["run", "spin.rhai", "--out", "o", "--timeout", "2"],
        dir.path(),
    );
    let took = start.elapsed().as_secs_f64();
    assert_one_line_error(
        code,
        &stderr,
        "stopped at the time limit of 2.0 s (--timeout)",
    );
    assert!(
        (1.5..6.0).contains(&took),
        "--timeout 2 ended after {took:.2} s"
    );
    let (code, _, stderr) = hdrvis(&["run", "spin.rhai", "--timeout", "0"], dir.path());
    assert_one_line_error(code, &stderr, "--timeout: expected seconds > 0, got 0");
    // Beyond what a Duration holds, NaN and negatives: one line, no panic.
    for (value, needle) in [
        (
            "1e20",
            "--timeout: expected seconds > 0 and below 1.8e19, got 100000000000000000000",
        ),
        (
            "inf",
            "--timeout: expected seconds > 0 and below 1.8e19, got inf",
        ),
        ("NaN", "--timeout: expected seconds > 0, got NaN"),
        ("-3", "--timeout: expected seconds > 0, got -3"),
    ] {
        let flag = format!("--timeout={value}");
        let (code, _, stderr) = hdrvis(&["run", "spin.rhai", &flag], dir.path());
        assert_one_line_error(code, &stderr, needle);
    }
    // A limit the clock cannot reach (1e19 s) runs the script without a deadline.
    std::fs::write(dir.path().join("quick.rhai"), "print(6 * 7);").unwrap();
    let (code, stdout, stderr) = hdrvis(
        &["run", "quick.rhai", "--out", "o", "--timeout", "1e19"],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.lines().any(|l| l.trim() == "42"), "{stdout}");
}

/// `hdrvis ARGS` in `cwd` with the cache chosen by the platform rules: no HDRVIS_CACHE, and
/// `XDG_CACHE_HOME` and `HOME` as given.
fn hdrvis_platform_cache(
    args: &[&str],
    cwd: &Path,
    xdg: Option<&Path>,
    home: &Path,
) -> (i32, String, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hdrvis"));
    cmd.args(args)
        .current_dir(cwd)
        .env_remove("HDRVIS_CACHE")
        .env_remove("XDG_CACHE_HOME")
        .env("HOME", home);
    if let Some(xdg) = xdg {
        cmd.env("XDG_CACHE_HOME", xdg);
    }
    let out = cmd.output().unwrap();
    let text = |b: &[u8]| String::from_utf8_lossy(b).to_string();
    (
        out.status.code().unwrap_or(-1),
        text(&out.stdout),
        text(&out.stderr),
    )
}

#[test]
fn outside_the_checkout_the_cache_is_the_platform_one() {
    let scratch = tempfile::tempdir().unwrap();
    let (work, xdg, home) = (
        scratch.path().join("work"),
        scratch.path().join("xdg"),
        scratch.path().join("home"),
    );
    std::fs::create_dir_all(&work).unwrap();
    let script = "let g = load_grid(generate(\"okada\", #{ n: 9 })); print(g.nx);";
    std::fs::write(work.join("g.rhai"), script).unwrap();
    let (code, stdout, stderr) =
        hdrvis_platform_cache(&["run", "g.rhai", "--out", "o"], &work, Some(&xdg), &home);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains('9'), "{stdout}");
    let (code, stdout, stderr) =
        hdrvis_platform_cache(&["gen", "mantle", "--n", "9"], &work, Some(&xdg), &home);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        Path::new(stdout.trim()).starts_with(xdg.join("hdrvis")),
        "{stdout}"
    );
    assert!(
        !work.join("datasets").exists(),
        "datasets/ appeared in the working directory"
    );
    let mut here: Vec<_> = std::fs::read_dir(&work)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    here.sort();
    assert_eq!(here, ["g.rhai", "o"]);

    let (_, du, _) = hdrvis_platform_cache(&["cache", "du"], &work, Some(&xdg), &home);
    let first = du.lines().next().unwrap();
    assert_eq!(
        first,
        format!(
            "cache: {} ($XDG_CACHE_HOME/hdrvis)",
            xdg.join("hdrvis").display()
        )
    );
    for kind in ["mantle ", "okada "] {
        let line = du.lines().find(|l| l.starts_with(kind)).expect(kind);
        assert!(line.contains(" 1 files "), "{du}");
    }
    let (code, cleaned, _) =
        hdrvis_platform_cache(&["cache", "clean", "okada"], &work, Some(&xdg), &home);
    assert_eq!(code, 0);
    assert!(cleaned.contains("removed 1 files"), "{cleaned}");
    let (_, du, _) = hdrvis_platform_cache(&["cache", "du"], &work, Some(&xdg), &home);
    assert!(!du.contains("okada ") && du.contains("mantle "), "{du}");

    // Without XDG_CACHE_HOME the cache is ~/.cache/hdrvis.
    let (_, du, _) = hdrvis_platform_cache(&["cache", "du"], &work, None, &home);
    let expected = home.join(".cache").join("hdrvis");
    assert!(
        du.starts_with(&format!("cache: {} (~/.cache/hdrvis)", expected.display())),
        "{du}"
    );
}

/// `hdrvis bench distributed` in the default build says how to build the MPI one; a bad
/// `--ranks` list is refused first in any build.
#[test]
fn bench_distributed_refuses_without_mpi_and_bad_rank_lists() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, stderr) = hdrvis(&["bench", "distributed", "--ranks", "1,0"], dir.path());
    assert_one_line_error(code, &stderr, "--ranks: expected whole numbers >= 1");
    #[cfg(not(feature = "mpi"))]
    {
        let (code, stdout, stderr) = hdrvis(&["bench", "distributed"], dir.path());
        assert_one_line_error(code, &stderr, "--features mpi");
        assert!(stdout.is_empty(), "{stdout}");
    }
}

/// `hdrvis ARGS` in `cwd`, killed after `limit` if it has not ended: `None` then.
fn hdrvis_within(args: &[&str], cwd: &Path, limit: std::time::Duration) -> Option<(i32, String)> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(args)
        .current_dir(cwd)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run hdrvis");
    let start = std::time::Instant::now();
    while start.elapsed() < limit {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
            return Some((status.code().unwrap_or(-1), stderr));
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    None
}

#[test]
fn fifos_and_devices_are_refused_before_they_are_opened() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for name in ["pipe.npy", "pipe.exr", "pipe.rhai", "pipe.nhdr", "pipe.raw"] {
        let made = Command::new("mkfifo").arg(d.join(name)).status().unwrap();
        assert!(made.success(), "mkfifo {name}");
    }
    std::fs::write(
        d.join("v.nhdr"),
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 2 2\nendian: little\ndata file: pipe.raw\n",
    )
    .unwrap();
    let limit = std::time::Duration::from_secs(20);
    for (args, file) in [
        (&["info", "pipe.npy"][..], "pipe.npy"),
        (&["info", "pipe.exr"], "pipe.exr"),
        (&["info", "pipe.nhdr"], "pipe.nhdr"),
        (&["info", "v.nhdr"], "pipe.raw"),
        (&["info", "/dev/zero"], "/dev/zero"),
        (&["tonemap", "pipe.exr", "-o", "t.png"], "pipe.exr"),
        (&["run", "pipe.rhai", "--out", "o"], "pipe.rhai"),
    ] {
        let (code, stderr) = hdrvis_within(args, d, limit)
            .unwrap_or_else(|| panic!("hdrvis {args:?} still blocked after {limit:?}"));
        let what = if file == "/dev/zero" {
            "a device"
        } else {
            "a FIFO (named pipe)"
        };
        assert_one_line_error(code, &stderr, &format!("is {what}, not a regular file"));
        assert!(stderr.contains(file), "{args:?}: {stderr}");
    }
    let script = "print(volume_stats(load_volume(\"pipe.npy\")).max);";
    std::fs::write(d.join("load.rhai"), script).unwrap();
    let (code, stderr) = hdrvis_within(&["run", "load.rhai", "--out", "o"], d, limit)
        .expect("load_volume of a FIFO blocked");
    assert_one_line_error(
        code,
        &stderr,
        "pipe.npy: is a FIFO (named pipe), not a regular file",
    );
}
