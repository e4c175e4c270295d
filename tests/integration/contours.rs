//! Contour lines and vector arrows over surface pictures: lines against the closed-form level
//! set on a plain map, a projected map (placed by PROJ-tested projections) and a section;
//! arrows and contours from scripts, from the rendered grid and from another; bad options
//! refused in one line with nothing written.

use hdrvis::model::contour::contour_lines;
use hdrvis::model::{
    CoordKind, Grid, GridCoords, HdrImage, MapProjection, ProjectionKind, Projector,
};
use hdrvis::render::surface::{
    ContourLevels, ContourStyle, FringeMode, SurfaceOptions, SurfaceRenderer, SurfaceView,
};

fn renderer() -> SurfaceRenderer {
    let backend = crate::common::backends()[0];
    SurfaceRenderer::new(crate::common::renderer(backend).context().clone())
}

fn axis(kind: CoordKind, units: &str, values: Vec<f64>) -> GridCoords {
    GridCoords {
        name: "a".into(),
        units: units.into(),
        values,
        kind,
        edges: None,
    }
}

/// The pixels a line overlay changed: where the two pictures differ, as pixel centres.
fn changed(plain: &HdrImage, lined: &HdrImage) -> Vec<[f64; 2]> {
    let w = plain.width as usize;
    (0..plain.pixels.len())
        .filter(|&k| plain.pixels[k] != lined.pixels[k])
        .map(|k| [(k % w) as f64 + 0.5, (k / w) as f64 + 0.5])
        .collect()
}

fn with_contours(levels: Vec<f64>) -> Option<ContourStyle> {
    Some(ContourStyle {
        levels: ContourLevels::Values(levels),
        ..ContourStyle::default()
    })
}

#[test]
fn contours_of_circles_lie_within_half_a_pixel_of_the_closed_form() {
    // f = x² + y² on 81 × 81 nodes over [−2, 2]², drawn 400 px square: the map spans half a
    // spacing beyond the end nodes, [−2.025, 2.025], at 400/4.05 px per unit.
    let xs: Vec<f64> = (0..81).map(|i| -2.0 + 0.05 * i as f64).collect();
    let f: Vec<f64> = xs
        .iter()
        .flat_map(|&y| xs.iter().map(move |&x| x * x + y * y))
        .collect();
    let grid = Grid::with_coords(
        "circles",
        axis(CoordKind::Plain, "km", xs.clone()),
        axis(CoordKind::Plain, "km", xs),
        vec![("f".into(), f)],
        None,
    )
    .unwrap();
    let per_unit = 400.0 / 4.05;
    let to_px = |p: [f64; 2]| [(p[0] + 2.025) * per_unit, (2.025 - p[1]) * per_unit];
    let radii = [1.0, 1.5];
    // The traced lines' vertices: on the circle within half a pixel.
    for l in contour_lines(&grid, 0, &radii.map(|r| r * r)) {
        let r = l.level.sqrt();
        assert!(l.closed());
        for p in &l.points {
            let off = (p[0].hypot(p[1]) - r).abs() * per_unit;
            assert!(off < 0.5, "r = {r}: vertex {p:?} {off} px off");
        }
    }
    let r = renderer();
    let opts = SurfaceOptions {
        mode: FringeMode::Direct,
        width: Some(400),
        height: Some(400),
        ..Default::default()
    };
    let plain = r.render(&grid, &opts).unwrap().remove(0);
    let lined = r
        .render(
            &grid,
            &SurfaceOptions {
                contours: with_contours(radii.map(|r| r * r).to_vec()),
                ..opts.clone()
            },
        )
        .unwrap()
        .remove(0);
    let drawn = changed(&plain, &lined);
    // A 1-px line covers pixels whose centre lies under a pixel from it; the line within half
    // a pixel of the circle.
    for p in &drawn {
        let d = radii
            .iter()
            .map(|r| {
                ((p[0] / per_unit - 2.025).hypot(2.025 - p[1] / per_unit) - r).abs() * per_unit
            })
            .fold(f64::INFINITY, f64::min);
        assert!(d < 1.5, "pixel {p:?} {d} px from both circles");
    }
    // And all round each circle.
    for r in radii {
        for k in 0..360 {
            let t = (k as f64).to_radians();
            let c = to_px([r * t.cos(), r * t.sin()]);
            assert!(
                drawn.iter().any(|p| (p[0] - c[0]).hypot(p[1] - c[1]) < 1.0),
                "r = {r}: nothing drawn near {c:?}"
            );
        }
    }
    assert!(lined
        .meta("contours")
        .unwrap()
        .starts_with("2 lines at 1 2.25"));
}

