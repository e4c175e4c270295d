//! Unstructured meshes written as each model and convention writes them (netCDF4-python,
//! tests/python/write_mesh_cases.py): UGRID 1.0 (mixed polygons, 0- and 1-based), ICON (its own
//! file and a separate grid file), MPAS (Voronoi cells, values on cells and on vertices), SCRIP
//! (degrees and radians), FVCOM and ADCIRC triangle lists. Every variable sampled onto a regular
//! latitude–longitude grid equals the brute-force point-in-polygon (cell data, exactly) and
//! barycentric (node data, 1e-9 relative) reference at every grid node not on a cell edge, and a
//! linear node field is reproduced exactly. Drawn cell by cell (`load_mesh`, `render_surface`),
//! every pixel of a map and a globe shows that reference value where its centre (or its ray's
//! hit on the sphere) lies. A real UGRID file from the registries (the Met Office's LFRic C4 mesh
//! in iris-sample-data) is held to the same reference, and a real ship's track is not taken for
//! columns. Bad meshes and drawings are refused in one line.

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

/// One variable to sample: file, grid file, variable, selection, step, node data, and for a
/// real file how the reference reads its geometry (write_mesh_cases.py's `mesh_from_spec`, as
/// JSON).
struct Case {
    file: &'static str,
    grid: Option<&'static str>,
    variable: &'static str,
    index: &'static [(&'static str, i64)],
    step: f64,
    on_nodes: bool,
    mesh: Option<&'static str>,
    /// A coastal model's water only: its cells cover a small part of their box.
    coastal: bool,
}

