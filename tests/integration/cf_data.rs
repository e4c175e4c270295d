//! NetCDF as real files come, against what the reference tools make of the same files
//! (tests/python/write_cf_cases.py): netCDF's default fill values, auxiliary variables, longitudes
//! across the prime meridian, CF time in two calendars and selection by dimension.

use crate::cli::hdrvis;
use crate::common::{assert_values, python_reference, reference_numbers as numbers};
use hdrvis::datasets::select::{At, Selection};
use hdrvis::datasets::LoadOptions;
use hdrvis::model::CoordKind;
use std::collections::HashMap;
use std::path::Path;

/// The files of `case` written into `dir` and the reference values, by key (write_cf_cases.py);
/// `None` when the Python modules are missing.
fn reference(dir: &Path, case: &str) -> Option<HashMap<String, Vec<String>>> {
    python_reference("write_cf_cases.py", dir, case)
}

#[test]
fn default_fill_values_are_missing_as_netcdf4_python_masks_them() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "fills") else {
        return;
    };
    let path = dir.path().join("fills.nc");
    for var in ["t", "n", "s", "u"] {
        let want = numbers(&r, &format!("{var}.values"));
        let got: Vec<f64> = if var == "t" {
            let v = hdrvis::datasets::load_volume_var(&path, Some(var)).unwrap();
            v.data.iter().map(|&x| f64::from(x)).collect()
        } else {
            hdrvis::datasets::read_grid(&path, Some(var)).unwrap().data
        };
        assert_values(&got, &want, 0.0, var);
        let (code, out, err) = hdrvis(
            &["info", path.to_str().unwrap(), "--variable", var],
            dir.path(),
        );
        assert_eq!(code, 0, "{err}");
        let masked = numbers(&r, &format!("{var}.masked"))[0];
        let max = numbers(&r, &format!("{var}.max"))[0];
        assert!(
            out.contains(&format!(
                "missing: {masked} NaN (of which {masked} fill values)"
            )),
            "{var}: {out}"
        );
        assert!(out.contains(&format!("max: {max:.6e}")), "{var}: {out}");
    }
}

#[test]
fn auxiliary_variables_are_not_chosen_as_data() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "aux") else {
        return;
    };
    let path = dir.path().join("aux.nc");
    // xarray wrote the ancillary `qc` (3-D too) first: the default is still `temp`.
    assert_eq!(r["order"][..2], ["qc", "temp"]);
    // temp's latitude and longitude are 2-D (a curvilinear grid): no volume on the sphere; in
    // index space with geometry "cartesian".
    let e = hdrvis::datasets::load_volume(&path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("variable \"temp\" is on a curvilinear grid (latitude and longitude are 2-D)")
            && e.contains("geometry: \"cartesian\""),
        "{e}"
    );
    let cartesian = LoadOptions {
        cartesian: true,
        ..LoadOptions::default()
    };
    let v = hdrvis::datasets::load_volume_with(&path, &cartesian).unwrap();
    assert_eq!(v.name, "temp");
    let e = hdrvis::datasets::bricked::open_bricked(&path, Some("temp"), 32)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("'temp' lies on a curvilinear grid (2-D latitude and longitude)"),
        "{e}"
    );
    let got: Vec<f64> = v.data.iter().map(|&x| f64::from(x)).collect();
    assert_values(&got, &numbers(&r, "temp"), 0.0, "temp");
    let (code, out, err) = hdrvis(&["info", path.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("variable: temp"), "{out}");
    for aux in ["qc", "crs", "z_bnds", "latitude", "longitude"] {
        assert!(
            out.lines()
                .any(|l| l.contains(&format!(" {aux} [")) && l.ends_with("(auxiliary)")),
            "{aux}: {out}"
        );
    }
    // No 2-D data variable: the 2-D latitude is not one; the 3-D field needs a selection.
    let err = hdrvis::datasets::read_grid(&path, None)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("'temp' has shape [3, 4, 5] (z=3, y=4, x=5); expected a 2-D array"),
        "{err}"
    );
}

