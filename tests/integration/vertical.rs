//! CF parametric vertical coordinates on files written by netCDF4-python
//! (tests/python/write_vertical_cases.py): a CAM-like hybrid sigma–pressure field with CF's
//! formula_terms and with NCAR's A_var/B_var/PS_var attributes, and a ROMS-like ocean
//! s-coordinate (g2) field. `at: #{ pressure: P }` and `at: #{ depth: d }` must equal an
//! independent numpy implementation of vinth2p's rule (linear in ln p between the bracketing
//! levels, no extrapolation) and of CF's g2 formula within 1e-5 relative, missing where the
//! column does not reach the level.

use crate::cli::hdrvis;
use crate::common::{assert_values, python_report, reference_numbers};
use hdrvis::datasets::select::{At, Selection};
use std::collections::HashMap;
use std::path::Path;

fn reference(dir: &Path) -> Option<HashMap<String, Vec<f64>>> {
    let report = python_report("write_vertical_cases.py", &[dir.to_str().unwrap()])?;
    Some(
        report
            .keys()
            .map(|k| (k.clone(), reference_numbers(&report, k)))
            .collect(),
    )
}

fn at(
    path: &Path,
    var: &str,
    key: &str,
    value: f64,
    index: &[(&str, i64)],
) -> hdrvis::Result<Vec<f64>> {
    let sel = Selection {
        index: index.iter().map(|(d, i)| (d.to_string(), *i)).collect(),
        at: vec![(key.to_string(), At::Value(value))],
    };
    hdrvis::datasets::read_values(path, Some(var), &sel).map(|(dims, data)| {
        assert!(
            !dims.iter().any(|(d, _)| d == "lev" || d == "s_rho"),
            "{dims:?}"
        );
        data
    })
}

/// `got` equals `want` within 1e-5 relative, NaN where `want` is NaN.
fn close(got: &[f64], want: &[f64], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        if w.is_nan() {
            assert!(g.is_nan(), "{what}[{i}]: {g}, missing in the reference");
        } else {
            assert!((g - w).abs() <= 1e-5 * w.abs(), "{what}[{i}]: {g} vs {w}");
        }
    }
}

#[test]
fn hybrid_levels_interpolate_to_pressure_as_vinth2p_does() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path()) else {
        return;
    };
    let cf = dir.path().join("hybrid_cf.nc");
    close(
        &at(&cf, "T", "pressure", 500.0, &[("time", 1)]).unwrap(),
        &r["hybrid.p500"],
        "500 hPa",
    );
    let p1000 = at(&cf, "T", "pressure", 1000.0, &[("time", 1)]).unwrap();
    close(&p1000, &r["hybrid.p1000"], "1000 hPa");
    assert!(p1000.iter().any(|v| v.is_nan()) && p1000.iter().any(|v| !v.is_nan()));
    let ncar = dir.path().join("hybrid_ncar.nc");
    close(
        &at(&ncar, "T", "pressure", 850.0, &[("time", 0)]).unwrap(),
        &r["hybrid_ncar.p850"],
        "NCAR form, 850 hPa",
    );
}

#[test]
fn ocean_s_levels_interpolate_to_depth_by_cf_formula() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path()) else {
        return;
    };
    let ocean = dir.path().join("ocean_s.nc");
    let got = at(&ocean, "temp", "depth", 100.0, &[("ocean_time", 0)]).unwrap();
    close(&got, &r["ocean.d100"], "100 m");
    let same = at(&ocean, "temp", "height", -100.0, &[("ocean_time", 0)]).unwrap();
    assert_values(&same, &got, 0.0, "height -100 m is depth 100 m");
}

#[test]
fn levels_no_column_reaches_are_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    if reference(dir.path()).is_none() {
        return;
    }
    let cf = dir.path().join("hybrid_cf.nc");
    let err = at(&cf, "T", "pressure", 1.0, &[("time", 0)])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("hybrid_cf.nc") && err.contains("pressure 1 lies outside every column"),
        "{err}"
    );
    let err = at(
        &dir.path().join("ocean_s.nc"),
        "temp",
        "pressure",
        500.0,
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("ask for height or depth, not pressure"),
        "{err}"
    );
    let err = at(&cf, "PS", "pressure", 500.0, &[])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("no dimension 'pressure'") && err.contains("parametric vertical coordinate"),
        "{err}"
    );
    let script = r#"
        let g = load_grid("hybrid_cf.nc", #{ variable: "T", at: #{ pressure: 2000.0 }, index: #{ time: 0 } });
        save_grid(g, "t.nc");
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let (code, _, err) = hdrvis(&["run", "s.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 1);
    assert!(err.contains("outside every column"), "{err}");
    assert!(!dir.path().join("o/t.nc").exists());
}

#[test]
fn a_pressure_map_renders_from_a_script() {
    let dir = tempfile::tempdir().unwrap();
    if reference(dir.path()).is_none() {
        return;
    }
    let script = r#"
        let g = load_grid("hybrid_ncar.nc", #{ variable: "T", at: #{ pressure: 500.0 }, index: #{ time: 0 } });
        print(g.name);
        save_grid(g, "t500.nc");
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let (code, out, err) = hdrvis(&["run", "s.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("pressure 500 hPa: interpolated linearly in ln p"),
        "{out}"
    );
    let (_, data) =
        hdrvis::datasets::read_values(&dir.path().join("o/t500.nc"), None, &Selection::default())
            .unwrap();
    assert!(
        data.iter()
            .all(|v| v.is_finite() && *v > 200.0 && *v < 300.0),
        "{data:?}"
    );
}
