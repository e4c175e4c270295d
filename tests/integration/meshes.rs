//! Unstructured meshes written as each model and convention writes them (netCDF4-python,
//! tests/python/write_mesh_cases.py): UGRID 1.0 (mixed polygons, 0- and 1-based), ICON (its own
//! file and a separate grid file), MPAS (Voronoi cells, values on cells and on vertices), SCRIP
//! (degrees and radians), FVCOM and ADCIRC triangle lists. Every variable sampled onto a regular
//! latitude–longitude grid equals the brute-force point-in-polygon (cell data, exactly) and
//! barycentric (node data, 1e-9 relative) reference at every grid node not on a cell edge, and a
//! linear node field is reproduced exactly. Bad meshes are refused in one line.

use crate::cli::{hdrvis, python_check};
use hdrvis::datasets::select::Selection;
use hdrvis::datasets::LoadOptions;
use serde_json::{json, Value};
use std::path::Path;

/// Writes the cases into `dir`; `false` (skip) without netCDF4.
fn cases(dir: &Path) -> bool {
    let Some(report) = python_check("write_mesh_cases.py", &["write", dir.to_str().unwrap()])
    else {
        return false;
    };
    assert!(report.starts_with("exit 0\n"), "{report}");
    true
}

/// One variable to sample: file, grid file, variable, selection, step, node data.
struct Case {
    file: &'static str,
    grid: Option<&'static str>,
    variable: &'static str,
    index: &'static [(&'static str, i64)],
    step: f64,
    on_nodes: bool,
}

const CASES: [Case; 14] = [
    Case {
        file: "ugrid.nc",
        grid: None,
        variable: "temp",
        index: &[("time", 1)],
        step: 0.5,
        on_nodes: false,
    },
    Case {
        file: "ugrid.nc",
        grid: None,
        variable: "elev",
        index: &[],
        step: 0.5,
        on_nodes: true,
    },
    Case {
        file: "ugrid_1based.nc",
        grid: None,
        variable: "depth",
        index: &[],
        step: 0.5,
        on_nodes: false,
    },
    Case {
        file: "icon_data.nc",
        grid: None,
        variable: "S",
        index: &[("time", 1), ("depth", 2)],
        step: 1.0,
        on_nodes: false,
    },
    Case {
        file: "icon_data_only.nc",
        grid: Some("icon_grid.nc"),
        variable: "S",
        index: &[("time", 0), ("depth", 0)],
        step: 1.0,
        on_nodes: false,
    },
    Case {
        file: "mpas_data.nc",
        grid: Some("mpas_grid.nc"),
        variable: "temperature",
        index: &[("Time", 0), ("nVertLevels", 1)],
        step: 1.0,
        on_nodes: false,
    },
    Case {
        file: "mpas_data.nc",
        grid: Some("mpas_grid.nc"),
        variable: "vorticity",
        index: &[("Time", 1)],
        step: 1.0,
        on_nodes: true,
    },
    Case {
        file: "scrip_data.nc",
        grid: Some("scrip_grid.nc"),
        variable: "T850",
        index: &[],
        step: 0.5,
        on_nodes: false,
    },
    Case {
        file: "scrip_data.nc",
        grid: Some("scrip_grid_radians.nc"),
        variable: "T850",
        index: &[],
        step: 0.5,
        on_nodes: false,
    },
    Case {
        file: "fvcom.nc",
        grid: None,
        variable: "zeta",
        index: &[("time", 1)],
        step: 0.025,
        on_nodes: true,
    },
    Case {
        file: "fvcom.nc",
        grid: None,
        variable: "temp",
        index: &[("time", 0), ("siglay", 1)],
        step: 0.025,
        on_nodes: false,
    },
    Case {
        file: "adcirc.nc",
        grid: None,
        variable: "zeta",
        index: &[("time", 1)],
        step: 0.02,
        on_nodes: true,
    },
    Case {
        file: "camse.nc",
        grid: None,
        variable: "T850",
        index: &[("time", 1)],
        step: 2.0,
        on_nodes: true,
    },
    Case {
        file: "adcirc.nc",
        grid: None,
        variable: "depth",
        index: &[],
        step: 0.02,
        on_nodes: true,
    },
];

fn options(c: &Case, dir: &Path) -> LoadOptions {
    LoadOptions {
        variable: Some(c.variable.into()),
        select: Selection {
            index: c.index.iter().map(|(d, i)| (d.to_string(), *i)).collect(),
            at: Vec::new(),
        },
        resolution: Some(c.step),
        grid: c.grid.map(|g| dir.join(g)),
        ..LoadOptions::default()
    }
}