#[test]
fn contours_of_latitude_follow_the_projected_parallels() {
    let lon: Vec<f64> = (0..180).map(|i| -179.0 + 2.0 * i as f64).collect();
    let lat: Vec<f64> = (0..90).map(|j| -89.0 + 2.0 * j as f64).collect();
    let t = lat
        .iter()
        .flat_map(|&y| lon.iter().map(move |_| y))
        .collect();
    let grid = Grid::from_lon_lat("world", lon, lat, vec![("t".into(), t)]).unwrap();
    let p = MapProjection {
        lon_0: Some(0.0),
        ..MapProjection::new(ProjectionKind::Robinson)
    };
    let opts = SurfaceOptions {
        mode: FringeMode::Direct,
        width: Some(800),
        projection: Some(p),
        ..Default::default()
    };
    let r = renderer();
    let plain = r.render(&grid, &opts).unwrap().remove(0);
    let lined = r
        .render(
            &grid,
            &SurfaceOptions {
                contours: with_contours(vec![30.0, -45.0]),
                ..opts.clone()
            },
        )
        .unwrap()
        .remove(0);
    let world = hdrvis::model::LonLatBox {
        west: -180.0,
        east: 180.0,
        south: -90.0,
        north: 90.0,
    };
    let projector = Projector::new(&p, &world).unwrap();
    let meta = |k: &str| -> Vec<f64> {
        lined
            .meta(k)
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect()
    };
    let (c, s) = (
        meta("map_projection_centre"),
        meta("map_projection_scale")[0],
    );
    let px = |xy: [f64; 2]| {
        [
            400.0 + (xy[0] - c[0]) / s,
            0.5 * lined.height as f64 - (xy[1] - c[1]) / s,
        ]
    };
    // The parallels, projected every 0.05°.
    let parallels: Vec<[f64; 2]> = [30.0, -45.0]
        .iter()
        .flat_map(|&lat| (0..7200).map(move |k| (-180.0 + 0.05 * k as f64, lat)))
        .filter_map(|(lon, lat)| projector.forward(lon, lat).map(px))
        .collect();
    let drawn = changed(&plain, &lined);
    assert!(drawn.len() > 1000, "{}", drawn.len());
    for p in &drawn {
        let d = parallels
            .iter()
            .map(|q| (p[0] - q[0]).hypot(p[1] - q[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(d < 1.5, "pixel {p:?} {d} px from the parallels");
    }
}

#[test]
fn contours_on_a_section_run_along_its_depths() {
    // A section-like grid: distance along x, depth down y; f = depth, level 350 km.
    let x: Vec<f64> = (0..50).map(|i| 100.0 * i as f64).collect();
    let y: Vec<f64> = (0..30).map(|j| 25.0 * j as f64).collect();
    let f = y.iter().flat_map(|&d| x.iter().map(move |_| d)).collect();
    let grid = Grid::with_coords(
        "section",
        axis(CoordKind::Plain, "km", x),
        axis(CoordKind::Depth, "km", y),
        vec![("f".into(), f)],
        None,
    )
    .unwrap();
    let opts = SurfaceOptions {
        mode: FringeMode::Direct,
        view: SurfaceView::Map,
        width: Some(500),
        height: Some(300),
        ..Default::default()
    };
    let r = renderer();
    let plain = r.render(&grid, &opts).unwrap().remove(0);
    let lined = r
        .render(
            &grid,
            &SurfaceOptions {
                contours: with_contours(vec![350.0]),
                ..opts.clone()
            },
        )
        .unwrap()
        .remove(0);
    // Depths −12.5 (top) to 737.5 km over 300 rows: 350 km at row 145.
    let row = (350.0 + 12.5) / 750.0 * 300.0;
    let drawn = changed(&plain, &lined);
    assert!(drawn.len() >= 500, "{}", drawn.len());
    assert!(drawn.iter().all(|p| (p[1] - row).abs() < 1.5), "{drawn:?}");
}

/// From a script: a wind map with arrows over pressure with labelled contours from another
/// grid, on the plain map and in Robinson; then what contours and vectors cannot be asked for,
/// each refused in one line naming the option, with nothing written.
#[test]
fn scripts_draw_contours_and_arrows_and_refuse_bad_ones_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let Some(report) = crate::cli::python_check(
        "projection_cases.py",
        &["write", dir.path().to_str().unwrap()],
    ) else {
        return;
    };
    assert!(report.starts_with("exit 0\n"), "{report}");
    let script = r#"
        let w = load_grid("wind.nc");
        let p = load_grid("psl.nc");
        for proj in ["equirectangular", "robinson"] {
            let img = render_surface(w, #{ property: "uas", mode: "direct", projection: proj, width: 480,
                coastlines: true, vectors: #{ u: "uas", v: "vas", spacing: 24, reference: 10.0 },
                contours: #{ grid: p, levels: 6, labels: true } });
            print(img.meta("vectors"));
            print(img.meta("contours"));
            save_png(img, proj + ".png");
        }
        // The colour bar says what it measures: the long name and units, or the label given.
        print(render_surface(p, #{ mode: "direct", width: 64 }).meta("legend_label"));
        print(render_surface(p, #{ mode: "direct", width: 64, label: "SLP (hPa)" }).meta("legend_label"));
        print(render_surface(p, #{ width: 64 }).meta("legend_label"));
    "#;
    std::fs::write(dir.path().join("w.rhai"), script).unwrap();
    let (code, out, err) = crate::cli::hdrvis(&["run", "w.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("arrows of (uas, vas) every 24 px") && out.contains("reference 10"),
        "{out}"
    );
    assert!(
        out.contains("lines at 992.5 995 997.5 1000 1002.5 1005 1007.5,"),
        "{out}"
    );
    assert!(dir.path().join("o/robinson.png").is_file());
    let labels: Vec<&str> = out.lines().rev().take(3).collect();
    assert_eq!(
        labels,
        [
            "sea-level pressure (hPa) within a fringe",
            "SLP (hPa)",
            "sea-level pressure (hPa)"
        ]
    );
    let g = "load_grid(\"wind.nc\")";
    let cases = [
        ("vectors: #{ u: \"uas\" }", "vectors: v is required"),
        ("vectors: #{ u: \"uas\", v: \"ws\" }", "vectors.v:"),
        (
            "vectors: #{ u: \"uas\", v: \"vas\", spacing: 2 }",
            "spacing",
        ),
        ("vectors: true", "vectors: expected a map"),
        (
            "contours: 0",
            "contours: expected a count of levels from 1 to 100",
        ),
        ("contours: #{ property: \"psl\" }", "contours.property:"),
        (
            "contours: true, view: \"perspective\"",
            "contours: contours are drawn on map and globe views",
        ),
        ("contours: #{ grid: 3 }", "contours.grid: expected a grid"),
        ("contours: #{ colour: \"no such colour\" }", "contours"),
    ];
    crate::cli::surface_options_refused(dir.path(), g, &cases);
}
