//! Every script in `scripts/` runs (at small sizes through `--set`) and writes valid EXR and PNG
//! files: the case studies of the paper, the sweeps and the demo. A sweep's frames become
//! movies (animated PNG, GIF, MP4 through ffmpeg) that independent decoders read back.

use std::path::Path;
use std::process::Command;

#[test]
fn every_script_runs_and_writes_valid_images() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let work = tempfile::tempdir().unwrap();
    let cache = work.path().join("cache");
    let mut scripts: Vec<_> = std::fs::read_dir(root.join("scripts"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "rhai"))
        // Interactive scenes preview instead of writing files; tests/integration/tui.rs runs them.
        .filter(|p| {
            !p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("tui_"))
        })
        .collect();
    scripts.sort();
    assert!(
        scripts.len() >= 7,
        "expected the case studies, sweeps and demo: {scripts:?}"
    );
    for script in scripts {
        let name = script.file_stem().unwrap().to_string_lossy().to_string();
        let out_dir = work.path().join(&name);
        let source = std::fs::read_to_string(&script).unwrap();
        // Only the parameters the script reads: a --set it does not read is refused.
        let sets = sets_read_by(
            &source,
            &[
                ("n", "40"),
                ("size", "40"),
                ("duration", "1200.0"),
                ("frames", "3"),
            ],
        );
        let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
            .arg("run")
            .arg(&script)
            .arg("--out")
            .arg(&out_dir)
            .args(&sets)
            // The real-shaped examples read their small models from the fixtures.
            .arg("--allow-path")
            .arg(root.join("datasets/fixtures"))
            .env("HDRVIS_CACHE", &cache)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        let written: Vec<String> = String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter_map(|l| l.strip_prefix("wrote ").map(str::to_string))
            .collect();
        assert!(
            written.iter().any(|p| p.ends_with(".exr")),
            "{name} wrote no EXR: {written:?}"
        );
        assert!(
            written.iter().any(|p| p.ends_with(".png")),
            "{name} wrote no PNG: {written:?}"
        );
        for file in &written {
            let path = Path::new(file);
            assert!(
                path.starts_with(&out_dir),
                "{name} wrote outside its output folder: {file}"
            );
            if file.ends_with(".exr") {
                let img = hdrvis::io::exr::read_exr(path).unwrap_or_else(|e| panic!("{name}: {e}"));
                assert!(img.width > 0 && img.height > 0);
                assert!(
                    img.pixels
                        .iter()
                        .all(|p| p[..3].iter().all(|v| v.is_finite()) || p[3] == 0.0),
                    "{name}: {file}"
                );
                assert!(
                    img.pixels
                        .iter()
                        .any(|p| p[0] > 0.0 || p[1] > 0.0 || p[2] > 0.0),
                    "{name}: {file} is black"
                );
            } else if file.ends_with(".png") {
                image::open(path).unwrap_or_else(|e| panic!("{name}: {file}: {e}"));
            }
        }
    }
}

/// The sets every script gets in `every_script_runs_and_writes_valid_images` that it reads.
pub(crate) fn sets_read_by(source: &str, sets: &[(&str, &str)]) -> Vec<String> {
    sets.iter()
        .filter(|(k, _)| source.contains(&format!("param(\"{k}\"")))
        .flat_map(|(k, v)| ["--set".to_string(), format!("{k}={v}")])
        .collect()
}

/// A 20 x 25 x 5 box of ones (x, y, z), one unit per voxel.
fn write_box(dir: &Path) {
    let ones = vec![1.0f32; 20 * 25 * 5];
    hdrvis::datasets::npy::write_npy_f32(&dir.join("box.npy"), &[5, 25, 20], &ones).unwrap();
}