const CASES: [Case; 14] = [
    Case {
        file: "ugrid.nc",
        grid: None,
        variable: "temp",
        index: &[("time", 1)],
        step: 0.5,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "ugrid.nc",
        grid: None,
        variable: "elev",
        index: &[],
        step: 0.5,
        on_nodes: true,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "ugrid_1based.nc",
        grid: None,
        variable: "depth",
        index: &[],
        step: 0.5,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "icon_data.nc",
        grid: None,
        variable: "S",
        index: &[("time", 1), ("depth", 2)],
        step: 1.0,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "icon_data_only.nc",
        grid: Some("icon_grid.nc"),
        variable: "S",
        index: &[("time", 0), ("depth", 0)],
        step: 1.0,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "mpas_data.nc",
        grid: Some("mpas_grid.nc"),
        variable: "temperature",
        index: &[("Time", 0), ("nVertLevels", 1)],
        step: 1.0,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "mpas_data.nc",
        grid: Some("mpas_grid.nc"),
        variable: "vorticity",
        index: &[("Time", 1)],
        step: 1.0,
        on_nodes: true,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "scrip_data.nc",
        grid: Some("scrip_grid.nc"),
        variable: "T850",
        index: &[],
        step: 0.5,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "scrip_data.nc",
        grid: Some("scrip_grid_radians.nc"),
        variable: "T850",
        index: &[],
        step: 0.5,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "fvcom.nc",
        grid: None,
        variable: "zeta",
        index: &[("time", 1)],
        step: 0.025,
        on_nodes: true,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "fvcom.nc",
        grid: None,
        variable: "temp",
        index: &[("time", 0), ("siglay", 1)],
        step: 0.025,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "adcirc.nc",
        grid: None,
        variable: "zeta",
        index: &[("time", 1)],
        step: 0.02,
        on_nodes: true,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "camse.nc",
        grid: None,
        variable: "T850",
        index: &[("time", 1)],
        step: 2.0,
        on_nodes: true,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "adcirc.nc",
        grid: None,
        variable: "depth",
        index: &[],
        step: 0.02,
        on_nodes: true,
        mesh: None,
        coastal: false,
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

/// The brute-force reference of `c` at the points `at` asks for (`lon` and `lat` axes, or
/// `points`): per point a value, null (no cell) or a string (on an edge, or two cells overlap).
fn reference(dir: &Path, c: &Case, at: Value) -> Vec<Value> {
    // `dir` holds the case's files; the request goes to a scratch folder.
    let mut request = json!({
        "file": c.file,
        "grid": c.grid,
        "variable": c.variable,
        "index": c.index.iter().map(|(d, i)| (d.to_string(), json!(i))).collect::<serde_json::Map<_, _>>(),
    });
    if let Some(spec) = c.mesh {
        request["mesh"] = serde_json::from_str(spec).unwrap();
    }
    for (k, v) in at.as_object().unwrap() {
        request[k] = v.clone();
    }
    let scratch = tempfile::tempdir().unwrap();
    let req = scratch.path().join("request.json");
    std::fs::write(&req, request.to_string()).unwrap();
    let report = python_check(
        "write_mesh_cases.py",
        &["sample", dir.to_str().unwrap(), req.to_str().unwrap()],
    )
    .unwrap();
    assert!(report.starts_with("exit 0\n"), "{}: {report}", c.file);
    let want: Value = serde_json::from_str(report.lines().nth(1).unwrap()).unwrap();
    want["values"].as_array().unwrap().clone()
}

#[test]
fn meshes_sample_as_brute_force_point_location_does() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    for c in &CASES {
        assert_sampled(dir.path(), c);
    }
}

/// `c` (in `data`) sampled with load_grid equals the reference at every grid node not on a cell
/// edge: cell data exactly (to the last bit serde_json's float parsing keeps), node data within
/// 1e-9 relative; more than half the nodes lie on cells.
fn assert_sampled(data: &Path, c: &Case) {
    let what = format!("{} {} {:?}", c.file, c.variable, c.index);
    let grid = hdrvis::datasets::load_grid_with(&data.join(c.file), &options(c, data))
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(grid.is_geographic(), "{what}");
    let (lon, lat) = (grid.x().values.clone(), grid.y().values.clone());
    let got = grid.property(c.variable).unwrap();
    let want = reference(data, c, json!({ "lon": lon, "lat": lat }));
    assert_eq!(got.len(), want.len(), "{what}");
    let (mut compared, mut inside) = (0, 0);
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
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
                let tol = if c.on_nodes { 1e-9 } else { 4.0 * f64::EPSILON } * w.abs().max(1.0);
                assert!((g - w).abs() <= tol, "{at}: {g} vs {w}");
                inside += 1;
            }
        }
        compared += 1;
    }
    let share = if c.coastal { 10 } else { 2 };
    assert!(
        inside > compared / share,
        "{what}: {inside} of {compared} inside the mesh"
    );
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
        (
            "icon_data_other_grid.nc",
            "S",
            Some("icon_grid.nc"),
            "uuidOfHGrid 0b7e2f4a-5c1d-4e8f-8a3b-2d9c6e1f7a40, but the grid file",
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

/// Drawing a mesh: the same bad files refused by load_mesh, and what a mesh cannot be asked for
/// (cell edges in a 3-D view or on a grid, another property), each in one line naming
/// the option, with no picture written.
#[test]
fn bad_mesh_drawings_are_refused_in_one_line_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let icon = "load_mesh(\"icon_data.nc\", #{ variable: \"S\", index: #{ time: 0, depth: 0 } })";
    for (call, expected) in [
        (
            "load_mesh(\"bad_index.nc\", #{ variable: \"depth\" })".to_string(),
            "names node 148",
        ),
        (
            "load_mesh(\"icon_data_mismatch.nc\", #{ variable: \"S\", grid: \"icon_grid.nc\", index: #{ time: 0, depth: 0 } })".to_string(),
            "none of the 320 cells",
        ),
        (
            "load_mesh(\"icon_data.nc\", #{ variable: \"S\", index: #{ time: 0 } })".to_string(),
            "keeps [depth=3, ncells=320]",
        ),
        (
            "load_mesh(\"fvcom.nc\", #{ variable: \"time\" })".to_string(),
            "lies on no unstructured mesh",
        ),
        (
            format!("render_surface({icon}, #{{ view: \"perspective\", cell_edges: true }})"),
            "cell_edges: cell edges are drawn on the map and the globe",
        ),
        (
            format!("render_surface({icon}, #{{ property: \"T\" }})"),
            "property: [\"T\"]: a mesh field has one property, \"S\"",
        ),
        (
            format!("render_surface({icon}, #{{ cell_edges: #{{ width: 0.0 }} }})"),
            "cell_edges.width",
        ),
        (
            "render_surface(load_grid(\"icon_data.nc\", #{ variable: \"S\", index: #{ time: 0, depth: 0 } }), #{ cell_edges: true })".to_string(),
            "cell_edges: cells are drawn on meshes",
        ),
    ] {
        let script = format!("let img = {call}; save_png(img, \"out.png\");");
        std::fs::write(dir.path().join("bad.rhai"), &script).unwrap();
        let (code, _, err) = hdrvis(&["run", "bad.rhai", "--out", "bad"], dir.path());
        assert_eq!(code, 1, "{call}: {err}");
        let line = err.lines().next().unwrap_or("");
        assert!(line.contains(expected), "{call}: {err}");
        assert!(!dir.path().join("bad/out.png").exists(), "{call}");
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

/// `img`'s extra channel `name`.
fn channel<'a>(img: &'a hdrvis::model::HdrImage, name: &str) -> &'a [f32] {
    &img.extra_channels
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no channel {name}"))
        .1
}

