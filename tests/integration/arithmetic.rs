//! Arithmetic on fields against numpy on the same arrays (tests/python/write_arithmetic_cases.py,
//! files written by netCDF4-python): differences, a number on either side, products, quotients
//! and nanmean / nanmin / nanmax / nanstd over time steps of grids equal numpy's exactly (f64);
//! volumes' differences and means equal numpy's rounded to f32. Units follow, and fields on other
//! axes or in other units are refused in one line. Scripts reach all of it through operators.

use crate::cli::{hdrvis, python_check};
use hdrvis::datasets::select::Selection;
use hdrvis::datasets::LoadOptions;
use hdrvis::model::arithmetic::{self, Op, Reduction, Side};
use hdrvis::model::{Grid, Volume};
use serde_json::Value;
use std::path::Path;

/// Writes the files into `dir` and returns numpy's results; `None` (skip) without netCDF4.
fn cases(dir: &Path) -> Option<Value> {
    let report = python_check("write_arithmetic_cases.py", &[dir.to_str().unwrap()])?;
    assert!(report.starts_with("exit 0\n"), "{report}");
    Some(serde_json::from_str(report.lines().nth(1).unwrap()).unwrap())
}

fn select(var: &str, dim: &str, i: i64) -> LoadOptions {
    LoadOptions {
        variable: Some(var.into()),
        select: Selection {
            index: vec![(dim.to_string(), i)],
            at: Vec::new(),
        },
        ..LoadOptions::default()
    }
}

fn sst(dir: &Path, t: i64) -> Grid {
    hdrvis::datasets::load_grid_with(&dir.join("sst.nc"), &select("sst", "time", t)).unwrap()
}

fn temp(dir: &Path, t: i64) -> Volume {
    hdrvis::datasets::load_volume_with(&dir.join("temp.nc"), &select("t", "time", t)).unwrap()
}

/// `got` equals numpy's `want` (null: missing) value for value, exactly.
fn assert_exact(what: &str, got: &[f64], want: &Value) {
    let want = want.as_array().unwrap();
    assert_eq!(got.len(), want.len(), "{what}");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        match w.as_f64() {
            Some(w) => assert_eq!(*g, w, "{what}: node {k}"),
            None => assert!(g.is_nan(), "{what}: node {k}: {g} where numpy has none"),
        }
    }
}

#[test]
fn grid_arithmetic_and_reductions_equal_numpy_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let Some(want) = cases(dir.path()) else {
        return;
    };
    let g: Vec<Grid> = (0..6).map(|t| sst(dir.path(), t)).collect();
    let prop = |x: &Grid| x.property("sst").unwrap().to_vec();
    let diff = arithmetic::grids(&g[3], Op::Sub, &g[0]).unwrap();
    assert_exact("g3 - g0", &prop(&diff), &want["jul_minus_jan"]);
    assert_eq!(diff.units(0), "K");
    let c = arithmetic::grid_number(&g[0], Op::Sub, 273.15, Side::Right).unwrap();
    assert_exact("g0 - 273.15", &prop(&c), &want["celsius"]);
    assert_eq!(c.units(0), "K");
    let twice = arithmetic::grid_number(&g[1], Op::Mul, 2.0, Side::Left).unwrap();
    assert_exact("2 * g1", &prop(&twice), &want["twice"]);
    let ratio = arithmetic::grids(&g[1], Op::Div, &g[2]).unwrap();
    assert_exact("g1 / g2", &prop(&ratio), &want["ratio"]);
    assert_eq!(ratio.units(0), "1");
    let product = arithmetic::grids(&g[0], Op::Mul, &g[1]).unwrap();
    assert_exact("g0 * g1", &prop(&product), &want["product"]);
    assert_eq!(product.units(0), "K K");
    let refs: Vec<&Grid> = g.iter().collect();
    for how in [
        Reduction::Mean,
        Reduction::Min,
        Reduction::Max,
        Reduction::Std,
    ] {
        let r = arithmetic::reduce_grids(&refs, how).unwrap();
        assert_exact(how.name(), &prop(&r), &want[how.name()]);
        assert_eq!(r.units(0), "K", "{}", how.name());
    }
    // The axes and the geography are the operands'.
    assert_eq!(diff.x().values, g[0].x().values);
    assert!(diff.is_geographic());
}