#[test]
fn meshes_sample_as_brute_force_point_location_does() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    for c in &CASES {
        let what = format!("{} {} {:?}", c.file, c.variable, c.index);
        let grid =
            hdrvis::datasets::load_grid_with(&dir.path().join(c.file), &options(c, dir.path()))
                .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert!(grid.is_geographic(), "{what}");
        let (lon, lat) = (grid.x().values.clone(), grid.y().values.clone());
        let got = grid.property(c.variable).unwrap();
        let request = json!({
            "file": c.file,
            "grid": c.grid,
            "variable": c.variable,
            "index": c.index.iter().map(|(d, i)| (d.to_string(), json!(i))).collect::<serde_json::Map<_, _>>(),
            "lon": lon,
            "lat": lat,
        });
        let req = dir.path().join("request.json");
        std::fs::write(&req, request.to_string()).unwrap();
        let report = python_check(
            "write_mesh_cases.py",
            &[
                "sample",
                dir.path().to_str().unwrap(),
                req.to_str().unwrap(),
            ],
        )
        .unwrap();
        assert!(report.starts_with("exit 0\n"), "{what}: {report}");
        let want: Value = serde_json::from_str(report.lines().nth(1).unwrap()).unwrap();
        let want = want["values"].as_array().unwrap();
        assert_eq!(got.len(), want.len(), "{what}");
        let (mut compared, mut inside) = (0, 0);
        for (k, (g, w)) in got.iter().zip(want).enumerate() {
            let at = format!(
                "{what}: node {k} ({}, {})",
                lon[k % lon.len()],
                lat[k / lon.len()]
            );
            match w {
                Value::String(_) => continue, // on a cell edge: either cell's value
                Value::Null => assert!(g.is_nan(), "{at}: {g} where no cell is"),
                w => {
                    let w = w.as_f64().unwrap();
                    // Cell data exactly (to the last bit serde_json's float parsing keeps);
                    // node data within 1e-9 relative.
                    let tol = if c.on_nodes { 1e-9 } else { 4.0 * f64::EPSILON } * w.abs().max(1.0);
                    assert!((g - w).abs() <= tol, "{at}: {g} vs {w}");
                    inside += 1;
                }
            }
            compared += 1;
        }
        assert!(
            inside > compared / 2,
            "{what}: {inside} of {compared} inside the mesh"
        );
    }
}

#[test]
fn linear_node_fields_are_reproduced_exactly() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    // ugrid's elev = 100 + 3 lon - 2 lat; FVCOM's zeta = 0.5 + 0.01 lon - 0.02 lat + 0.1 t.
    for (c, f) in [
        (
            &CASES[1],
            &(|lon: f64, lat: f64| 100.0 + 3.0 * lon - 2.0 * lat) as &dyn Fn(f64, f64) -> f64,
        ),
        (&CASES[9], &|lon: f64, lat: f64| {
            0.5 + 0.01 * lon - 0.02 * lat + 0.1
        }),
    ] {
        let grid =
            hdrvis::datasets::load_grid_with(&dir.path().join(c.file), &options(c, dir.path()))
                .unwrap();
        let (lon, lat) = (&grid.x().values, &grid.y().values);
        let got = grid.property(c.variable).unwrap();
        let mut checked = 0;
        for (k, v) in got.iter().enumerate().filter(|(_, v)| v.is_finite()) {
            let want = f(lon[k % lon.len()], lat[k / lon.len()]);
            assert!(
                (v - want).abs() <= 1e-9 * want.abs().max(1.0),
                "{} node {k}: {v} vs {want}",
                c.file
            );
            checked += 1;
        }
        assert!(checked > 500, "{}: {checked}", c.file);
    }
}