/// Compares a picture of `field` with the reference at its pixels: `value_at` (f64) equals it
/// exactly for cell data and within 1e-9 relative for node data, and the picture's value channel
/// (f32) equals `value_at` within f32 rounding about the field's range; missing where no cell is.
fn assert_pixels(
    what: &str,
    field: &hdrvis::model::mesh::MeshField,
    img: &hdrvis::model::HdrImage,
    points: &[[f64; 2]],
    want: &[Value],
    on_nodes: bool,
) -> usize {
    let values = channel(img, field.name());
    assert_eq!(values.len(), points.len(), "{what}");
    assert_eq!(want.len(), points.len(), "{what}");
    let (lo, hi) = field.range().unwrap();
    let f32_tol = 2.0 * f32::EPSILON as f64 * lo.abs().max(hi.abs()).max(1.0);
    let mut inside = 0;
    for (k, (p, w)) in points.iter().zip(want).enumerate() {
        let at = format!("{what}: pixel {k} at ({}, {})", p[0], p[1]);
        // A cell whose value is missing shows nothing, as no cell does.
        let exact = field.value_at(p[0], p[1]).filter(|v| !v.is_nan());
        match w {
            Value::String(_) => continue,
            Value::Null => {
                assert!(exact.is_none(), "{at}: {exact:?} where no cell is");
                assert!(values[k].is_nan(), "{at}: {} where no cell is", values[k]);
            }
            w => {
                let w = w.as_f64().unwrap();
                let e = exact.unwrap_or_else(|| panic!("{at}: nothing where {w} is"));
                let tol = if on_nodes { 1e-9 } else { 4.0 * f64::EPSILON } * w.abs().max(1.0);
                assert!((e - w).abs() <= tol, "{at}: {e} vs {w}");
                let g = values[k] as f64;
                assert!((g - e).abs() <= f32_tol, "{at}: drawn {g} vs {e}");
                inside += 1;
            }
        }
    }
    inside
}

/// Where a map picture's pixel-space point (x right, y down, in pixels) lies: (longitude,
/// latitude) on the axes the picture records.
fn map_point(img: &hdrvis::model::HdrImage, [x, y]: [f64; 2]) -> [f64; 2] {
    let extent = |key: &str| -> [f64; 2] {
        let v: Vec<f64> = img
            .meta(key)
            .unwrap()
            .split_whitespace()
            .map(|t| t.parse().unwrap())
            .collect();
        [v[0], v[1]]
    };
    let ([x0, x1], [y0, y1]) = (extent("map_x_extent"), extent("map_y_extent"));
    [
        x0 + x * (x1 - x0) / img.width as f64,
        y1 - y * (y1 - y0) / img.height as f64,
    ]
}