#[test]
fn longitudes_across_the_meridian_are_unwrapped_not_all_round_in_storage_or_numeric_order() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "wrapped") else {
        return;
    };
    let path = dir.path().join("wrapped.nc");
    let grid = hdrvis::datasets::read_grid(&path, Some("eta")).unwrap();
    assert_eq!(grid.x.as_ref().unwrap().values, numbers(&r, "unwrapped"));
    assert_values(&grid.data, &numbers(&r, "eta"), 0.0, "eta");
    let (code, out, err) = hdrvis(&["info", path.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    // 322.5 .. 362.5 by 5: a 40 degree region, not the circle.
    assert!(out.contains("longitude 322.5° to 362.5°"), "{out}");
    assert!(
        out.contains("lon = 9: longitude, 322.5 to 362.5 degrees_east"),
        "{out}"
    );
    assert!(!out.contains("all round"), "{out}");
    let v = hdrvis::datasets::load_volume(&path).unwrap();
    assert_eq!(v.dims, [9, 4, 3]);
    // Across the antimeridian in numeric order (-177.5 .. -157.5, 162.5 .. 177.5, with bounds):
    // read in geographic order, 162.5 .. 202.5, as xarray's roll puts it.
    let sorted = dir.path().join("sorted.nc");
    let grid = hdrvis::datasets::read_grid(&sorted, Some("eta")).unwrap();
    assert_eq!(
        grid.x.as_ref().unwrap().values,
        numbers(&r, "sorted.unwrapped")
    );
    assert_values(&grid.data, &numbers(&r, "sorted.eta"), 0.0, "sorted eta");
    let v = hdrvis::datasets::load_volume_var(&sorted, Some("rho")).unwrap();
    let rho: Vec<f64> = v.data.iter().map(|&x| f64::from(x)).collect();
    assert_values(&rho, &numbers(&r, "sorted.rho"), 0.0, "sorted rho");
    let (code, out, err) = hdrvis(&["info", "sorted.nc", "--variable", "rho"], dir.path());
    assert_eq!(code, 0, "{err}");
    for line in [
        "lon = 9: longitude, 162.5 to 202.5 degrees_east",
        "latitude 40° to 55°, longitude 160° to 205°",
    ] {
        assert!(out.contains(line), "{line:?} in\n{out}");
    }
    // Indices count in geographic order too: index 4 is 182.5 east, stored at 0.
    let lon4 = numbers(&r, "sorted.eta_lon4");
    let (code, out, err) = hdrvis(
        &["info", "sorted.nc", "--variable", "eta", "--index", "lon=4"],
        dir.path(),
    );
    assert_eq!(code, 0, "{err}");
    for (key, value) in [("min", lon4[0]), ("max", lon4[3])] {
        assert!(
            out.contains(&format!("{key}: {value:.6e}")),
            "{key} {value} in\n{out}"
        );
    }
}

fn selection(index: &[(&str, i64)], at: &[(&str, At)]) -> LoadOptions {
    LoadOptions {
        variable: Some("temp".into()),
        select: Selection {
            index: index.iter().map(|(d, i)| (d.to_string(), *i)).collect(),
            at: at.iter().map(|(d, a)| (d.to_string(), a.clone())).collect(),
        },
        ..LoadOptions::default()
    }
}

#[test]
fn cf_time_decodes_as_cftime_does_and_is_never_space() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "series") else {
        return;
    };
    for case in ["series360", "series_gregorian"] {
        let path = dir.path().join(format!("{case}.nc"));
        let key = |k: &str| r[&format!("{case}.{k}")].clone();
        let steps = hdrvis::datasets::select::time_steps(&path, Some("temp")).unwrap();
        assert_eq!(steps, key("dates"), "{case}");
        let (first, last, calendar) = (&key("first")[0], &key("last")[0], &key("calendar")[0]);
        let (code, out, err) = hdrvis(&["info", path.to_str().unwrap()], dir.path());
        assert_eq!(code, 0, "{err}");
        for line in [
            format!("time = 6: time, {first} to {last} ({calendar} calendar)"),
            "depth = 4: vertical, 0 to 600 m".to_string(),
            "lat = 3: latitude".to_string(),
            "lon = 5: longitude".to_string(),
        ] {
            assert!(out.contains(&line), "{case}: {line}\n{out}");
        }
        // (time, lat, lon) is not a volume, nor (time, depth, lat, lon) a grid.
        let volume_err = hdrvis::datasets::load_volume_var(&path, Some("tas"))
            .unwrap_err()
            .to_string();
        let grid_err = hdrvis::datasets::read_grid(&path, None)
            .unwrap_err()
            .to_string();
        for (what, e) in [("tas", volume_err), ("temp", grid_err)] {
            let want = format!(
                "variable '{what}': dimension 'time' is time (6 steps, {first} to {last} ({calendar} calendar)), not space; choose a step with index: #{{ time: 0 }}"
            );
            assert!(e.contains(&want) && !e.contains('\n'), "{e}");
        }
    }
}