#[test]
fn a_variable_is_picked_by_option_and_by_shorthand_in_an_xarray_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let nc = d.join("box.nc");
    let Some(report) = crate::cli::python_check("write_box_nc.py", &[nc.to_str().unwrap()]) else {
        return;
    };
    assert!(report.starts_with("exit 0"), "{report}");
    let script = r#"
        for v in [load_volume("box.nc"), load_volume("box.nc", #{ variable: "S" }),
                  load_volume("box.nc:S"), open_volume("box.nc", #{ variable: "S", brick: 8 }),
                  open_volume("box.nc:T")] {
            let s = volume_stats(v);
            print(`${v.dims} ${s.min} ${s.max}`);
        }
    "#;
    std::fs::write(d.join("s.rhai"), script).unwrap();
    let (code, stdout, stderr) = crate::cli::hdrvis(&["run", "s.rhai", "-o", "o"], d);
    assert_eq!(code, 0, "{stderr}");
    let lines: Vec<&str> = stdout.lines().collect();
    // T = 1 + x over x = 0..19; S = 100 + y over y = 0..24.
    let t = "[20, 25, 5] 1.0 20.0";
    let s = "[20, 25, 5] 100.0 124.0";
    assert_eq!(lines, [t, s, s, s, t], "{stdout}");

    for (call, needle) in [
        (
            r#"load_volume("box.nc", #{ variable: "Q" })"#,
            "no variable 'Q'; the file has: T",
        ),
        (
            r#"load_volume("box.nc:Q")"#,
            "no variable 'Q'; the file has: T",
        ),
        (
            r#"open_volume("box.nc", #{ var: "T" })"#,
            "write variable: \"NAME\"",
        ),
        (r#"load_volume("box.nc:T", #{ variable: "S" })"#, "give one"),
    ] {
        std::fs::write(d.join("bad.rhai"), format!("let v = {call};")).unwrap();
        let (code, _, stderr) = crate::cli::hdrvis(&["run", "bad.rhai", "-o", "o"], d);
        assert_eq!(code, 1, "{call}: {stderr}");
        assert!(
            stderr.lines().next().unwrap().contains(needle),
            "{call}: {stderr}"
        );
    }
}

#[test]
fn a_set_no_param_reads_is_refused_before_anything_runs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_box(d);
    let script = r#"
        fn exposure() { param("exposure", 0.0) }
        let v = load_volume("box.npy");
        let img = render_volume(v, #{ tf: tf_emission_absorption(1.0, 0.1), camera: camera_axis("z"),
                                      width: param("size", 16) });
        save_png(img, "view.png", exposure());
    "#;
    std::fs::write(d.join("sweep.rhai"), script).unwrap();
    let (code, stdout, stderr) =
        crate::cli::hdrvis(&["run", "sweep.rhai", "-o", "o", "--set", "sizee=64"], d);
    assert_eq!(code, 1, "{stderr}");
    assert_eq!(
        stderr.trim(),
        "error: --set sizee: no param(\"sizee\", ...) in the script reads it; did you mean size? \
         its parameters: exposure, size"
    );
    let nothing_written = std::fs::read_dir(d.join("o")).map_or(true, |mut r| r.next().is_none());
    assert!(stdout.is_empty() && nothing_written, "{stdout}");
    // The parameter read inside a function counts, and the right name runs.
    let (code, stdout, stderr) = crate::cli::hdrvis(
        &[
            "run",
            "sweep.rhai",
            "-o",
            "o",
            "--set",
            "size=20",
            "--set",
            "exposure=1.0",
        ],
        d,
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("view.png"), "{stdout}");
}

/// Columns and rows of `img` that hold any emission (the box), as (columns, rows).
fn lit_extent(img: &hdrvis::model::HdrImage) -> (usize, usize) {
    let lit = |x: u32, y: u32| img.pixel(x, y)[0] > 0.0;
    let cols = (0..img.width)
        .filter(|&x| (0..img.height).any(|y| lit(x, y)))
        .count();
    let rows = (0..img.height)
        .filter(|&y| (0..img.width).any(|x| lit(x, y)))
        .count();
    (cols, rows)
}