fn mesh_renderer() -> hdrvis::render::surface::SurfaceRenderer {
    let backend = crate::common::backends()[0];
    hdrvis::render::surface::SurfaceRenderer::new(
        crate::common::renderer(backend).context().clone(),
    )
}

#[test]
fn meshes_drawn_cell_by_cell_show_the_brute_force_value_at_every_pixel() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let r = mesh_renderer();
    for c in &CASES {
        assert_map(&r, dir.path(), c);
    }
}

/// `c` (in `data`) loaded with load_mesh.
fn mesh_field(data: &Path, c: &Case) -> std::sync::Arc<hdrvis::model::mesh::MeshField> {
    let opts = LoadOptions {
        resolution: None,
        ..options(c, data)
    };
    std::sync::Arc::new(
        hdrvis::datasets::load_mesh(&data.join(c.file), &opts)
            .unwrap_or_else(|e| panic!("{} {}: {e}", c.file, c.variable)),
    )
}

/// A 120-pixel map of `c` (in `data`) drawn cell by cell shows the reference at every pixel's
/// centre, a third of them on cells at least.
fn assert_map(r: &hdrvis::render::surface::SurfaceRenderer, data: &Path, c: &Case) {
    use hdrvis::render::surface::{FringeMode, SurfaceOptions};
    let what = format!("{} {} {:?} map", c.file, c.variable, c.index);
    let field = mesh_field(data, c);
    let surface = SurfaceOptions {
        mode: FringeMode::Direct,
        antialias: false,
        width: Some(120),
        ..Default::default()
    };
    let img = r.render_mesh(&field, &surface).unwrap().remove(0);
    // The pixels' centres on the map's axes, rows from the north.
    let (w, h) = (img.width as usize, img.height as usize);
    let lon: Vec<f64> = (0..w)
        .map(|i| map_point(&img, [i as f64 + 0.5, 0.5])[0])
        .collect();
    let lat: Vec<f64> = (0..h)
        .map(|j| map_point(&img, [0.5, j as f64 + 0.5])[1])
        .collect();
    let points: Vec<[f64; 2]> = lat
        .iter()
        .flat_map(|&b| lon.iter().map(move |&a| [a, b]))
        .collect();
    let want = reference(data, c, json!({ "lon": lon, "lat": lat }));
    let inside = assert_pixels(&what, &field, &img, &points, &want, c.on_nodes);
    let share = if c.coastal { 10 } else { 3 };
    assert!(
        inside > points.len() / share,
        "{what}: {inside} pixels inside"
    );
}

#[test]
fn meshes_on_the_globe_show_the_brute_force_value_where_each_ray_meets_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let r = mesh_renderer();
    // A global triangle mesh (cells), a Voronoi mesh (vertex data) and the columns, seen over
    // a pole so that the cap cells and the antimeridian are in view.
    for (k, lat) in [(3, 70.0), (6, -60.0), (12, 20.0)] {
        assert_globe(&r, dir.path(), &CASES[k], [lat, 170.0]);
    }
}