#[test]
fn selections_give_xarrays_isel_sel_and_interp() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "series") else {
        return;
    };
    for case in ["series360", "series_gregorian"] {
        let path = dir.path().join(format!("{case}.nc"));
        let want = |k: &str| numbers(&r, &format!("{case}.{k}"));
        // isel(time=2): a spherical (depth, lat, lon) volume.
        let v = hdrvis::datasets::load_volume_with(&path, &selection(&[("time", 2)], &[])).unwrap();
        assert_eq!(v.geometry.name(), "spherical", "{case}");
        let got: Vec<f64> = v.data.iter().map(|&x| f64::from(x)).collect();
        assert_values(&got, &want("isel_time2"), 0.0, "isel_time2");
        assert!(v.name.starts_with("temp at time index 2 ("), "{}", v.name);
        // sel(time=near, method="nearest") of tas: a (lat, lon) grid.
        let near = r[&format!("{case}.near")][0].clone();
        let mut opts = selection(&[], &[("time", At::Date(near.clone()))]);
        opts.variable = Some("tas".into());
        let g = hdrvis::datasets::load_grid_with(&path, &opts).unwrap();
        assert_values(
            g.property("tas").unwrap(),
            &want("sel_near_tas"),
            0.0,
            "sel_near_tas",
        );
        // A depth level of one step: a (lat, lon) grid with its geography.
        let opts = selection(&[("time", 1)], &[("depth", At::Value(600.0))]);
        let g = hdrvis::datasets::read_grid_with(&path, Some("temp"), &opts.select).unwrap();
        assert_values(&g.data, &want("isel_time1_depth600"), 0.0, "depth600");
        let x = g.x.unwrap();
        assert_eq!((x.kind, x.values.len()), (CoordKind::Longitude, 5));
        assert_eq!(g.y.unwrap().kind, CoordKind::Latitude);
        // Between two levels: xarray's interp (linear), and the grid says so.
        let opts = selection(&[("time", 1)], &[("depth", At::Value(200.0))]);
        let g = hdrvis::datasets::read_grid_with(&path, Some("temp"), &opts.select).unwrap();
        assert_values(&g.data, &want("interp_time1_depth200"), 1e-12, "interp");
        assert!(
            g.selected.iter().any(|s| s
                == "depth 200 m, interpolated linearly between 100 (index 1) and 300 (index 2)"),
            "{:?}",
            g.selected
        );
        let (code, out, err) = hdrvis(
            &[
                "info",
                path.to_str().unwrap(),
                "--var",
                "temp",
                "--index",
                "time=1",
                "--at",
                "depth=200",
            ],
            dir.path(),
        );
        assert_eq!(code, 0, "{err}");
        assert!(out.contains("shape: [3, 5] (lat=3, lon=5)"), "{out}");
        assert!(
            out.contains("selected: depth 200 m, interpolated linearly"),
            "{out}"
        );
        let second = &r[&format!("{case}.dates")][1];
        assert!(
            out.contains(&format!("selected: time index 1 ({second})")),
            "{out}"
        );
    }
}

