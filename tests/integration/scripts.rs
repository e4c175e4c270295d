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
        let out = Command::new(env!("CARGO_BIN_EXE_hdrvis"))
            .arg("run")
            .arg(&script)
            .arg("--out")
            .arg(&out_dir)
            .args([
                "--set",
                "n=40",
                "--set",
                "size=40",
                "--set",
                "duration=1200.0",
                "--set",
                "frames=3",
            ])
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

/// Whether `ffmpeg` and `ffprobe` run; when not, the movie checks that need them are skipped,
/// unless HDRVIS_REQUIRE_FFMPEG=1 (as in CI) makes their absence a failure.
fn ffmpeg_tools() -> bool {
    let runs = |tool: &str| {
        Command::new(tool)
            .arg("-version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    let present = runs("ffmpeg") && runs("ffprobe");
    let required = std::env::var("HDRVIS_REQUIRE_FFMPEG").as_deref() == Ok("1");
    assert!(
        present || !required,
        "ffmpeg/ffprobe missing (HDRVIS_REQUIRE_FFMPEG=1)"
    );
    if !present {
        eprintln!("skipping the MP4 checks: ffmpeg/ffprobe not installed");
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
        )
    };
    let (ok, stderr) = run(&["run", "orbit.rhai", "--out", "o"], None);
    assert!(ok, "{stderr}");
    let frames = apng_frames(&d.join("o/orbit.png"));
    assert_eq!(frames.len(), 36);
    assert_eq!(frames[9], png_pixels(&d.join("o/orbit/az90.png")));
    use image::AnimationDecoder;
    let gif = std::io::BufReader::new(std::fs::File::open(d.join("o/two.gif")).unwrap());
    let gif = image::codecs::gif::GifDecoder::new(gif).unwrap();
    assert_eq!(gif.into_frames().collect_frames().unwrap().len(), 2);

    // The command line: the pattern expands in natural order (az20 is the third frame).
    let (ok, stderr) = run(
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
    let (ok, stderr) = run(&["animate", "o/orbit/*.png", "-o", "x.mp4"], Some(&empty));
    assert!(
        !ok && stderr.contains("needs ffmpeg, which is not installed"),
        "{stderr}"
    );
    assert!(!d.join("x.mp4").exists());

    if ffmpeg_tools() {
        let (ok, stderr) = run(&["animate", "o/orbit/*.png", "-o", "orbit.mp4"], None);
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