/// A 64² globe of `c` (in `data`) from above `at` (latitude, longitude) drawn cell by cell shows
/// the reference where each pixel's ray meets the sphere, on 1500 pixels at least.
fn assert_globe(r: &hdrvis::render::surface::SurfaceRenderer, data: &Path, c: &Case, at: [f64; 2]) {
    use hdrvis::model::Camera;
    use hdrvis::render::surface::{FringeMode, SurfaceOptions, SurfaceView};
    let what = format!("{} {} globe", c.file, c.variable);
    let field = mesh_field(data, c);
    let camera = Camera::geo([0.0; 3], at[0], at[1], 3.2, 40.0).unwrap();
    let surface = SurfaceOptions {
        mode: FringeMode::Direct,
        antialias: false,
        view: SurfaceView::Globe(camera),
        width: Some(64),
        height: Some(64),
        ..Default::default()
    };
    let img = r.render_mesh(&field, &surface).unwrap().remove(0);
    // Where each pixel's ray meets the unit sphere (the nearer root), as longitude, latitude;
    // pixels off the sphere are far away, where no cell is.
    let points: Vec<[f64; 2]> = (0..64 * 64)
        .map(|p| {
            let (o, d) = camera.ray(p % 64, p / 64, 64, 64);
            let b = o[0] * d[0] + o[1] * d[1] + o[2] * d[2];
            let cc = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - 1.0;
            let disc = b * b - cc;
            if disc < 0.0 {
                return [0.0, 95.0];
            }
            let t = -b - disc.sqrt();
            let q = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
            let la = q[2].atan2(q[0].hypot(q[1])).to_degrees();
            [q[1].atan2(q[0]).to_degrees(), la]
        })
        .collect();
    let want = reference(data, c, json!({ "points": points }));
    let inside = assert_pixels(&what, &field, &img, &points, &want, c.on_nodes);
    assert!(inside > 1500, "{what}: {inside} pixels on cells");
}

