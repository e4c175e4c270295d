//! Files shaped as climate archives write them (tests/python/write_archive_cases.py, written by
//! netCDF4-python with CORDEX's, CMIP5's and old NetCDF-3 examples' variables and attributes)
//! read as xarray's `isel` reads them: a `char` grid mapping, a 2 m `height` as a scalar and as
//! a size-1 dimension, `months since` in two calendars, a time axis of missing values and a
//! classic header longer than 64 KiB.

use crate::cli::hdrvis;
use crate::common::{assert_values, python_reference, reference_numbers as numbers};
use hdrvis::datasets::select::Selection;
use hdrvis::datasets::LoadOptions;
use std::collections::HashMap;
use std::path::Path;

fn reference(dir: &Path, case: &str) -> Option<HashMap<String, Vec<String>>> {
    python_reference("write_archive_cases.py", dir, case)
}

/// `path`'s variable `var` with `index` fixed, read by `load_grid` (which must succeed) and as
/// stored by `read_grid`.
fn grid_values(path: &Path, var: &str, index: &[(&str, i64)]) -> Vec<f64> {
    let sel = Selection {
        index: index.iter().map(|(d, i)| (d.to_string(), *i)).collect(),
        at: Vec::new(),
    };
    let opts = LoadOptions {
        variable: Some(var.to_string()),
        select: sel.clone(),
        ..LoadOptions::default()
    };
    hdrvis::datasets::load_grid_with(path, &opts)
        .unwrap_or_else(|e| panic!("load_grid {}: {e}", path.display()));
    hdrvis::datasets::read_grid_with(path, Some(var), &sel)
        .unwrap()
        .data
}

/// `hdrvis info --json` of `var` as a JSON value; the report must succeed too.
fn info_json(path: &Path, var: &str) -> serde_json::Value {
    let cwd = path.parent().unwrap();
    let file = path.to_str().unwrap();
    let (code, _, err) = hdrvis(&["info", file, "--variable", var], cwd);
    assert_eq!(code, 0, "info {file}: {err}");
    let (code, out, err) = hdrvis(&["info", "--json", file, "--variable", var], cwd);
    assert_eq!(code, 0, "info --json {file}: {err}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

fn words(v: &serde_json::Value) -> Vec<String> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap_or("null").to_string())
        .collect()
}

#[test]
fn a_cordex_file_with_a_char_grid_mapping_reads_as_xarray_reads_it() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "cordex") else {
        return;
    };
    let path = dir.path().join("tas_EUR-11_cordex.nc");
    let got = grid_values(&path, "tas", &[("time", 1)]);
    assert_values(&got, &numbers(&r, "tas.t1"), 0.0, "tas at time 1");
    let info = info_json(&path, "tas");
    assert_eq!(words(&info["times"]), r["time"]);
    assert_eq!(info["missing"], 1);
    for axis in ["rlat", "rlon"] {
        let coords: Vec<f64> = info["coords"][axis]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_values(&coords, &numbers(&r, axis), 0.0, axis);
    }
    // The rotated pole comes from the char variable's attributes.
    let (_, report, _) = hdrvis(
        &["info", path.to_str().unwrap(), "--variable", "tas"],
        dir.path(),
    );
    assert!(
        report.contains("rotated pole at 39.25°N -162°E"),
        "{report}"
    );
}

#[test]
fn a_two_metre_height_is_a_label_as_a_scalar_and_as_a_size_one_axis() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "cmip") else {
        return;
    };
    let scalar = dir.path().join("tas_Amon_cmip.nc");
    let got = grid_values(&scalar, "tas", &[("time", 2)]);
    assert_values(&got, &numbers(&r, "tas.t2"), 0.0, "tas at time 2");
    assert_eq!(words(&info_json(&scalar, "tas")["times"]), r["time"]);
    let sized = dir.path().join("tas_height.nc");
    let got = grid_values(&sized, "tas", &[("time", 2)]);
    assert_values(
        &got,
        &numbers(&r, "tas_height.t2"),
        0.0,
        "tas(height=1) at time 2",
    );
    let info = info_json(&sized, "tas");
    assert_eq!(info["shape"], serde_json::json!([4, 1, 12, 16]));
    assert_eq!(
        words(&info["roles"]),
        ["time", "vertical", "latitude", "longitude"]
    );
}