#[test]
fn axis_views_of_a_20_by_25_box_have_square_pixels() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_box(d);
    let script = r#"
        let v = load_volume("box.npy");
        let tf = tf_emission_absorption(1.0, 0.1);
        save_exr(render_volume(v, #{ tf: tf, camera: camera_axis("z") }), "auto.exr");
        save_exr(render_volume(v, #{ tf: tf, camera: camera_axis("z"), width: 100, height: 100 }), "square.exr");
        save_exr(render_volume(v, #{ tf: tf, camera: camera_axis("z"), height: 50 }), "h50.exr");
    "#;
    std::fs::write(d.join("s.rhai"), script).unwrap();
    let (code, _, stderr) = crate::cli::hdrvis(&["run", "s.rhai", "-o", "o"], d);
    assert_eq!(code, 0, "{stderr}");
    let read = |name: &str| hdrvis::io::exr::read_exr(&d.join("o").join(name)).unwrap();
    // No size: the box's aspect, 512 on the long side, the box filling the image.
    let auto = read("auto.exr");
    assert_eq!((auto.width, auto.height), (410, 512));
    assert_eq!(lit_extent(&auto), (410, 512));
    // 100 x 100: letterboxed, 0.25 units per pixel both ways, background beside the box.
    let square = read("square.exr");
    assert_eq!((square.width, square.height), (100, 100));
    assert_eq!(lit_extent(&square), (80, 100));
    assert_eq!(square.pixel(5, 50)[0], 0.0, "background left of the box");
    let h50 = read("h50.exr");
    assert_eq!((h50.width, h50.height), (40, 50));
}

#[test]
fn image_sizes_beyond_the_adapter_are_refused_and_out_of_memory_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_box(d);
    let script = r#"
        let v = load_volume("box.npy");
        let n = param("n", 16384);
        let img = render_volume(v, #{ tf: tf_emission_absorption(1.0, 0.1), camera: camera_axis("z"),
                                      width: n, height: n });
        save_exr(img, "big.exr");
    "#;
    std::fs::write(d.join("big.rhai"), script).unwrap();
    let (code, stdout, stderr) = crate::cli::hdrvis(&["run", "big.rhai", "-o", "o"], d);
    assert!(!stderr.contains("panicked"), "{stderr}");
    if code != 0 {
        // Refused before any GPU work, naming the adapter's limit.
        assert_eq!(code, 1, "{stderr}");
        let first = stderr.lines().next().unwrap();
        assert!(
            first.contains("16384 x 16384 pixels")
                && (first.contains("max_buffer_size")
                    || first.contains("max_texture_dimension_2d")),
            "{stderr}"
        );
    } else {
        assert!(stdout.contains("big.exr"), "{stdout}");
    }
    // Out of memory forced by a 1.5 GB address-space limit on a 1 GiB image (lavapipe's device
    // memory is host memory): one error line, exit 1, no panic.
    let hdrvis_bin = env!("CARGO_BIN_EXE_hdrvis");
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 1500000 && exec '{hdrvis_bin}' run big.rhai -o o --set n=8192"
        ))
        .current_dir(d)
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let adapter = crate::common::renderer(hdrvis::gpu::BackendChoice::Auto)
        .context()
        .info
        .device_type;
    if adapter != wgpu::DeviceType::Cpu {
        // A real GPU's memory is not bounded by ulimit; the render may succeed.
        assert!(!stderr.contains("panicked"), "{stderr}");
        return;
    }
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let first = stderr.lines().next().unwrap();
    assert!(first.contains("gpu: Out of Memory"), "{stderr}");
    assert!(
        !stderr.contains("panicked") && !d.join("o/big.exr").exists(),
        "{stderr}"
    );
}

#[test]
fn sigterm_mid_sweep_prints_what_was_written() {
    use std::io::{BufRead, BufReader};
    use std::os::unix::process::ExitStatusExt;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write_box(d);
    let script = r#"
        let v = load_volume("box.npy");
        for i in 0..2000 {
            let img = render_volume(v, #{ tf: tf_emission_absorption(1.0, 0.1 + i * 0.001),
                                          camera: camera_orbit(i * 1.0, 20.0), width: 64, height: 64 });
            save_png(img, `frame-${i}.png`);
        }
    "#;
    std::fs::write(d.join("sweep.rhai"), script).unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .args(["run", "sweep.rhai", "-o", "o"])
        .current_dir(d)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    let mut lines = Vec::new();
    // Two outputs reported while the run goes on, then SIGTERM.
    while lines.len() < 2 {
        let mut line = String::new();
        assert!(
            stdout.read_line(&mut line).unwrap() > 0,
            "the sweep ended early"
        );
        lines.push(line.trim().to_string());
    }
    let killed = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stdout, &mut rest).unwrap();
    lines.extend(rest.lines().map(str::to_string));
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut stderr).unwrap();
    let status = child.wait().unwrap();
    assert_eq!(
        status.signal(),
        Some(15),
        "dies of SIGTERM as without the handler"
    );
    let written: Vec<&str> = lines
        .iter()
        .map(|l| l.strip_prefix("wrote ").expect("only wrote lines"))
        .collect();
    assert!(written.len() >= 2 && written.len() < 2000, "{written:?}");
    for (i, w) in written.iter().enumerate() {
        assert!(
            w.ends_with(&format!("frame-{i}.png")) && Path::new(w).is_file(),
            "{w}"
        );
    }
    // Every frame that has its final name was reported: a stop between a file's rename and its
    // "wrote" line would leave an output the run never owned up to.
    let mut on_disk: Vec<String> = std::fs::read_dir(d.join("o"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| !n.starts_with(".hdrvis-"))
        .collect();
    on_disk.sort_by_key(|n| frame_number(n));
    let reported: Vec<String> = written.iter().map(|w| file_name(w)).collect();
    assert_eq!(on_disk, reported);
    let stop = stderr
        .lines()
        .find(|l| l.starts_with("stopped by SIGTERM"))
        .unwrap_or_else(|| panic!("no stop line: {stderr}"));
    assert!(
        stop.contains(&format!("after writing {} files: ", written.len()))
            && stop.ends_with(written.last().unwrap()),
        "{stop}"
    );
}

