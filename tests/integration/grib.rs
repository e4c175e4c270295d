//! GRIB files written by ecCodes (tests/python/write_grib_cases.py, the `eccodes` wheel): one
//! GRIB2 file per packing (simple, complex, complex with spatial differencing, JPEG 2000, PNG,
//! CCSDS) and per grid (regular and Gaussian latitude–longitude, rotated, Lambert conformal,
//! polar stereographic, Mercator), a bitmap, a forecast of several levels and steps, an ensemble,
//! GRIB1 simple packing on regular, Gaussian, Mercator, Lambert and polar grids, reduced Gaussian
//! grids (read filled onto the regular grid) and model levels with their PV array (read at a
//! pressure). Every message read by hdrvis must equal what ecCodes reads: its values (missing
//! where the bitmap says), and its nodes' latitudes and longitudes within 1e-6°.
use crate::cli::{hdrvis, python_check};
use hdrvis::datasets::select::{At, Selection};
use hdrvis::datasets::LoadOptions;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Writes the cases into `dir`; their ecCodes reference, or `None` (skip) without ecCodes.
fn cases(dir: &Path) -> Option<Value> {
    let report = python_check("write_grib_cases.py", &[dir.to_str().unwrap()])?;
    assert!(report.starts_with("exit 0\n"), "{report}");
    let text = std::fs::read_to_string(dir.join("reference.json")).unwrap();
    Some(serde_json::from_str(&text).unwrap())
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap_or(f64::NAN))
        .collect()
}

fn message(index: i64) -> Selection {
    Selection {
        index: vec![("message".to_string(), index)],
        at: Vec::new(),
    }
}

/// The longitude difference folded into [−180°, 180°).
fn lon_gap(a: f64, b: f64) -> f64 {
    (a - b + 540.0).rem_euclid(360.0) - 180.0
}

/// The latitudes and longitudes of every node of a grid of dimensions `dims`, in the message's
/// value order: from 1-D `latitude` and `longitude` coordinates, or the 2-D ones of a projected
/// or rotated grid.
fn nodes(path: &Path, dims: &[(String, usize)]) -> (Vec<f64>, Vec<f64>) {
    let read = |name: &str| {
        hdrvis::datasets::read_values(path, Some(name), &Selection::default())
            .unwrap()
            .1
    };
    let (lat, lon) = (read("latitude"), read("longitude"));
    let [(_, ny), (_, nx)] = [dims[0].clone(), dims[1].clone()];
    if lat.len() == ny && lon.len() == nx {
        (
            (0..ny * nx).map(|k| lat[k / nx]).collect(),
            (0..ny * nx).map(|k| lon[k % nx]).collect(),
        )
    } else {
        (lat, lon)
    }
}