#[test]
fn months_since_decode_by_cftime_in_360_day_and_by_udunits_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "months") else {
        return;
    };
    for key in ["months", "months_std"] {
        let path = dir.path().join(format!("{key}.nc"));
        let got = grid_values(&path, "sst", &[("time", 3)]);
        assert_values(&got, &numbers(&r, &format!("{key}.sst.t3")), 0.0, key);
    }
    // cftime decodes the 360_day axis; hdrvis gives the same dates.
    let info = info_json(&dir.path().join("months.nc"), "sst");
    assert_eq!(words(&info["times"]), r["months.time"]);
    // xarray leaves the standard-calendar axis as numbers; hdrvis keeps them as stored and dates
    // them by udunits' month (365.242198781 / 12 days), saying so.
    let info = info_json(&dir.path().join("months_std.nc"), "sst");
    let raw: Vec<f64> = r["months_std.time"][1..]
        .iter()
        .map(|w| w.parse().unwrap())
        .collect();
    let coords: Vec<f64> = info["coords"]["time"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap())
        .collect();
    assert_eq!(coords, raw);
    assert_eq!(words(&info["times"])[4], "1960-02-16T03:21:08");
    assert!(info["note"].as_str().unwrap().contains("udunits"));
}

#[test]
fn absolute_day_time_axes_of_cdo_and_icon_are_dates() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "absolute") else {
        return;
    };
    let path = dir.path().join("absolute_time.nc");
    let info = info_json(&path, "ts");
    assert_eq!(words(&info["times"]), r["absolute.time"]);
    assert!(
        info["note"].as_str().unwrap_or("").contains("YYYYMMDD"),
        "{info}"
    );
    // Selection by date on it, as on any CF time axis.
    let sel = Selection {
        index: Vec::new(),
        at: vec![(
            "time".to_string(),
            hdrvis::datasets::select::At::Date("2024-02-29T12:00".into()),
        )],
    };
    let (_, got) = hdrvis::datasets::read_values(&path, Some("ts"), &sel).unwrap();
    assert_values(
        &got,
        &numbers(&r, "absolute.ts.t2"),
        0.0,
        "ts at 2024-02-29T12",
    );
}

#[test]
fn a_time_axis_of_missing_values_stays_numbers_and_the_data_read() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "nat") else {
        return;
    };
    let path = dir.path().join("all_missing_time.nc");
    let got = grid_values(&path, "precip", &[("time", 1)]);
    assert_values(&got, &numbers(&r, "precip.t1"), 0.0, "precip at time 1");
    let info = info_json(&path, "precip");
    assert!(info["times"].is_null());
    assert!(
        info["note"]
            .as_str()
            .unwrap()
            .contains("only missing values"),
        "{info}"
    );
}

#[test]
fn a_classic_header_longer_than_64_kib_reads() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "longhdr") else {
        return;
    };
    assert!(numbers(&r, "header_bytes")[0] > 65536.0);
    let path = dir.path().join("long_header.nc");
    let got = hdrvis::datasets::read_grid(&path, Some("elevation"))
        .unwrap()
        .data;
    assert_values(&got, &numbers(&r, "elevation"), 0.0, "elevation");
}