#[test]
fn antialiased_pixels_are_the_mean_of_their_four_quarter_points() {
    use hdrvis::render::surface::{FringeMode, SurfaceOptions};
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let c = &CASES[0];
    let opts = LoadOptions {
        resolution: None,
        ..options(c, dir.path())
    };
    let field =
        std::sync::Arc::new(hdrvis::datasets::load_mesh(&dir.path().join(c.file), &opts).unwrap());
    let surface = SurfaceOptions {
        mode: FringeMode::Direct,
        width: Some(90),
        ..Default::default()
    };
    let img = mesh_renderer()
        .render_mesh(&field, &surface)
        .unwrap()
        .remove(0);
    let values = channel(&img, c.variable);
    let (w, h) = (img.width as usize, img.height as usize);
    let (mut blended, mut whole) = (0, 0);
    for j in 0..h {
        for i in 0..w {
            let quarter: Vec<f64> = [[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]
                .iter()
                .filter_map(|o| {
                    let [lon, lat] = map_point(&img, [i as f64 + o[0], j as f64 + o[1]]);
                    field.value_at(lon, lat).filter(|v| v.is_finite())
                })
                .collect();
            let g = values[j * w + i] as f64;
            if quarter.len() < 2 {
                assert!(
                    g.is_nan(),
                    "pixel ({i}, {j}): {g} on {} points",
                    quarter.len()
                );
                continue;
            }
            let mean = quarter.iter().sum::<f64>() / quarter.len() as f64;
            assert!(
                (g - mean).abs() <= 1e-4 * mean.abs().max(1.0),
                "({i}, {j}): {g} vs {mean}"
            );
            if quarter.iter().any(|v| *v != quarter[0]) {
                blended += 1;
            } else {
                whole += 1;
            }
        }
    }
    // Edges blend; most pixels lie inside one cell.
    assert!(
        blended > 50 && whole > blended,
        "{blended} blended, {whole} whole"
    );
}

/// A real UGRID file from the package registries: the Met Office's LFRic C4 cubed-sphere mesh
/// (96 quadrilaterals, start_index 1, longitudes in [0°, 360°)) with synthetic values, shipped in
/// iris-sample-data and pinned in the conformance corpus. Sampled, drawn on the map and drawn on
/// the globe over a cube corner, it shows the brute-force reference at every node and pixel.
#[test]
fn a_real_ugrid_mesh_from_the_registries_samples_and_draws_as_brute_force_location_does() {
    let Some(corpus) = crate::conformance::corpus() else {
        return;
    };
    let c = Case {
        file: "iris-sample-data/mesh_C4_synthetic_float.nc",
        grid: None,
        variable: "synthetic",
        index: &[],
        step: 2.0,
        on_nodes: false,
        mesh: None,
        coastal: false,
    };
    let files = corpus.join("files");
    let field = mesh_field(&files, &c);
    assert_eq!(
        field.describe(),
        "synthetic on the UGRID mesh of 96 cells and 98 nodes, values on its cells (nexample_C4_face)"
    );
    assert_sampled(&files, &c);
    let r = mesh_renderer();
    assert_map(&r, &files, &c);
    assert_globe(&r, &files, &c, [35.26, 45.0]);
    // A ship's track (ARM's navigation data in act-atmos: lat(time), lon(time)) is a path in
    // time, not columns to triangulate.
    let track = files.join("act-atmos/marnavM1.a1.20180201.000000.nc");
    let opts = LoadOptions {
        variable: Some("roll".into()),
        ..LoadOptions::default()
    };
    let e = hdrvis::datasets::load_mesh(&track, &opts).unwrap_err();
    assert!(
        e.to_string().contains("lies on no unstructured mesh"),
        "{e}"
    );
}

/// Real meshes as model centres and their tools publish them, pinned in the conformance corpus
/// (tests/python/conformance.py): LFRic cubed spheres in UGRID with a misspelt cf_role and
/// latitudes named first (cf-python), FESOM2 output with no coordinates beside its mesh file
/// (pyfesom2), ICON output in CDI's layout (ESMValCore), a UGRID 0.9 file whose connectivity
/// runs (nodes, faces) (pyugrid), and NCL's example data from Debian: ICON-ocean R2B4 output,
/// CAM-SE ne30 columns, a SCRIP grid of hexagons and pentagons in radians, and two coastal
/// triangle meshes, one without any attributes. Each variable sampled onto a grid, and drawn on
/// the map, shows the brute-force reference (which reads each file as its header states) at every
/// node and pixel.
const REAL: [Case; 12] = [
    Case {
        file: "cf-python/ugrid_global_1.nc",
        grid: None,
        variable: "surface_altitude",
        index: &[],
        step: 3.0,
        on_nodes: false,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "node_lon", "lat": "node_lat", "faces": "face_nodes", "face_dims": ["dim0"]}"#,
        ),
        coastal: false,
    },
    Case {
        file: "cf-python/ugrid_global_2.nc",
        grid: None,
        variable: "theta",
        index: &[("time", 0)],
        step: 2.0,
        on_nodes: false,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "Mesh2d_node_x", "lat": "Mesh2d_node_y", "faces": "face_nodes", "face_dims": ["nMesh2d_face"]}"#,
        ),
        coastal: false,
    },
    Case {
        file: "pyfesom2/a_ice.fesom.1948.nc",
        grid: Some("pyfesom2/fesom.mesh.diag.nc"),
        variable: "a_ice",
        index: &[("time", 0)],
        step: 2.0,
        on_nodes: true,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "lon", "lat": "lat", "faces": "elements", "faces_first": false, "base": 1, "node_dims": ["nod2"], "face_dims": ["elem"]}"#,
        ),
        coastal: false,
    },
    Case {
        file: "pyfesom2/u.fesom.1948.nc",
        grid: Some("pyfesom2/fesom.mesh.diag.nc"),
        variable: "u",
        index: &[("time", 0), ("nz1", 0)],
        step: 2.0,
        on_nodes: false,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "lon", "lat": "lat", "faces": "elements", "faces_first": false, "base": 1, "node_dims": ["nod2"], "face_dims": ["elem"]}"#,
        ),
        coastal: false,
    },
    Case {
        file: "esmvalcore/icon_atm_2d.nc",
        grid: None,
        variable: "tas",
        index: &[("time", 0)],
        step: 10.0,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "pyugrid/ElevenPoints_UGRIDv0.9.nc",
        grid: None,
        variable: "Mesh2_depth",
        index: &[],
        step: 0.25,
        on_nodes: true,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "Mesh2_node_x", "lat": "Mesh2_node_y", "faces": "Mesh2_face_nodes", "faces_first": false, "node_dims": ["nMesh2_node"], "face_dims": ["nMesh2_face"]}"#,
        ),
        coastal: false,
    },
    Case {
        file: "pyugrid/ElevenPoints_UGRIDv0.9.nc",
        grid: None,
        variable: "Mesh2_face_u",
        index: &[],
        step: 0.25,
        on_nodes: false,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "Mesh2_node_x", "lat": "Mesh2_node_y", "faces": "Mesh2_face_nodes", "faces_first": false, "node_dims": ["nMesh2_node"], "face_dims": ["nMesh2_face"]}"#,
        ),
        coastal: false,
    },
    Case {
        file: "libncarg-data/triangular_grid_ICON.nc",
        grid: None,
        variable: "S",
        index: &[("time", 0), ("depth", 0)],
        step: 2.0,
        on_nodes: false,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "libncarg-data/camse_unstructured_grid.nc",
        grid: None,
        variable: "T850",
        index: &[],
        step: 2.0,
        on_nodes: true,
        mesh: None,
        coastal: false,
    },
    Case {
        file: "libncarg-data/hswm_d000000p000.g2.nc",
        grid: None,
        variable: "height",
        index: &[("time", 0)],
        step: 3.0,
        on_nodes: false,
        mesh: Some(
            r#"{"kind": "corners", "lon": "grid_corner_lon", "lat": "grid_corner_lat", "face_dims": ["grid_cells"]}"#,
        ),
        coastal: false,
    },
    Case {
        file: "libncarg-data/ctcbay.nc",
        grid: None,
        variable: "depth",
        index: &[],
        step: 0.02,
        on_nodes: true,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "lon", "lat": "lat", "faces": "ele", "base": 1, "node_dims": ["node"]}"#,
        ),
        coastal: true,
    },
    Case {
        file: "libncarg-data/ctnccl.nc",
        grid: None,
        variable: "dat",
        index: &[],
        step: 0.03,
        on_nodes: true,
        mesh: Some(
            r#"{"kind": "nodes", "lon": "lon", "lat": "lat", "faces": "ele", "base": 1, "node_dims": ["nodes"]}"#,
        ),
        coastal: true,
    },
];