#[test]
fn every_message_equals_what_eccodes_reads() {
    let dir = tempfile::tempdir().unwrap();
    let Some(reference) = cases(dir.path()) else {
        return;
    };
    let mut checked = 0;
    for file in reference["files"].as_array().unwrap() {
        let path = dir.path().join(file["file"].as_str().unwrap());
        for m in file["messages"].as_array().unwrap() {
            let k = m["message"].as_i64().unwrap();
            let what = format!("{}[{k}] ({})", path.display(), m["packingType"]);
            let (dims, data) = hdrvis::datasets::read_values(&path, None, &message(k))
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            // Maps read it too (a projected grid regridded onto latitude and longitude).
            let opts = LoadOptions {
                select: message(k),
                resolution: (dims[0].0 == "y").then_some(1.0),
                ..LoadOptions::default()
            };
            hdrvis::datasets::load_grid_with(&path, &opts)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            // A reduced grid reads as the regular grid of its longest row, filled along rows:
            // the reference is numpy's periodic interpolation of ecCodes' values.
            let on_grid = m.get("regular").unwrap_or(m);
            let want = numbers(&on_grid["values"]);
            assert_eq!(data.len(), want.len(), "{what}");
            // ecCodes decodes in double precision; the GRIB2 decoders give single precision
            // (2.4e-7 relative: two roundings of f32), GRIB1's is double.
            let relative = if m["edition"] == 2 { 2.4e-7 } else { 1e-12 };
            for (i, (got, want)) in data.iter().zip(&want).enumerate() {
                if want.is_nan() {
                    assert!(
                        got.is_nan(),
                        "{what}: point {i} is missing in ecCodes, {got} here"
                    );
                } else {
                    assert!(
                        (got - want).abs() <= relative * want.abs(),
                        "{what}: point {i}: {got} vs {want}"
                    );
                }
            }
            let (lats, lons) = nodes(&path, &dims);
            // ecCodes gives rotated grids' true coordinates to about 1e-6° (node 2 of the rotated
            // case: 65.706148° where PROJ's ob_tran and hdrvis give 65.7061468601°).
            let tol_deg = if m["gridType"] == "rotated_ll" {
                2e-6
            } else {
                1e-6
            };
            for (i, (la, lo)) in lats.iter().zip(&lons).enumerate() {
                let (wla, wlo) = (
                    on_grid["latitudes"][i].as_f64().unwrap(),
                    on_grid["longitudes"][i].as_f64().unwrap(),
                );
                assert!(
                    (la - wla).abs() < tol_deg,
                    "{what}: latitude {i}: {la} vs {wla}"
                );
                assert!(
                    lon_gap(*lo, wlo).abs() < tol_deg,
                    "{what}: longitude {i}: {lo} vs {wlo}"
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 50, "{checked} messages");
}

#[test]
fn messages_group_into_variables_by_level_step_and_member() {
    let dir = tempfile::tempdir().unwrap();
    let Some(reference) = cases(dir.path()) else {
        return;
    };
    let forecast = dir.path().join("forecast.grib2");
    let messages: Vec<&Value> = reference["files"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["file"] == "forecast.grib2")
        .unwrap()["messages"]
        .as_array()
        .unwrap()
        .iter()
        .collect();
    // t at 500 hPa, step 6 h, by name and level, equals the message ecCodes lists for it.
    let opts = LoadOptions {
        variable: Some("t".into()),
        select: Selection {
            index: vec![("step".into(), 1)],
            at: vec![("isobaricInhPa".into(), At::Value(500.0))],
        },
        ..LoadOptions::default()
    };
    hdrvis::datasets::load_grid_with(&forecast, &opts).unwrap();
    let grid = hdrvis::datasets::read_grid_with(&forecast, Some("t"), &opts.select).unwrap();
    let want = messages
        .iter()
        .find(|m| m["shortName"] == "t" && m["level"] == 500 && m["step"] == 6)
        .unwrap();
    let expected = numbers(&want["values"]);
    let worst = grid
        .data
        .iter()
        .zip(&expected)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-3, "t at 500 hPa, step 6: off by {worst}");

    // The variables and their dimensions, as cfgrib lists them.
    let file = forecast.to_str().unwrap();
    let (code, out, err) = hdrvis(&["info", "--json", file, "--variable", "t"], dir.path());
    assert_eq!(code, 0, "{err}");
    let info: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(
        info["dims"],
        serde_json::json!(["step", "isobaricInhPa", "latitude", "longitude"])
    );
    assert_eq!(
        info["coords"]["isobaricInhPa"],
        serde_json::json!([850.0, 500.0, 250.0])
    );
    assert_eq!(info["coords"]["step"], serde_json::json!([0.0, 6.0]));
    let (code, out, _) = hdrvis(&["info", "--json", file, "--variable", "u"], dir.path());
    assert_eq!(code, 0);
    let info: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(
        info["dims"],
        serde_json::json!(["step", "latitude", "longitude"])
    );

    let ensemble = dir.path().join("ensemble.grib2");
    let (code, out, err) = hdrvis(&["info", "--json", ensemble.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    let info: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(
        info["dims"],
        serde_json::json!(["number", "latitude", "longitude"])
    );
    assert_eq!(
        info["coords"]["number"],
        serde_json::json!([0.0, 1.0, 2.0, 3.0])
    );
}

#[test]
fn grib_maps_render_from_a_script() {
    let dir = tempfile::tempdir().unwrap();
    if cases(dir.path()).is_none() {
        return;
    }
    let script = r#"
        let g = load_grid("forecast.grib2", #{ variable: "t", at: #{ isobaricInhPa: 850.0 }, index: #{ step: 0 } });
        let s = grid_stats(g, "t");
        print(`${s.min} ${s.max}`);
        let img = render_surface(g, #{ mode: "direct", width: 64 });
        save_png(img, "t850.png");
        let m = load_grid("lambert.grib2", #{ index: #{ message: 0 }, resolution: 1.0 });
        print(`${m.nx} ${m.ny}`);
    "#;
    std::fs::write(dir.path().join("g.rhai"), script).unwrap();
    let (code, out, err) = hdrvis(&["run", "g.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    let mut lines = out.lines().filter(|l| !l.starts_with("wrote "));
    let range: Vec<f64> = lines
        .next()
        .unwrap()
        .split(' ')
        .map(|w| w.parse().unwrap())
        .collect();
    assert!(
        range[0] > 200.0 && range[1] < 320.0 && range[0] < range[1],
        "{out}"
    );
    assert!(dir.path().join("o/t850.png").is_file());
    let shape: Vec<usize> = lines
        .next()
        .unwrap()
        .split(' ')
        .map(|w| w.parse().unwrap())
        .collect();
    assert!(shape[0] > 1 && shape[1] > 1, "{out}");
}

#[test]
fn damaged_grib_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    if cases(dir.path()).is_none() {
        return;
    }
    let whole = std::fs::read(dir.path().join("forecast.grib2")).unwrap();
    let cut: PathBuf = dir.path().join("cut.grib2");
    std::fs::write(&cut, &whole[..whole.len() - 100]).unwrap();
    let (code, _, err) = hdrvis(&["info", cut.to_str().unwrap()], dir.path());
    assert_eq!(code, 1);
    let line = err.trim();
    assert!(
        !line.contains('\n')
            && line.contains("cut.grib2")
            && line.contains("message 7")
            && line.contains("truncated"),
        "{line}"
    );
    let err =
        hdrvis::datasets::read_grid_with(&dir.path().join("forecast.grib2"), None, &message(8))
            .unwrap_err()
            .to_string();
    assert!(
        err.contains("index 8 is outside the file's messages 0..8"),
        "{err}"
    );
    // An unknown grid template: template number 3.90 (space view) patched into section 3.
    let mut patched = std::fs::read(dir.path().join("grid_simple.grib2")).unwrap();
    let sect3 = 16 + u32::from_be_bytes(patched[16..20].try_into().unwrap()) as usize;
    let at = if patched[sect3 + 4] == 3 {
        sect3
    } else {
        sect3 + u32::from_be_bytes(patched[sect3..sect3 + 4].try_into().unwrap()) as usize
    };
    assert_eq!(patched[at + 4], 3, "section 3 found");
    patched[at + 12..at + 14].copy_from_slice(&90u16.to_be_bytes());
    let odd = dir.path().join("space_view.grib2");
    std::fs::write(&odd, &patched).unwrap();
    let (code, _, err) = hdrvis(&["info", odd.to_str().unwrap()], dir.path());
    assert_eq!(code, 1);
    assert!(
        err.contains("message 0") && err.contains("template 3.90"),
        "{err}"
    );
}

#[test]
fn model_levels_interpolate_to_pressure_from_the_pv_array() {
    let dir = tempfile::tempdir().unwrap();
    let Some(reference) = cases(dir.path()) else {
        return;
    };
    let mut compared = 0;
    for (file, targets) in reference["model_levels"].as_object().unwrap() {
        let path = dir.path().join(file);
        for (hpa, want) in targets.as_object().unwrap() {
            let sel = Selection {
                index: Vec::new(),
                at: vec![("pressure".into(), At::Value(hpa.parse().unwrap()))],
            };
            let (dims, got) = hdrvis::datasets::read_values(&path, Some("t"), &sel)
                .unwrap_or_else(|e| panic!("{file} at {hpa} hPa: {e}"));
            assert_eq!(dims.len(), 2, "{file}: {dims:?}");
            let want = numbers(want);
            assert_eq!(got.len(), want.len(), "{file}");
            // The pressure of each level from the PV array and e^lnsp or sp, then linear in
            // ln p: numpy's rule of vinth2p on ecCodes' decoded values, within 1e-5 relative.
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(
                    (g - w).abs() <= 1e-5 * w.abs(),
                    "{file} at {hpa} hPa, point {i}: {g} vs {w}"
                );
            }
            compared += 1;
        }
    }
    assert_eq!(compared, 3);
    // Under the lowest model level everywhere (its pressure is at most 948 hPa): one line.
    let path = dir.path().join("model_levels.grib2");
    let sel = Selection {
        index: Vec::new(),
        at: vec![("pressure".into(), At::Value(1000.0))],
    };
    let err = hdrvis::datasets::read_values(&path, Some("t"), &sel)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("model_levels.grib2") && err.contains("outside every column"),
        "{err}"
    );
}