/// `N` of `frame-N.png`.
fn frame_number(name: &str) -> usize {
    name.trim_start_matches("frame-")
        .trim_end_matches(".png")
        .parse()
        .unwrap_or_else(|_| panic!("not a frame: {name}"))
}

fn file_name(path: &str) -> String {
    Path::new(path)
        .file_name()
        .unwrap()
        .to_string_lossy()
        .to_string()
}

/// Whether `ffmpeg` and `ffprobe` run; when not, the movie checks that need them are skipped,
/// unless HDRVIS_REQUIRE_FFMPEG=1 (as in CI) makes their absence a failure.
pub(crate) fn ffmpeg_tools() -> bool {
    let runs = |tool: &str| {
        Command::new(tool)
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let present = runs("ffmpeg") && runs("ffprobe");
    if !present {
        crate::common::missing::<()>(
            "HDRVIS_REQUIRE_FFMPEG",
            "the MP4 checks need ffmpeg and ffprobe, which are not installed",
        );
    }
    present
}

/// The frames of an animated PNG, decoded by the `png` crate.
fn apng_frames(path: &Path) -> Vec<Vec<u8>> {
    let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let n = reader
        .info()
        .animation_control
        .expect("an animated PNG")
        .num_frames;
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    (0..n)
        .map(|_| {
            let info = reader.next_frame(&mut buf).unwrap();
            buf[..info.buffer_size()].to_vec()
        })
        .collect()
}

fn png_pixels(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().to_rgb8().into_raw()
}

#[test]
fn orbit_frames_become_movies() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let v = hdrvis::model::Volume::from_fn("blob", [20, 16, 12], |x, y, z| {
        (-((x - 12.0).powi(2) + (y - 8.0).powi(2) + (z - 5.0).powi(2)) / 10.0).exp()
    })
    .unwrap();
    hdrvis::datasets::npy::write_npy_f32(&d.join("blob.npy"), &[12, 16, 20], &v.data).unwrap();
    let script = r#"
        let v = load_volume("blob.npy");
        let frames = [];
        for i in 0..36 {
            let img = render_volume(v, #{ tf: tf_emission_absorption(2.0, 0.5),
                                          camera: camera_orbit(10.0 * i, 20.0), width: 64, height: 48 });
            save_png(img, `orbit/az${10 * i}.png`);
            frames.push(img);
        }
        save_animation(frames, "orbit.png", #{ fps: 24 });
        save_animation(["orbit/az0.png", "orbit/az10.png"], "two.gif");
    "#;
    std::fs::write(d.join("orbit.rhai"), script).unwrap();
    let run = |args: &[&str], path: Option<&Path>| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_hdrvis"));
        cmd.args(args).current_dir(d);
        if let Some(path) = path {
            cmd.env("PATH", path);
        }
        let out = cmd.output().unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stderr).to_string(),
            String::from_utf8_lossy(&out.stdout).to_string(),
        )
    };
    let (ok, stderr, stdout) = run(&["run", "orbit.rhai", "--out", "o"], None);
    assert!(ok, "{stderr}");
    // Movies are outputs like images: each reported the moment it is complete.
    for movie in ["orbit.png", "two.gif"] {
        let line = format!("wrote {}", d.join("o").join(movie).display());
        assert!(stdout.lines().any(|l| l == line), "{line} in {stdout}");
    }
    let frames = apng_frames(&d.join("o/orbit.png"));
    assert_eq!(frames.len(), 36);
    assert_eq!(frames[9], png_pixels(&d.join("o/orbit/az90.png")));
    use image::AnimationDecoder;
    let gif = std::io::BufReader::new(std::fs::File::open(d.join("o/two.gif")).unwrap());
    let gif = image::codecs::gif::GifDecoder::new(gif).unwrap();
    assert_eq!(gif.into_frames().collect_frames().unwrap().len(), 2);

    // The command line: the pattern expands in natural order (az20 is the third frame).
    let (ok, stderr, _) = run(
        &["animate", "o/orbit/az*.png", "-o", "cli.png", "--fps", "6"],
        None,
    );
    assert!(ok, "{stderr}");
    let frames = apng_frames(&d.join("cli.png"));
    assert_eq!(frames.len(), 36);
    assert_eq!(frames[2], png_pixels(&d.join("o/orbit/az20.png")));
    assert_eq!(frames[35], png_pixels(&d.join("o/orbit/az350.png")));

    // Without ffmpeg an MP4 is a one-line hint and no file.
    let empty = d.join("no-tools");
    std::fs::create_dir_all(&empty).unwrap();
    let (ok, stderr, _) = run(&["animate", "o/orbit/*.png", "-o", "x.mp4"], Some(&empty));
    assert!(
        !ok && stderr.contains("needs ffmpeg, which is not installed"),
        "{stderr}"
    );
    assert!(!d.join("x.mp4").exists());
    // A script that would write an MP4 says so before it renders a frame.
    std::fs::write(
        d.join("movie.rhai"),
        "let img = render_volume(load_volume(\"blob.npy\"), #{ tf: tf_emission_absorption(2.0, 0.5), width: 16, height: 16 }); save_png(img, \"first.png\"); save_animation([img], \"late.mp4\");",
    )
    .unwrap();
    let (ok, stderr, _) = run(&["run", "movie.rhai", "--out", "m"], Some(&empty));
    assert!(
        !ok && stderr
            .lines()
            .next()
            .unwrap_or("")
            .contains("late.mp4: writing .mp4 needs ffmpeg"),
        "{stderr}"
    );
    assert!(
        !d.join("m/first.png").exists(),
        "a frame was rendered first"
    );

    if ffmpeg_tools() {
        let (ok, stderr, _) = run(&["animate", "o/orbit/*.png", "-o", "orbit.mp4"], None);
        assert!(ok, "{stderr}");
        let probe = Command::new("ffprobe")
            .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
            .args([
                "-show_entries",
                "stream=codec_name,width,height,nb_read_frames",
            ])
            .args(["-of", "csv=p=0"])
            .arg(d.join("orbit.mp4"))
            .output()
            .unwrap();
        assert_eq!(
            String::from_utf8_lossy(&probe.stdout).trim(),
            "h264,64,48,36"
        );
    }
    let leftovers: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.starts_with(".hdrvis-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// `scripts/tomography.rhai` renders the CF global model of the fixtures natively: in the view
/// from above the North Pole every ray through the shell gathers light and opacity, and every
/// ray past the outer sphere (radius 6371 − 25 km) none; the shell is seen as a disc.
#[test]
fn tomography_script_renders_the_fixture_as_a_disc() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out_dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .arg("run")
        .arg(root.join("scripts/tomography.rhai"))
        .args(["--out"])
        .arg(out_dir.path())
        .args(["--set", "size=48", "--allow-path"])
        .arg(root.join("datasets/fixtures"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("spherical 90x45x16"), "{stdout}");
    let img = hdrvis::io::exr::read_exr(&out_dir.path().join("tomography_pole.exr")).unwrap();
    let n = img.width as usize;
    assert_eq!((img.width, img.height), (48, 48));
    let (mut inside, mut outside) = (0, 0);
    for py in 0..n {
        for px in 0..n {
            // The axis view spans the shell's box [-R, R]², R the outer radius.
            let x = 2.0 * (px as f64 + 0.5) / n as f64 - 1.0;
            let y = 1.0 - 2.0 * (py as f64 + 0.5) / n as f64;
            let b = (x * x + y * y).sqrt();
            let p = img.pixels[py * n + px];
            if b < 0.95 {
                inside += 1;
                assert!(p[3] > 1e-3 && p[0] + p[1] + p[2] > 0.0, "b {b}: {p:?}");
            } else if b > 1.05 {
                outside += 1;
                assert_eq!(p, [0.0; 4], "b {b}");
            }
        }
    }
    assert!(inside > 1500 && outside > 250, "{inside} {outside}");
}

/// `resample(volume, #{ n })` from a script: the tomography shell on a 40-voxel box, the same
/// value range inside (trilinear interpolation cannot leave it), missing outside the shell.
#[test]
fn resample_from_a_script_boxes_the_shell() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let script = dir.path().join("box.rhai");
    let model = root.join("datasets/fixtures/tomography.nc");
    std::fs::write(
        &script,
        format!(
            "let v = load_volume({model:?});\nlet b = resample(v, #{{ n: 40 }});\nlet s = volume_stats(v);\nlet t = volume_stats(b);\nprint(`${{b.geometry}} ${{b.dims}} ${{t.min >= s.min}} ${{t.max <= s.max}} ${{t.missing > 0}}`);\n"
        ),
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
        .arg("run")
        .arg(&script)
        .arg("--out")
        .arg(dir.path().join("out"))
        .arg("--allow-path")
        .arg(root.join("datasets/fixtures"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("cartesian [40, 40, 40] true true true"),
        "{stdout}"
    );
}