#[test]
fn real_meshes_from_the_registries_sample_and_draw_as_brute_force_location_does() {
    let Some(corpus) = crate::conformance::corpus() else {
        return;
    };
    let files = corpus.join("files");
    let r = mesh_renderer();
    for c in &REAL {
        assert_sampled(&files, c);
        assert_map(&r, &files, c);
    }
    // The global ones round a pole, where cells close along it; the CAM-SE columns away from
    // it: the 8 triangles round their pole column are widened there into quadrilaterals whose
    // node values are linear over a fan from each triangle's first node, and qhull (the
    // reference's triangulation) lists those nodes from another one than hdrvis's does.
    for (k, at) in [
        (0, [60.0, 100.0]),
        (2, [-40.0, -150.0]),
        (7, [-70.0, 170.0]),
        (8, [30.0, 100.0]),
    ] {
        assert_globe(&r, &files, &REAL[k], at);
    }
    let described = |c: &Case| mesh_field(&files, c).describe();
    assert_eq!(
        described(&REAL[5]),
        "Mesh2_depth on the UGRID mesh of 13 cells and 11 nodes, values on its nodes (nMesh2_node)"
    );
    assert_eq!(
        described(&REAL[6]),
        "Mesh2_face_u on the UGRID mesh of 13 cells and 11 nodes, values on its cells (nMesh2_face)"
    );
    // ICON atmosphere output of another R2B4 numbering, with no coordinates: given the ocean
    // file as its grid, the pairing rests on the count alone, and the description says so.
    let other = Case {
        file: "libncarg-data/atm_phy_mag0004_1985.nc",
        grid: Some("libncarg-data/triangular_grid_ICON.nc"),
        variable: "ts",
        index: &[("time", 0)],
        step: 2.0,
        on_nodes: false,
        mesh: None,
        coastal: false,
    };
    assert!(
        described(&other).ends_with(
            "values on its cells (ncells; paired with triangular_grid_ICON.nc by its 20480 count \
             alone: the values name the grid uuidOfHGrid f25aa6bc-809a-11e2-839d-15e92cba77d6, \
             which triangular_grid_ICON.nc does not carry)"
        ),
        "{}",
        described(&other)
    );
}