#[test]
fn bad_selections_are_one_line_errors_naming_file_variable_and_dimension() {
    let dir = tempfile::tempdir().unwrap();
    if reference(dir.path(), "series").is_none() {
        return;
    }
    let file = "series360.nc";
    let cases: [(&[&str], &str); 6] = [
        (&["--index", "time=6"], "series360.nc: variable 'temp', dimension 'time': index 6 is out of range; expected 0..=5"),
        (&["--at", "depth=1000"], "series360.nc: variable 'temp', dimension 'depth': 1000 m is outside the axis (0 to 600, half a step beyond allowed)"),
        (&["--at", "time=1999-10-01"], "dimension 'time': 1999-10-01 is outside the axis (1999-11-16T00:00:00 to 2000-04-16T06:00:00"),
        (&["--index", "level=0"], "series360.nc: variable 'temp' has no dimension 'level'; its dimensions are time, depth, lat, lon"),
        (&["--at", "time=16/01/2000"], "series360.nc: variable 'temp', dimension 'time': '16/01/2000' is not an ISO 8601 date"),
        (&["--at", "time=2000-02-31"], "dimension 'time': 2000-02-31 is not a day of the 360_day calendar"),
    ];
    for (args, want) in cases {
        let mut all = vec!["info", file, "--variable", "temp"];
        all.extend_from_slice(args);
        let (code, out, err) = hdrvis(&all, dir.path());
        assert_ne!(code, 0, "{args:?}: {out}");
        assert!(
            err.contains(want) && err.trim().lines().count() == 1,
            "{args:?}: {err}"
        );
    }
    // A calendar CF does not name leaves the axis as numbers, said in the report (as xarray
    // leaves it undecoded); only what needs dates is refused.
    let (code, out, err) = hdrvis(&["info", "series_badcal.nc"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("calendar: unknown calendar 'lunar'")
            && out.contains("its values are left as numbers"),
        "{out}"
    );
    let (code, _, err) = hdrvis(
        &["info", "series_badcal.nc", "--at", "time=2000-01-01"],
        dir.path(),
    );
    assert_ne!(code, 0);
    assert!(
        err.contains(
            "series_badcal.nc: time coordinate 'time': calendar: unknown calendar 'lunar'"
        ),
        "{err}"
    );
    // A selection that leaves the wrong rank, from a script: nothing is written.
    std::fs::write(
        dir.path().join("s.rhai"),
        "let g = load_grid(\"series360.nc\", #{ variable: \"temp\", index: #{ time: 1 } });\nsave_exr(render_surface(g, #{}), \"g.exr\");\n",
    )
    .unwrap();
    let (code, _, err) = hdrvis(&["run", "s.rhai", "--out", "o"], dir.path());
    assert_ne!(code, 0);
    assert!(
        err.contains("series360.nc: 'temp' has shape [4, 3, 5] (depth=4, lat=3, lon=5) after the selection; expected a 2-D array; fix 1 more dimension(s) with index or at"),
        "{err}"
    );
    assert!(!dir.path().join("o/g.exr").exists());
    // times() in a script.
    std::fs::write(
        dir.path().join("t.rhai"),
        "let t = times(\"series360.nc\"); if t.len() != 6 || t[5].date != \"2000-04-16T06:00:00\" || t[5].index != 5 { throw `times: ${t}`; }\n",
    )
    .unwrap();
    let (code, _, err) = hdrvis(&["run", "t.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
}

/// One colour range for a movie (tests/python/write_cf_cases.py `movie`, the fixture's writer):
/// series_range over every step is xarray's minimum and maximum, over steps 1, 3 and 5 with
/// robust numpy's 2nd and 98th percentiles, with a centre symmetric about it; the example script
/// renders every step with that range as its colour bar's domain (read back from the frames'
/// EXR), a rerun with --resume renders none again, and a step out of range is a one-line error.
#[test]
fn a_series_movie_has_one_colour_range_over_its_steps() {
    use hdrvis::datasets::series::{series_range, SeriesOptions};
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "movie") else {
        return;
    };
    let path = dir.path().join("tsunami_series.nc");
    let (lo, hi) = (numbers(&r, "min")[0], numbers(&r, "max")[0]);
    let all = series_range(&path, &SeriesOptions::default()).unwrap();
    assert_values(&all, &[lo, hi], 1e-12, "range");
    let robust = SeriesOptions {
        steps: Some(vec![1, 3, 5]),
        robust: true,
        ..Default::default()
    };
    let got = series_range(&path, &robust).unwrap();
    assert_values(&got, &numbers(&r, "robust"), 1e-12, "robust range");
    let centred = SeriesOptions {
        centre: Some(0.0),
        ..Default::default()
    };
    let half = lo.abs().max(hi.abs());
    let got = series_range(&path, &centred).unwrap();
    assert_values(&got, &[-half, half], 1e-12, "centred range");
    assert_eq!(
        hdrvis::datasets::select::time_steps(&path, None).unwrap(),
        r["dates"]
    );
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/tsunami_series.rhai");
    let out = dir.path().join("out");
    let set = format!("file={}", path.display());
    let args = [
        "run",
        script.to_str().unwrap(),
        "--allow-path",
        dir.path().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--set",
        &set,
    ];
    let (code, stdout, stderr) = hdrvis(&args, dir.path());
    assert_eq!(code, 0, "{stdout}{stderr}");
    for i in 0..6 {
        let frame = out.join(format!("series/eta_0{i}.exr"));
        let img = hdrvis::io::exr::read_exr(&frame).unwrap();
        let domain: Vec<f64> = img
            .meta("legend_domain")
            .unwrap_or_else(|| panic!("{}: no legend_domain", frame.display()))
            .split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect();
        assert_values(&domain, &[-half, half], 1e-12, "frame's colour bar");
    }
    assert!(out.join("series/eta.gif").is_file());
    let written = |name: &str| {
        std::fs::metadata(out.join(name))
            .unwrap()
            .modified()
            .unwrap()
    };
    let before = written("series/eta_00.exr");
    let resumed = [&args[..], &["--resume"]].concat();
    let (code, stdout, stderr) = hdrvis(&resumed, dir.path());
    assert_eq!(code, 0, "{stdout}{stderr}");
    assert_eq!(
        written("series/eta_00.exr"),
        before,
        "a finished frame was rendered again"
    );
    let bad = SeriesOptions {
        steps: Some(vec![6]),
        ..Default::default()
    };
    let e = series_range(&path, &bad).unwrap_err().to_string();
    assert!(
        e.contains("variable 'eta', dimension 'time'")
            && e.contains("step 6 is out of range; expected 0..=5")
            && !e.contains('\n'),
        "{e}"
    );
}

/// A vertical axis in units that are not a length is placed by index (model levels) or at the
/// standard atmosphere's heights (pressure) with a note instead of refusing the file; `vertical:` names an auxiliary height in metres that
/// places the same field on the sphere; selections take levels as xarray's isel/sel do; a
/// `vertical` that is not a length along one of the dimensions is a one-line error.
#[test]
fn vertical_levels_that_are_not_lengths_load_by_index_or_by_a_named_height() {
    use hdrvis::model::Geometry;
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "levels") else {
        return;
    };
    let model = dir.path().join("model_levels.nc");
    let v = hdrvis::datasets::load_volume(&model).unwrap();
    assert_eq!(v.dims, [12, 7, 5]);
    assert!(
        v.name.contains("level in '1' placed by index"),
        "{}",
        v.name
    );
    // z is the level's index: five unit cells from 0.
    let b = v.bounds();
    assert_eq!((b.lo[2], b.hi[2]), (0.0, 5.0));
    let got: Vec<f64> = v.data.iter().map(|&x| f64::from(x)).collect();
    assert_values(&got, &numbers(&r, "ta"), 0.0, "ta");
    let placed = LoadOptions {
        vertical: Some("level_height".into()),
        ..LoadOptions::default()
    };
    let s = hdrvis::datasets::load_volume_with(&model, &placed).unwrap();
    let Geometry::Spherical(g) = &s.geometry else {
        panic!("{s}: expected a spherical volume")
    };
    let radii: Vec<f64> = numbers(&r, "height").iter().map(|h| 6.371e6 + h).collect();
    assert_values(&g.radius.centres, &radii, 1e-12, "radii");
    assert_eq!(
        (g.length_unit.as_str(), g.vertical.as_str()),
        ("m", "height")
    );
    let isel = Selection {
        index: vec![("level".into(), 3)],
        at: vec![],
    };
    let level3 = hdrvis::datasets::read_grid_with(&model, None, &isel).unwrap();
    assert_values(&level3.data, &numbers(&r, "ta_level3"), 0.0, "isel level 3");
    // Pressure levels stored 1000 .. 100 hPa are no lengths either: placed at the 1976 US
    // Standard Atmosphere's geopotential heights (500 hPa at 5 574 m in its tables), surface
    // at the bottom, on the sphere; sel by value.
    let pressure = dir.path().join("pressure_levels.nc");
    let u = hdrvis::datasets::load_volume(&pressure).unwrap();
    assert!(
        u.name
            .contains("plev 1000–100 hPa placed at the 1976 standard atmosphere's heights"),
        "{}",
        u.name
    );
    let Geometry::Spherical(g) = &u.geometry else {
        panic!("{u}: expected a spherical volume")
    };
    assert_eq!(g.length_unit.as_str(), "km");
    let heights: Vec<f64> = g.radius.centres.iter().map(|r| r - 6371.0).collect();
    assert!((heights[2] - 5.574).abs() < 2e-3, "{heights:?}");
    assert!(
        heights.windows(2).all(|w| w[0] < w[1]) && heights[0] > 0.0 && heights[0] < 0.2,
        "{heights:?}"
    );
    let got: Vec<f64> = u.data.iter().map(|&x| f64::from(x)).collect();
    assert_values(&got, &numbers(&r, "u"), 0.0, "u");
    // A (plev, lat) slice: rows at those heights too, 1000 hPa at the bottom.
    let slice = LoadOptions {
        select: Selection {
            index: vec![("lon".into(), 0)],
            at: vec![],
        },
        ..LoadOptions::default()
    };
    let s = hdrvis::datasets::load_grid_with(&pressure, &slice).unwrap();
    let y = s.y();
    assert_eq!(y.units, "km");
    assert!(y.name.contains("standard-atmosphere height"), "{}", y.name);
    assert!(
        (y.values[0] - heights[0]).abs() < 1e-9 && !s.y_down(),
        "{:?}",
        y.values
    );
    assert!((y.values[2] - 5.574).abs() < 2e-3);
    let sel = Selection {
        index: vec![],
        at: vec![("plev".into(), At::Value(500.0))],
    };
    let g500 = hdrvis::datasets::read_grid_with(&pressure, None, &sel).unwrap();
    assert_values(&g500.data, &numbers(&r, "u_500"), 0.0, "sel plev 500");
    let (code, out, err) = hdrvis(&["info", pressure.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("plev = 5: vertical pressure (placed at the standard atmosphere's heights), 1000 to 100 hPa"),
        "{out}"
    );
    for (name, want) in [
        ("plev", "'plev' is in 'hPa'; expected units of length"),
        (
            "lat",
            "'lat' is in 'degrees_north'; expected units of length",
        ),
        ("nothing", "no variable 'nothing' in the file"),
    ] {
        let opts = LoadOptions {
            vertical: Some(name.into()),
            ..LoadOptions::default()
        };
        let file = if name == "plev" { &pressure } else { &model };
        let e = hdrvis::datasets::load_volume_with(file, &opts)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want) && e.contains(".nc"), "{name}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

/// A rotated-pole volume (tests/python/write_cf_cases.py `rotated3d`, xarray: (depth, rlat,
/// rlon) on EURO-CORDEX's grid) lies at its true positions: a Gaussian blob about the true point
/// 50°N 10°E (placed by pyproj's node positions) seen by `camera_geo(50, 10)` — a camera in the
/// true frame, turned into the grid's — is centred in the image within a pixel, with coastlines
/// drawn; a section along a true great circle through a field holding each node's true
/// latitude reads, in every column, that column's latitude (within 0.01°); the volume's
/// description names the pole.
#[test]
fn rotated_pole_volumes_lie_at_their_true_positions() {
    use hdrvis::model::section::{great_circle_section, SectionSpec};
    use hdrvis::model::{Geometry, Missing};
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "rotated3d") else {
        return;
    };
    let path = dir.path().join("rotated3d.nc");
    let blob = hdrvis::datasets::load_volume_with(
        &path,
        &LoadOptions {
            variable: Some("blob".into()),
            ..LoadOptions::default()
        },
    )
    .unwrap();
    let Geometry::Spherical(g) = &blob.geometry else {
        panic!("a spherical volume: {:?}", blob.geometry.name());
    };
    let pole = g.rotated_pole.expect("the rotated pole");
    let at = numbers(&r, "blob_rotated");
    let (rlat, rlon) = pole.to_rotated(50.0, 10.0);
    assert!((rlat - at[0]).abs() < 1e-9 && (rlon - at[1]).abs() < 1e-9);
    assert!(
        g.to_string()
            .contains("(rotated: rotated pole at 39.25°N -162°E)"),
        "{g}"
    );
    // Bricks are boxes: the opened volume would lie elsewhere, so it is refused.
    let e = hdrvis::datasets::bricked::open_bricked(&path, Some("blob"), 32)
        .unwrap_err()
        .to_string();
    assert!(e.contains("'blob' lies on a rotated-pole grid"), "{e}");
    let n = 96u32;
    std::fs::write(
        dir.path().join("r.rhai"),
        format!(
            r#"let v = load_volume("rotated3d.nc", #{{ variable: "blob" }});
            save_exr(render_volume(v, #{{ tf: tf_emission_absorption(1.0, 0.0), camera: camera_geo(50.0, 10.0, 3.0, 8.0), width: {n}, height: {n}, coastlines: true }}), "r.exr");"#
        ),
    )
    .unwrap();
    let (code, _, err) = hdrvis(&["run", "r.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    let img = hdrvis::io::exr::read_exr(&dir.path().join("o/r.exr")).unwrap();
    let (mut sum, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for (k, p) in img.pixels.iter().enumerate() {
        let w = p[0] as f64;
        sum += w;
        cx += w * ((k as u32 % n) as f64 + 0.5);
        cy += w * ((k as u32 / n) as f64 + 0.5);
    }
    let (cx, cy) = (cx / sum, cy / sum);
    let centre = n as f64 / 2.0;
    eprintln!("blob centroid ({cx:.3}, {cy:.3}), image centre {centre}");
    assert!(
        (cx - centre).abs() < 1.0 && (cy - centre).abs() < 1.0,
        "blob centroid ({cx:.2}, {cy:.2}), expected ({centre}, {centre})"
    );
    let tlat = hdrvis::datasets::load_volume_with(
        &path,
        &LoadOptions {
            variable: Some("tlat".into()),
            ..LoadOptions::default()
        },
    )
    .unwrap();
    let spec = SectionSpec {
        from: [45.0, 0.0],
        to: [55.0, 20.0],
        depth: [0.0, 600.0],
        n: [21, 3],
        missing: Missing::Strict,
    };
    let s = great_circle_section(&tlat, &spec).unwrap();
    let (values, lats) = (s.property("tlat").unwrap(), s.property("latitude").unwrap());
    let worst = values
        .iter()
        .zip(lats)
        .map(|(v, l)| (v - l).abs())
        .fold(0.0, f64::max);
    eprintln!("section: true latitude read back within {worst:.2e} degrees");
    assert!(worst < 0.01, "worst {worst}");
}

/// A curvilinear grid as ocean models write it (tests/python/write_cf_cases.py `curvilinear`,
/// xarray: 2-D lat/lon, sheared and bent, across the antimeridian with longitudes stored in
/// [-180, 180), one missing node): `load_grid` with `resolution: 0.5` regrids it onto exactly the
/// regular nodes numpy computes, with numpy's values of linear interpolation over the grid's
/// triangles (1e-9), missing where numpy's are; `lin`, linear in latitude and longitude, equals
/// its closed form wherever it is defined; map and globe render with coastlines; `hdrvis info`
/// says what the grid is; a resolution for a grid on 1-D axes is a one-line error.
#[test]
fn curvilinear_grids_are_regridded_onto_latitude_and_longitude() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "curvilinear") else {
        return;
    };
    let path = dir.path().join("curvilinear.nc");
    let (lon, lat) = (numbers(&r, "lon"), numbers(&r, "lat"));
    for name in ["sst", "lin"] {
        let opts = LoadOptions {
            variable: Some(name.into()),
            resolution: Some(0.5),
            ..LoadOptions::default()
        };
        let grid = hdrvis::datasets::load_grid_with(&path, &opts).unwrap();
        assert!(grid.is_geographic(), "{name}");
        assert_values(&grid.x().values, &lon, 1e-12, "lon");
        assert_values(&grid.y().values, &lat, 1e-12, "lat");
        let got = grid.property(name).unwrap();
        assert_values(got, &numbers(&r, name), 1e-9, name);
        let defined = got.iter().filter(|v| v.is_finite()).count();
        assert!(
            defined > got.len() / 3,
            "{name}: {defined} of {}",
            got.len()
        );
        if name == "lin" {
            for (k, v) in got.iter().enumerate().filter(|(_, v)| v.is_finite()) {
                let want = 0.1 * lat[k / lon.len()] + 0.05 * lon[k % lon.len()];
                assert!((v - want).abs() < 1e-9, "lin node {k}: {v} vs {want}");
            }
        }
    }
    std::fs::write(
        dir.path().join("c.rhai"),
        r#"let g = load_grid("curvilinear.nc", #{ variable: "sst" });
        save_png(render_surface(g, #{ mode: "direct", coastlines: true, graticule: 10.0 }), "map.png", #{ frame: true, legend: true });
        save_png(render_surface(g, #{ view: "globe", mode: "cyclic", nu: 1.0, coastlines: true }), "globe.png");"#,
    )
    .unwrap();
    let (code, _, err) = hdrvis(&["run", "c.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = hdrvis(
        &["info", path.to_str().unwrap(), "--var", "sst"],
        dir.path(),
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("curvilinear grid: lat and lon are 2-D; latitudes -30.0000 to ")
            && out.contains(&format!("longitudes {:.4} to ", lon[0])),
        "{out}"
    );
    std::fs::write(
        dir.path().join("bad.rhai"),
        r#"let g = load_grid("curvilinear.nc", #{ variable: "sst" }); let h = load_grid("flat.nc", #{ resolution: 0.5 });"#,
    )
    .unwrap();
    hdrvis::datasets::netcdf::write_grid(
        dir.path().join("flat.nc"),
        &[
            ("lat", &[10.0, 20.0], "degrees_north"),
            ("lon", &[1.0, 2.0, 3.0], "degrees_east"),
        ],
        &[("v", &[1.0f64; 6], "m", "v")],
        &[],
    )
    .unwrap();
    let (code, _, err) = hdrvis(&["run", "bad.rhai", "--out", "o2"], dir.path());
    assert_ne!(code, 0);
    assert!(
        err.contains("flat.nc: resolution 0.5: only curvilinear grids"),
        "{err}"
    );
}

/// A rotated-pole grid as EURO-CORDEX writes it (tests/python/write_cf_cases.py `rotated`,
/// xarray): every node's true position equals pyproj's (PROJ's ob_tran) within 1e-9°; on the
/// globe, each pixel's value of `tlat` (the nodes' true latitudes, from pyproj, interpolated)
/// is the true latitude of the point its ray meets, within 0.01°; the map is drawn in rotated coordinates
/// with the coastlines moved there; `hdrvis info` names the rotated axes and the pole.
#[test]
fn rotated_pole_grids_lie_at_their_true_positions() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "rotated") else {
        return;
    };
    let path = dir.path().join("rotated.nc");
    let opts = LoadOptions {
        variable: Some("tlat".into()),
        ..LoadOptions::default()
    };
    let grid = hdrvis::datasets::load_grid_with(&path, &opts).unwrap();
    let pole = *grid.rotated_pole().expect("a rotated pole");
    assert!(grid.is_geographic());
    let (rlat, rlon) = (numbers(&r, "rlat"), numbers(&r, "rlon"));
    assert_eq!(grid.x().values, rlon);
    assert_eq!(grid.y().values, rlat);
    let (tlat, tlon) = (numbers(&r, "tlat"), numbers(&r, "tlon"));
    assert_values(grid.property("tlat").unwrap(), &tlat, 0.0, "tlat");
    for (j, &la) in rlat.iter().enumerate() {
        for (i, &lo) in rlon.iter().enumerate() {
            let (lat, lon) = pole.to_true(la, lo);
            let k = j * rlon.len() + i;
            assert!(
                (lat - tlat[k]).abs() < 1e-9,
                "node {i},{j}: {lat} vs {}",
                tlat[k]
            );
            assert!(
                (lon - tlon[k]).abs() < 1e-9,
                "node {i},{j}: {lon} vs {}",
                tlon[k]
            );
        }
    }
    // The globe from 3 radii above the rotated origin's true position (50.75°N, 18°E).
    let (n, fov) = (96u32, 30.0);
    let eye = hdrvis::model::SphericalGrid::to_world(3.0, 50.75, 18.0);
    std::fs::write(
        dir.path().join("r.rhai"),
        format!(
            r#"let g = load_grid("rotated.nc", #{{ variable: "tlat" }});
            let cam = camera_look_at([{}, {}, {}], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0], {fov});
            let o = #{{ view: cam, globe: true, mode: "direct", width: {n}, height: {n}, antialias: false }};
            save_exr(render_surface(g, o), "globe.exr");
            save_exr(render_surface(grid_subset(g, [0, 0], [65, 49]), o), "globe_subset.exr");
            save_png(render_surface(g, #{{ view: "map", mode: "direct", coastlines: true }}), "map.png", #{{ frame: true }});"#,
            eye[0], eye[1], eye[2]
        ),
    )
    .unwrap();
    let (code, _, err) = hdrvis(&["run", "r.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    let img = hdrvis::io::exr::read_exr(&dir.path().join("o/globe.exr")).unwrap();
    let values = &img
        .extra_channels
        .iter()
        .find(|(name, _)| name == "tlat")
        .expect("the tlat channel")
        .1;
    let camera = hdrvis::model::Camera::look_at(eye, [0.0; 3], [0.0, 0.0, 1.0], fov).unwrap();
    let (mut compared, mut worst) = (0, 0.0f64);
    for (k, &v) in values.iter().enumerate() {
        let v = v as f64;
        if !v.is_finite() {
            continue;
        }
        let (o, d) = camera.ray(k as u32 % n, k as u32 / n, n, n);
        // The near hit of o + t d on the unit sphere.
        let b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2];
        let c = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - 1.0;
        let t = -b - (b * b - c).sqrt();
        let p = [0, 1, 2].map(|a| o[a] + t * d[a]);
        let lat = p[2].clamp(-1.0, 1.0).asin().to_degrees();
        let lon = p[1].atan2(p[0]).to_degrees();
        // Within the nodes (the half cell beyond the edge nodes shows their values).
        let (ra, ro) = pole.to_rotated(lat, lon);
        if !(rlat[0]..=rlat[rlat.len() - 1]).contains(&ra)
            || !(rlon[0]..=rlon[rlon.len() - 1]).contains(&ro)
        {
            continue;
        }
        worst = worst.max((v - lat).abs());
        compared += 1;
    }
    assert!(compared > 1000, "{compared} pixels show the grid");
    eprintln!("rotated pole on the globe: {compared} pixels, worst {worst:.2e} degrees");
    assert!(worst < 0.01, "worst {worst} degrees");
    // A grid derived in the script keeps the pole: the same picture.
    let subset = hdrvis::io::exr::read_exr(&dir.path().join("o/globe_subset.exr")).unwrap();
    assert_eq!(subset.pixels, img.pixels);
    let (code, out, err) = hdrvis(&["info", path.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("rlat = 49: rotated latitude, -12 to 12 degrees"),
        "{out}"
    );
    assert!(out.contains("rotated pole at 39.25°N -162°E"), "{out}");
}
