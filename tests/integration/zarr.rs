//! Zarr stores written by xarray's `to_zarr` (tests/python/write_zarr_cases.py) with its default
//! codecs — Zarr v2 with Blosc (LZ4, byte shuffle), Zarr v3 with Zstandard — and a v2 store with
//! zlib: chunked with partial edge chunks, NaN fills, a datetime time axis and a packed int16
//! variable. Every value and date must equal `xarray.open_zarr`'s.

use crate::cli::hdrvis;
use crate::common::{assert_values, python_report, reference_numbers};
use hdrvis::datasets::select::Selection;
use std::collections::HashMap;
use std::path::Path;

fn reference(dir: &Path) -> Option<HashMap<String, Vec<String>>> {
    python_report("write_zarr_cases.py", &[dir.to_str().unwrap()])
}

#[test]
fn zarr_stores_read_as_xarray_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path()) else {
        return;
    };
    for store in ["v2", "v3", "v2_zlib"] {
        let path = dir.path().join(format!("{store}.zarr"));
        for (var, t, key) in [("sst", 3, "sst.t3"), ("t2m", 1, "t2m.t1")] {
            let sel = Selection {
                index: vec![("time".into(), t)],
                at: Vec::new(),
            };
            let (dims, got) = hdrvis::datasets::read_values(&path, Some(var), &sel)
                .unwrap_or_else(|e| panic!("{store} {var}: {e}"));
            assert_eq!(dims, [("lat".to_string(), 12), ("lon".to_string(), 16)]);
            // xarray unpacks in float64, as hdrvis does: equal to the last bit.
            assert_values(
                &got,
                &reference_numbers(&r, &format!("{store}.{key}")),
                0.0,
                &format!("{store} {var}"),
            );
        }
        let (code, out, err) = hdrvis(
            &[
                "info",
                "--json",
                path.to_str().unwrap(),
                "--variable",
                "sst",
            ],
            dir.path(),
        );
        assert_eq!(code, 0, "{err}");
        let info: serde_json::Value = serde_json::from_str(&out).unwrap();
        let times: Vec<String> = info["times"]
            .as_array()
            .unwrap()
            .iter()
            .map(|t| t.as_str().unwrap().to_string())
            .collect();
        assert_eq!(times, r[&format!("{store}.times")], "{store}");
        assert_eq!(
            info["roles"],
            serde_json::json!(["time", "latitude", "longitude"])
        );
    }
}

#[test]
fn a_zarr_map_renders_and_damage_is_named() {
    let dir = tempfile::tempdir().unwrap();
    if reference(dir.path()).is_none() {
        return;
    }
    let script = r#"
        let g = load_grid("v3.zarr", #{ variable: "sst", at: #{ time: "1979-01-01T12:00" } });
        let img = render_surface(g, #{ mode: "direct", width: 64 });
        save_png(img, "sst.png");
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let (code, _, err) = hdrvis(&["run", "s.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(dir.path().join("o/sst.png").is_file());
    // A chunk cut short: one line naming the chunk file.
    let chunk = dir.path().join("v2.zarr/sst/0.0.0");
    let bytes = std::fs::read(&chunk).unwrap();
    std::fs::write(&chunk, &bytes[..bytes.len() / 2]).unwrap();
    let (code, _, err) = hdrvis(
        &[
            "info",
            dir.path().join("v2.zarr").to_str().unwrap(),
            "--variable",
            "sst",
        ],
        dir.path(),
    );
    assert_eq!(code, 1);
    assert!(
        err.trim().lines().count() == 1 && err.contains("sst/0.0.0") && err.contains("damaged"),
        "{err}"
    );
    // A folder that is no store.
    let (code, _, err) = hdrvis(
        &["info", dir.path().join("o").to_str().unwrap()],
        dir.path(),
    );
    assert_eq!(code, 1);
    assert!(err.contains("is a folder"), "{err}");
}
