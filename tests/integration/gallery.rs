//! The gallery (docs/gallery.md and docs/gallery/, made by tools/gallery.py from the example
//! scripts) stays in step with the scripts: each figure was made by its script as it is now.

use std::path::Path;

/// SHA-256 of a file, through coreutils' `sha256sum`.
fn sha256(path: &Path) -> String {
    let out = std::process::Command::new("sha256sum")
        .arg(path)
        .output()
        .expect("sha256sum (coreutils) runs");
    assert!(out.status.success(), "sha256sum {}", path.display());
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .next()
        .unwrap_or_default()
        .to_string()
}

#[test]
fn the_gallery_is_in_step_with_the_scripts() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let manifest = std::fs::read_to_string(root.join("docs/gallery/manifest.tsv")).unwrap();
    let page = std::fs::read_to_string(root.join("docs/gallery.md")).unwrap();
    let rows: Vec<Vec<&str>> = manifest
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.split('\t').collect())
        .collect();
    let mut scripts: Vec<String> = std::fs::read_dir(root.join("scripts"))
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".rhai"))
        .collect();
    scripts.sort();
    let mut listed: Vec<String> = rows.iter().map(|r| r[0].to_string()).collect();
    listed.sort();
    assert_eq!(
        listed, scripts,
        "docs/gallery/manifest.tsv lists other scripts than scripts/ holds: run python3 tools/gallery.py"
    );
    let mut shown = 0;
    for row in &rows {
        let [script, digest, figure, caption] = row[..] else {
            panic!("manifest row {row:?}: expected 4 tab-separated fields");
        };
        assert_eq!(
            sha256(&root.join("scripts").join(script)),
            digest,
            "scripts/{script} changed since its figure was made: run python3 tools/gallery.py"
        );
        assert!(!caption.trim().is_empty(), "{script}: no caption");
        if figure == "-" {
            continue;
        }
        let picture = image::open(root.join("docs/gallery").join(figure))
            .unwrap_or_else(|e| panic!("docs/gallery/{figure}: {e}"));
        assert!(
            picture.width() <= 480 && picture.height() >= 16,
            "{figure}: {}x{}",
            picture.width(),
            picture.height()
        );
        assert!(
            page.contains(&format!("(gallery/{figure})")),
            "docs/gallery.md lacks {figure}"
        );
        shown += 1;
    }
    assert!(shown >= 8, "{shown} figures");
}