/// `load_grid(…, #{ mean: "time" })` and its kin read each step and reduce them: numpy's
/// nan-reductions over the file's axis, bit for bit, over all steps or a range of them; an
/// anomaly in one line of script; bad reductions refused in one line.
#[test]
fn reductions_over_a_file_dimension_equal_numpy_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let Some(want) = cases(dir.path()) else {
        return;
    };
    let path = dir.path().join("sst.nc");
    let reduce = |how, steps| LoadOptions {
        variable: Some("sst".into()),
        reduce: Some(hdrvis::datasets::ReduceOver {
            dim: "time".into(),
            how,
            steps,
        }),
        ..LoadOptions::default()
    };
    for how in [
        Reduction::Mean,
        Reduction::Min,
        Reduction::Max,
        Reduction::Std,
    ] {
        let g = hdrvis::datasets::load_grid_with(&path, &reduce(how, None)).unwrap();
        assert_exact(how.name(), g.property("sst").unwrap(), &want[how.name()]);
        assert_eq!(g.units(0), "K");
        assert!(g.is_geographic());
    }
    let part =
        hdrvis::datasets::load_grid_with(&path, &reduce(Reduction::Mean, Some((1, 4)))).unwrap();
    assert_exact(
        "mean 1..4",
        part.property("sst").unwrap(),
        &want["mean_1_4"],
    );
    assert!(
        part.name().contains("mean over time steps 1 to 4"),
        "{}",
        part.name()
    );
    let script = r#"
        let anomaly = load_grid("sst.nc", #{ variable: "sst", index: #{ time: 3 } }) - load_grid("sst.nc", #{ variable: "sst", mean: "time" });
        save_grid(anomaly, "anomaly.nc");
    "#;
    std::fs::write(dir.path().join("a.rhai"), script).unwrap();
    let (code, _, err) = crate::cli::hdrvis(&["run", "a.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    let saved = hdrvis::datasets::load_grid(&dir.path().join("o/anomaly.nc"), None).unwrap();
    assert_exact("anomaly", saved.property_at(0).1, &want["anomaly"]);
    for (opts, expected) in [
        (
            "mean: \"depth\"",
            "\"sst\" has no dimension \"depth\"; it has time, lat, lon",
        ),
        ("mean: \"time\", std: \"time\"", "one reduction per grid"),
        (
            "mean: \"time\", steps: [2, 9]",
            "steps 2 to 9 of \"time\", which has 6 (0 to 5)",
        ),
        (
            "mean: \"time\", index: #{ time: 1 }",
            "\"time\" is both reduced over and fixed",
        ),
        (
            "steps: [0, 1]",
            "steps: steps choose what mean, min, max or std reduce over",
        ),
    ] {
        let script = format!("let g = load_grid(\"sst.nc\", #{{ variable: \"sst\", {opts} }}); save_grid(g, \"g.nc\");");
        std::fs::write(dir.path().join("bad.rhai"), &script).unwrap();
        let (code, _, err) = crate::cli::hdrvis(&["run", "bad.rhai", "--out", "bad"], dir.path());
        assert_eq!(code, 1, "{opts}: {err}");
        assert!(
            err.lines().next().unwrap_or("").contains(expected),
            "{opts}: {err}"
        );
        assert!(!dir.path().join("bad/g.nc").exists());
    }
}

#[test]
fn volume_arithmetic_and_means_equal_numpy_within_f32_rounding() {
    let dir = tempfile::tempdir().unwrap();
    let Some(want) = cases(dir.path()) else {
        return;
    };
    let v: Vec<Volume> = (0..3).map(|t| temp(dir.path(), t)).collect();
    let as_f64 = |x: &Volume| x.data.iter().map(|&u| u as f64).collect::<Vec<_>>();
    let diff = arithmetic::volumes(&v[1], Op::Sub, &v[0]).unwrap();
    assert_exact("v1 - v0", &as_f64(&diff), &want["vol_diff"]);
    let refs: Vec<&Volume> = v.iter().collect();
    let mean = arithmetic::reduce_volumes(&refs, Reduction::Mean).unwrap();
    assert_exact("mean", &as_f64(&mean), &want["vol_mean"]);
    assert_eq!((diff.units.as_str(), mean.units.as_str()), ("K", "K"));
    assert_eq!(diff.dims, v[0].dims);
}

#[test]
fn fields_on_other_axes_or_in_other_units_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    if cases(dir.path()).is_none() {
        return;
    }
    let a = sst(dir.path(), 0);
    let small = Grid::from_arrays("small", 3, 2, vec![("sst".into(), vec![1.0; 6])]).unwrap();
    let e = arithmetic::grids(&a, Op::Sub, &small)
        .unwrap_err()
        .to_string();
    assert!(e.contains("lie on other axes") && !e.contains('\n'), "{e}");
    let c = arithmetic::grid_with_units(&a, "degC").unwrap();
    let e = arithmetic::grids(&a, Op::Add, &c).unwrap_err().to_string();
    assert!(
        e.contains("\"K\" + \"degC\"") && e.contains("with_units"),
        "{e}"
    );
    let e = arithmetic::reduce_grids(&[&a, &c], Reduction::Mean)
        .unwrap_err()
        .to_string();
    assert!(e.contains("degC"), "{e}");
    let v0 = temp(dir.path(), 0);
    let other = Volume::new("other", [2, 2, 2], [1.0; 3], [0.0; 3], vec![0.0; 8]).unwrap();
    let e = arithmetic::volumes(&v0, Op::Add, &other)
        .unwrap_err()
        .to_string();
    assert!(e.contains("lie on other voxels"), "{e}");
}

/// The operators from a script: an anomaly against the climatology of six steps, saved with
/// save_grid and read back, equals numpy's; a bad combination is a one-line error.
#[test]
fn scripts_make_an_anomaly_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let Some(want) = cases(dir.path()) else {
        return;
    };
    let script = r#"
let steps = [];
for t in 0..6 { steps.push(load_grid("sst.nc", #{ variable: "sst", index: #{ time: t } })); }
let clim = mean(steps);
let anomaly = steps[3] - clim;
let celsius = with_units(steps[0] - 273.15, "degC");
save_grid(anomaly, "anomaly.nc");
save_grid(celsius, "celsius.nc");
save_grid(2 * steps[1], "twice.nc");
print(`${anomaly.name}`);
"#;
    std::fs::write(dir.path().join("a.rhai"), script).unwrap();
    let (code, out, err) = hdrvis(&["run", "a.rhai", "--out", "out"], dir.path());
    assert_eq!(code, 0, "{out}{err}");
    let read = |f: &str| {
        hdrvis::datasets::load_grid_with(
            &dir.path().join("out").join(f),
            &LoadOptions {
                variable: Some("sst".into()),
                ..LoadOptions::default()
            },
        )
        .unwrap()
    };
    let g3: Vec<f64> = want["mean"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap_or(f64::NAN))
        .collect();
    let steps3 = sst(dir.path(), 3);
    let expect: Vec<Value> = steps3
        .property("sst")
        .unwrap()
        .iter()
        .zip(&g3)
        .map(|(a, m)| {
            serde_json::json!(if (a - m).is_finite() {
                Some(a - m)
            } else {
                None
            })
        })
        .collect();
    assert_exact(
        "anomaly",
        read("anomaly.nc").property("sst").unwrap(),
        &Value::Array(expect),
    );
    let c = read("celsius.nc");
    assert_exact("celsius", c.property("sst").unwrap(), &want["celsius"]);
    assert_eq!(c.units(0), "degC");
    assert_exact(
        "twice",
        read("twice.nc").property("sst").unwrap(),
        &want["twice"],
    );
    // A grid and a volume do not combine.
    std::fs::write(
        dir.path().join("bad.rhai"),
        "let g = load_grid(\"sst.nc\", #{ variable: \"sst\", index: #{ time: 0 } }); let x = g - generate_mantle(#{ n: 4 }); save_grid(x, \"x.nc\");",
    )
    .unwrap();
    let (code, _, err) = hdrvis(&["run", "bad.rhai", "--out", "bad"], dir.path());
    assert_eq!(code, 1, "{err}");
    assert!(
        err.lines()
            .next()
            .unwrap_or("")
            .contains("wrong arguments in call - (Grid, Volume)"),
        "{err}"
    );
    assert!(!dir.path().join("bad/x.nc").exists());
}
