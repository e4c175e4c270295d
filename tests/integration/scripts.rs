//! Every script in `scripts/` runs (at small sizes through `--set`) and writes valid EXR and PNG
//! files: the case studies of the paper, the sweeps and the demo.

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