#[test]
fn cf_attributes_of_a_plain_hdf5_dataset_decode_as_netcdf_c_decodes_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "h5cf") else {
        return;
    };
    let path = dir.path().join("cf.h5");
    let got = hdrvis::datasets::read_grid(&path, Some("/sst"))
        .unwrap()
        .data;
    let (nc, xr) = (numbers(&r, "netcdf4"), numbers(&r, "xarray"));
    for (i, ((g, n), x)) in got.iter().zip(&nc).zip(&xr).enumerate() {
        // netCDF-C masks valid_range too, which xarray leaves (the 32000 stored at index 4).
        assert!(
            (g.is_nan() && n.is_nan()) || (g - n).abs() <= 1e-6 * n.abs(),
            "[{i}] {g}, netCDF4-python {n}"
        );
        assert!(i == 4 || (g.is_nan() && x.is_nan()) || (g - x).abs() <= 1e-6 * x.abs());
    }
    assert!(got[2].is_nan() && got[4].is_nan() && !xr[4].is_nan());
}

#[test]
fn an_hdf5_file_with_dimension_scales_reads_through_cf_as_netcdf_does() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "h5dims") else {
        return;
    };
    let path = dir.path().join("dims.h5");
    // Named .h5, laid out as NetCDF-4: dimensions, CF roles, a noleap calendar and masking.
    let got = grid_values(&path, "t2m", &[("time", 1)]);
    assert_values(&got, &numbers(&r, "t2m.t1"), 0.0, "t2m at time 1");
    assert!(got[0].is_nan());
    let info = info_json(&path, "/t2m");
    assert_eq!(words(&info["roles"]), ["time", "latitude", "longitude"]);
    assert_eq!(words(&info["times"]), r["time"]);
}

#[test]
fn variables_in_groups_are_named_as_not_read_yet() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "groups") else {
        return;
    };
    assert_eq!(r["groups"], ["PRODUCT"]);
    let groups = "/PRODUCT (1 variable), /PRODUCT/SUPPORT_DATA (1 variable)";
    for args in [
        vec!["info", "groups.nc"],
        vec!["info", "groups.nc", "--variable", "ch4"],
    ] {
        let (code, _, err) = hdrvis(&args, dir.path());
        assert_ne!(code, 0);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(
            err.contains(&format!("variables in groups ({groups}) are not read yet")),
            "{err}"
        );
    }
    let (code, out, err) = hdrvis(&["info", "groups.nc", "--variable", "time"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains(&format!(
            "groups, not read yet (only the root group's variables are): {groups}"
        )),
        "{out}"
    );
}

#[test]
fn bad_input_is_one_line_naming_the_file_and_what_was_expected() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A NetCDF file cut short, a PNG named .nc, a GRIB message, text of no format, and text
    // named .nc (its reader says what it lacks).
    let (code, _, err) = hdrvis(&["gen", "okada", "--n", "8", "-o", "whole.nc"], d);
    assert_eq!(code, 0, "{err}");
    let bytes = std::fs::read(d.join("whole.nc")).unwrap();
    std::fs::write(d.join("cut.nc"), &bytes[..bytes.len() / 2]).unwrap();
    std::fs::write(d.join("picture.nc"), b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR").unwrap();
    std::fs::write(d.join("forecast.grib2"), b"GRIB\0\0\0\x02rest").unwrap();
    std::fs::write(d.join("notes.dat"), b"station,temp\n1,2\n").unwrap();
    std::fs::write(d.join("table.nc"), b"station,temp\n1,2\n").unwrap();
    for (file, expect) in [
        ("cut.nc", "cut.nc"),
        (
            "picture.nc",
            "named as NetCDF but not one (it is a PNG image",
        ),
        (
            "forecast.grib2",
            "message 0 (offset 0): the file ends inside its indicator section (truncated)",
        ),
        (
            "notes.dat",
            "not a format hdrvis reads (it begins \"station,\")",
        ),
        ("table.nc", "table.nc: not a readable NetCDF file"),
    ] {
        for args in [vec!["info", file], vec!["info", "--json", file]] {
            let (code, out, err) = hdrvis(&args, d);
            assert_ne!(code, 0, "{file}: {out}");
            assert!(out.is_empty(), "{file}: wrote {out}");
            assert_eq!(err.trim().lines().count(), 1, "{file}: {err}");
            assert!(err.contains(expect), "{file}: {err}");
        }
    }
}