#[test]
fn meshes_load_from_scripts_and_info_names_them() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let script = r#"
        let g = load_grid("icon_data_only.nc", #{ variable: "S", grid: "icon_grid.nc", index: #{ time: 0, depth: 0 } });
        save_grid(g, "s.nc");
        save_png(render_surface(g, #{ view: "globe", mode: "direct", coastlines: true }), "globe.png");
        let m = load_grid("mpas_data.nc", #{ variable: "temperature", grid: "mpas_grid.nc", index: #{ Time: 0, nVertLevels: 0 } });
        save_png(render_surface(m, #{ mode: "cyclic", nu: 2.0, coastlines: true }), "map.png");
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let (code, _, err) = hdrvis(&["run", "s.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    for f in ["o/s.nc", "o/globe.png", "o/map.png"] {
        assert!(dir.path().join(f).is_file(), "{f}");
    }
    let (code, out, err) = hdrvis(&["info", "icon_data.nc", "--variable", "S"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("mesh: ICON mesh of 320 cells"), "{out}");
    // A data file with only the values: its mesh named through --grid.
    let (code, out, err) = hdrvis(
        &[
            "info",
            "mpas_data.nc",
            "--variable",
            "temperature",
            "--grid",
            "mpas_grid.nc",
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("mesh: MPAS mesh of 162 cells and 320 nodes"),
        "{out}"
    );
    let (code, out, _) = hdrvis(&["info", "ugrid.nc"], dir.path());
    assert_eq!(code, 0);
    assert!(
        out.contains("UGRID mesh of 150 cells and 143 nodes"),
        "{out}"
    );
}

#[test]
fn bad_meshes_are_refused_in_one_line_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    for (file, var, grid, expected) in [
        ("bad_index.nc", "depth", None, "names node"),
        ("bad_polygon.nc", "depth", None, "expected at least 3"),
        ("bad_units.nc", "S", None, "unknown units 'furlongs'"),
        (
            "icon_data_mismatch.nc",
            "S",
            Some("icon_grid.nc"),
            "none of the 320 cells",
        ),
    ] {
        let grid_opt = grid.map_or(String::new(), |g| format!(", grid: \"{g}\""));
        let script = format!(
            "let g = load_grid(\"{file}\", #{{ variable: \"{var}\"{grid_opt}, index: #{{}} }}); save_grid(g, \"out.nc\");"
        );
        let script = script.replace(
            "index: #{}",
            if var == "S" {
                "index: #{ time: 0, depth: 0 }"
            } else {
                "index: #{}"
            },
        );
        std::fs::write(dir.path().join("bad.rhai"), script).unwrap();
        let (code, _, err) = hdrvis(&["run", "bad.rhai", "--out", "bad"], dir.path());
        assert_eq!(code, 1, "{file}: {err}");
        // The error's own line (a script's error is followed by the script line it came from).
        let line = err.lines().next().unwrap_or("");
        assert!(
            line.contains(file) && line.contains(expected),
            "{file}: {err}"
        );
        assert!(!dir.path().join("bad/out.nc").exists(), "{file}");
    }
}

/// ICON's salinity on depth levels loads as a spherical volume: each level is the grid that
/// `load_grid` samples at that depth, the depths place it below the surface, and a section and a
/// volume render of it run from a script.
#[test]
fn a_mesh_with_depth_levels_is_a_spherical_volume() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let path = dir.path().join("icon_data.nc");
    let at = |index: Vec<(String, i64)>| Selection {
        index,
        at: Vec::new(),
    };
    let opts = LoadOptions {
        variable: Some("S".into()),
        select: at(vec![("time".into(), 1)]),
        resolution: Some(3.0),
        ..LoadOptions::default()
    };
    let volume = hdrvis::datasets::load_volume_with(&path, &opts).unwrap();
    assert!(
        matches!(volume.geometry, hdrvis::model::Geometry::Spherical(_)),
        "{:?}",
        volume.geometry
    );
    let [nx, ny, nz] = volume.dims;
    assert_eq!(nz, 3);
    for depth in 0..nz {
        let level = LoadOptions {
            select: at(vec![("time".into(), 1), ("depth".into(), depth as i64)]),
            ..opts.clone()
        };
        let grid = hdrvis::datasets::load_grid_with(&path, &level).unwrap();
        assert_eq!((grid.nx(), grid.ny()), (nx, ny));
        let want = grid.property("S").unwrap();
        for (k, w) in want.iter().enumerate() {
            let got = volume.data[depth * nx * ny + k];
            assert!(
                (w.is_nan() && got.is_nan()) || (f64::from(got) - w).abs() <= 1e-6 * w.abs(),
                "depth {depth} node {k}: {got} vs {w}"
            );
        }
    }
    let script = r#"
        let v = load_volume("icon_data.nc", #{ variable: "S", index: #{ time: 0 }, resolution: 3.0 });
        let s = section(v, #{ from: [-60.0, -30.0], to: [60.0, 30.0], n: [64, 3] });
        save_grid(s, "section.nc");
        let img = render_volume(v, #{ tf: tf_emission_absorption(1.0, 1.0), width: 48, height: 48, step: 16.0 });
        save_exr(img, "v.exr");
    "#;
    std::fs::write(dir.path().join("v.rhai"), script).unwrap();
    let (code, _, err) = hdrvis(&["run", "v.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(dir.path().join("o/section.nc").is_file() && dir.path().join("o/v.exr").is_file());
}