/// Fringes on a mesh keep their phase exact at every pixel: with ν·d near 10⁷ the point fringe of
/// each pixel equals (1 + cos 2πν·d)/2 computed in f64 from the value at its centre (within 2e-5),
/// where d as one f32 (the naive phase) is off by most of a fringe somewhere.
#[test]
fn fringes_on_meshes_keep_the_phase_exact_at_every_pixel() {
    use hdrvis::render::surface::{fringe_f64, FringeMode, PhaseMethod, SurfaceOptions};
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let c = &CASES[1]; // UGRID node data: elev = 100 + 3·lon − 2·lat
    let field = mesh_field(dir.path(), c);
    let (lo, hi) = field.range().unwrap();
    let nu = 1e7 / lo.abs().max(hi.abs());
    let r = mesh_renderer();
    let mut worst = [0.0f64; 2];
    for (k, phase) in [PhaseMethod::Reduced, PhaseMethod::Naive]
        .into_iter()
        .enumerate()
    {
        let surface = SurfaceOptions {
            mode: FringeMode::Cyclic,
            nu: vec![nu],
            phase,
            antialias: false,
            width: Some(100),
            ..Default::default()
        };
        let img = r.render_mesh(&field, &surface).unwrap().remove(0);
        let fringe = channel(&img, "fringe");
        let (w, h) = (img.width as usize, img.height as usize);
        let mut compared = 0;
        for j in 0..h {
            for i in 0..w {
                let [lon, lat] = map_point(&img, [i as f64 + 0.5, j as f64 + 0.5]);
                let Some(d) = field.value_at(lon, lat).filter(|v| v.is_finite()) else {
                    continue;
                };
                let got = fringe[j * w + i] as f64;
                worst[k] = worst[k].max((got - fringe_f64(nu, d)).abs());
                compared += 1;
            }
        }
        assert!(compared > w * h / 3, "{compared} pixels");
    }
    assert!(worst[0] <= 2e-5, "reduced phase: {}", worst[0]);
    assert!(worst[1] > 0.1, "naive phase: {}", worst[1]);
}

/// A 3-D view of a mesh over its own relief draws the grid load_grid samples it onto (at the
/// cells' median size): the same picture, value for value, as that grid's.
#[test]
fn a_perspective_view_of_a_mesh_draws_the_grid_it_samples_onto() {
    use hdrvis::render::surface::{FringeMode, SurfaceOptions, SurfaceView};
    let dir = tempfile::tempdir().unwrap();
    if !cases(dir.path()) {
        return;
    }
    let c = &CASES[9]; // FVCOM zeta on the nodes
    let field = mesh_field(dir.path(), c);
    let grid = hdrvis::datasets::load_grid_with(
        &dir.path().join(c.file),
        &LoadOptions {
            resolution: None,
            ..options(c, dir.path())
        },
    )
    .unwrap();
    let opts = SurfaceOptions {
        mode: FringeMode::Modulated,
        view: SurfaceView::Orbit {
            azimuth: -60.0,
            elevation: 35.0,
            fov: 40.0,
        },
        relief: Some(c.variable.into()),
        exaggeration: 2000.0,
        width: Some(96),
        height: Some(64),
        ..Default::default()
    };
    let r = mesh_renderer();
    let from_mesh = r.render_mesh(&field, &opts).unwrap().remove(0);
    let from_grid = r.render(&grid, &opts).unwrap().remove(0);
    let (a, b) = (
        channel(&from_mesh, c.variable),
        channel(&from_grid, c.variable),
    );
    let drawn = a.iter().filter(|v| v.is_finite()).count();
    assert!(drawn > 96 * 64 / 8, "{drawn} pixels on the surface");
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            x == y || (x.is_nan() && y.is_nan()),
            "pixel {k}: {x} vs {y}"
        );
    }
    assert!(from_mesh
        .meta("mesh_samples")
        .unwrap()
        .contains("median size"));
}
