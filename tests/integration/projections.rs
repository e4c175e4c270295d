//! Map projections and uneven axes, judged against PROJ (pyproj) and files written by
//! netCDF4-python (tests/python/projection_cases.py): projected points within 0.1 px of PROJ's
//! at 1024 px; every sampled pixel of a projected map shows the field where PROJ's inverse puts
//! it; graticules drawn where PROJ puts them; Gaussian and equator-refined latitudes each drawn
//! at their own latitude.

use crate::cli::python_check;
use hdrvis::model::{Grid, HdrImage, LonLatBox, MapProjection, ProjectionKind, Projector};
use hdrvis::render::surface::{FringeMode, SurfaceOptions, SurfaceRenderer, SurfaceView};
use serde_json::{json, Value};
use std::path::Path;

fn renderer() -> SurfaceRenderer {
    let backend = crate::common::backends()[0];
    SurfaceRenderer::new(crate::common::renderer(backend).context().clone())
}

const WORLD: LonLatBox = LonLatBox {
    west: -180.0,
    east: 180.0,
    south: -90.0,
    north: 90.0,
};

/// A world grid at 2°: t is the node's latitude, u its longitude.
fn world() -> Grid {
    let lon: Vec<f64> = (0..180).map(|i| -179.0 + 2.0 * i as f64).collect();
    let lat: Vec<f64> = (0..90).map(|j| -89.0 + 2.0 * j as f64).collect();
    let t = lat
        .iter()
        .flat_map(|&y| lon.iter().map(move |_| y))
        .collect();
    let u = lat.iter().flat_map(|_| lon.iter().copied()).collect();
    Grid::from_lon_lat("world", lon, lat, vec![("t".into(), t), ("u".into(), u)]).unwrap()
}

/// Every projection with its parameters given (so PROJ is handed the same string).
fn projections() -> Vec<MapProjection> {
    let p = |kind, lon_0: f64, lat_0: f64, lat_1: f64, lat_2: f64| MapProjection {
        kind,
        lon_0: Some(lon_0),
        lat_0: Some(lat_0),
        lat_1: Some(lat_1),
        lat_2: Some(lat_2),
    };
    vec![
        p(ProjectionKind::Robinson, 0.0, 0.0, 0.0, 0.0),
        p(ProjectionKind::Mollweide, 20.0, 0.0, 0.0, 0.0),
        p(ProjectionKind::Orthographic, -30.0, 40.0, 0.0, 0.0),
        p(ProjectionKind::PolarNorth, -45.0, 90.0, 0.0, 0.0),
        p(ProjectionKind::PolarSouth, 0.0, -90.0, 0.0, 0.0),
        p(ProjectionKind::Lambert, -95.0, 38.0, 26.0, 50.0),
    ]
}

fn render(
    r: &SurfaceRenderer,
    grid: &Grid,
    p: &MapProjection,
    graticule: Option<f64>,
) -> Vec<HdrImage> {
    let opts = SurfaceOptions {
        properties: vec!["t".into(), "u".into()],
        mode: FringeMode::Direct,
        view: SurfaceView::Map,
        width: Some(1024),
        projection: Some(*p),
        graticule,
        ..Default::default()
    };
    r.render(grid, &opts).unwrap()
}

/// Where the picture's plane lies: its PROJ string, the plane's point at the picture's centre
/// and metres per pixel, as the image records them.
struct Plane {
    proj: String,
    centre: [f64; 2],
    scale: f64,
    size: [f64; 2],
}

impl Plane {
    fn of(img: &HdrImage) -> Plane {
        let described = img.meta("map_projection").expect("a projected map");
        let proj = described[described.find('(').unwrap() + 1..described.len() - 1].to_string();
        let c: Vec<f64> = img
            .meta("map_projection_centre")
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        Plane {
            proj,
            centre: [c[0], c[1]],
            scale: img.meta("map_projection_scale").unwrap().parse().unwrap(),
            size: [img.width as f64, img.height as f64],
        }
    }

    fn pixel(&self, [x, y]: [f64; 2]) -> [f64; 2] {
        [
            0.5 * self.size[0] + (x - self.centre[0]) / self.scale,
            0.5 * self.size[1] - (y - self.centre[1]) / self.scale,
        ]
    }

    fn xy(&self, [px, py]: [f64; 2]) -> [f64; 2] {
        [
            self.centre[0] + (px - 0.5 * self.size[0]) * self.scale,
            self.centre[1] - (py - 0.5 * self.size[1]) * self.scale,
        ]
    }
}

/// PROJ's answers to `request` (see projection_cases.py), or `None` when Python is missing.
fn proj(dir: &Path, request: &Value) -> Option<Vec<Value>> {
    let path = dir.join("request.json");
    std::fs::write(&path, request.to_string()).unwrap();
    let report = python_check("projection_cases.py", &["points", path.to_str().unwrap()])?;
    assert!(report.starts_with("exit 0\n"), "{report}");
    let body = report.split_once('\n').unwrap().1;
    let parsed: Value = serde_json::from_str(body.trim())
        .unwrap_or_else(|e| panic!("projection_cases.py: {e}\n{report}"));
    Some(parsed.as_array().unwrap().clone())
}

fn pair(v: &Value) -> Option<[f64; 2]> {
    let a = v.as_array()?;
    Some([a[0].as_f64()?, a[1].as_f64()?])
}

#[test]
fn graticule_and_coastline_points_project_within_a_tenth_of_a_pixel_of_proj() {
    let dir = tempfile::tempdir().unwrap();
    let r = renderer();
    let grid = world();
    let mut points: Vec<[f64; 2]> = Vec::new();
    for lat in (-80..=80).step_by(10) {
        for lon in (-180..180).step_by(10) {
            points.push([lon as f64, lat as f64]);
        }
    }
    let coast = hdrvis::datasets::coastlines::coastlines(
        hdrvis::datasets::coastlines::CoastResolution::Coarse,
    );
    points.extend(coast.iter().flatten().step_by(7).copied());
    let planes: Vec<Plane> = projections()
        .iter()
        .map(|p| Plane::of(&render(&r, &grid, p, None)[0]))
        .collect();
    let request: Vec<Value> = planes
        .iter()
        .map(|pl| json!({ "proj": pl.proj, "forward": points }))
        .collect();
    let Some(answers) = proj(dir.path(), &json!(request)) else {
        return;
    };
    for ((p, pl), answer) in projections().iter().zip(&planes).zip(&answers) {
        let ours = Projector::new(p, &WORLD).unwrap();
        assert_eq!(ours.projection().proj_string(), pl.proj);
        let theirs = answer["forward"].as_array().unwrap();
        let mut compared = 0;
        for (&[lon, lat], t) in points.iter().zip(theirs) {
            let Some(xy) = ours.forward(lon, lat) else {
                continue;
            };
            let t = pair(t).unwrap_or_else(|| panic!("{p:?}: PROJ places no ({lon}, {lat})"));
            let (a, b) = (pl.pixel(xy), pl.pixel(t));
            let d = (a[0] - b[0]).hypot(a[1] - b[1]);
            assert!(d < 0.1, "{:?} ({lon}, {lat}): {d} px from PROJ", p.kind);
            compared += 1;
        }
        assert!(compared > 500, "{:?}: only {compared} points shown", p.kind);
    }
}

#[test]
fn every_pixel_of_a_projected_map_shows_the_field_where_proj_unprojects_it() {
    let dir = tempfile::tempdir().unwrap();
    let r = renderer();
    let grid = world();
    let mut pictures = Vec::new();
    let mut request = Vec::new();
    for p in projections() {
        let imgs = render(&r, &grid, &p, None);
        let plane = Plane::of(&imgs[0]);
        let pixels: Vec<[usize; 2]> = (0..imgs[0].height as usize)
            .step_by(5)
            .flat_map(|j| (0..imgs[0].width as usize).step_by(5).map(move |i| [i, j]))
            .collect();
        let xy: Vec<[f64; 2]> = pixels
            .iter()
            .map(|&[i, j]| plane.xy([i as f64 + 0.5, j as f64 + 0.5]))
            .collect();
        request.push(json!({ "proj": plane.proj, "inverse": xy }));
        pictures.push((p, imgs, pixels));
    }
    let Some(answers) = proj(dir.path(), &json!(request)) else {
        return;
    };
    for ((p, imgs, pixels), answer) in pictures.iter().zip(&answers) {
        let ours = Projector::new(p, &WORLD).unwrap();
        // No straight axes to tick.
        assert!(imgs[0].meta("map_x_extent").is_none(), "{:?}", p.kind);
        let (t, u) = (channel(&imgs[0], "t"), channel(&imgs[1], "u"));
        let width = imgs[0].width as usize;
        let (mut shown, mut outline) = (0, 0);
        for (&[i, j], theirs) in pixels.iter().zip(answer["inverse"].as_array().unwrap()) {
            let k = j * width + i;
            let on_map = pair(theirs).filter(|&[lon, lat]| {
                // PROJ unprojects some points beyond a map's outline; they project elsewhere.
                ours.forward(lon, lat).is_some_and(|xy| {
                    let back = Plane::of(&imgs[0]).pixel(xy);
                    (back[0] - i as f64 - 0.5).hypot(back[1] - j as f64 - 0.5) < 1e-3
                })
            });
            match on_map {
                Some([lon, lat]) if t[k].is_finite() => {
                    let at = format!("{:?} pixel ({i}, {j}) at ({lon}, {lat})", p.kind);
                    // The end rows cover half a spacing beyond their nodes (±89°).
                    let want = lat.clamp(-89.0, 89.0);
                    assert!((t[k] as f64 - want).abs() < 2e-3, "{at}: t = {}", t[k]);
                    if lon.abs() < 178.9 {
                        assert!((u[k] as f64 - lon).abs() < 2e-3, "{at}: u = {}", u[k]);
                    }
                    shown += 1;
                }
                None if !t[k].is_finite() => {}
                // Pixels astride the outline may differ (PROJ's and our edge tests).
                _ => outline += 1,
            }
        }
        assert!(shown > 1000, "{:?}: {shown} pixels shown", p.kind);
        assert!(
            outline * 200 < shown,
            "{:?}: {outline} pixels disagree on the map's outline of {shown}",
            p.kind
        );
    }
}

/// `img`'s extra channel `name`.
fn channel<'a>(img: &'a HdrImage, name: &str) -> &'a [f32] {
    &img.extra_channels
        .iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no channel {name}"))
        .1
}

#[test]
fn graticules_are_drawn_where_proj_places_them() {
    let dir = tempfile::tempdir().unwrap();
    let r = renderer();
    let grid = world();
    let mut request = Vec::new();
    let mut pictures = Vec::new();
    let crossings: Vec<[f64; 2]> = (-2..=2)
        .flat_map(|j| (-6..6).map(move |i| [30.0 * i as f64, 30.0 * j as f64]))
        .collect();
    let between: Vec<[f64; 2]> = crossings
        .iter()
        .map(|&[x, y]| [x + 15.0, y + 15.0])
        .collect();
    for p in projections() {
        let plain = render(&r, &grid, &p, None).remove(0);
        let lined = render(&r, &grid, &p, Some(30.0)).remove(0);
        request.push(json!({ "proj": Plane::of(&plain).proj, "forward": crossings }));
        request.push(json!({ "proj": Plane::of(&plain).proj, "forward": between }));
        pictures.push((p, plain, lined));
    }
    let Some(answers) = proj(dir.path(), &json!(request)) else {
        return;
    };
    for (k, (p, plain, lined)) in pictures.iter().enumerate() {
        let ours = Projector::new(p, &WORLD).unwrap();
        let plane = Plane::of(plain);
        let pixel_at = |[lon, lat]: [f64; 2], theirs: &Value| -> Option<usize> {
            ours.forward(lon, lat)?;
            let [x, y] = plane.pixel(pair(theirs)?);
            let (w, h) = (plain.width as f64, plain.height as f64);
            (x > 3.0 && y > 3.0 && x < w - 3.0 && y < h - 3.0)
                .then(|| y as usize * plain.width as usize + x as usize)
        };
        let (mut on, mut off) = (0, 0);
        for (pt, theirs) in crossings
            .iter()
            .zip(answers[2 * k]["forward"].as_array().unwrap())
        {
            if let Some(px) = pixel_at(*pt, theirs) {
                assert_ne!(plain.pixels[px], lined.pixels[px], "{:?} {pt:?}", p.kind);
                on += 1;
            }
        }
        for (pt, theirs) in between
            .iter()
            .zip(answers[2 * k + 1]["forward"].as_array().unwrap())
        {
            if let Some(px) = pixel_at(*pt, theirs) {
                assert_eq!(plain.pixels[px], lined.pixels[px], "{:?} {pt:?}", p.kind);
                off += 1;
            }
        }
        assert!(
            on >= 10 && off >= 10,
            "{:?}: {on} crossings, {off} cells",
            p.kind
        );
        assert!(lined.meta("graticule").is_some());
    }
}

/// The grids projection_cases.py writes and their latitudes, or `None` without Python.
fn uneven_grids(dir: &Path) -> Option<Value> {
    let report = python_check("projection_cases.py", &["write", dir.to_str().unwrap()])?;
    assert!(report.starts_with("exit 0\n"), "{report}");
    let body = report.split_once('\n').unwrap().1;
    Some(serde_json::from_str(body.trim()).unwrap_or_else(|e| panic!("{e}\n{report}")))
}

#[test]
fn gaussian_and_refined_latitudes_are_drawn_at_their_own_latitudes() {
    let dir = tempfile::tempdir().unwrap();
    let Some(lats) = uneven_grids(dir.path()) else {
        return;
    };
    let r = renderer();
    for name in ["gaussian", "ocean"] {
        let grid =
            hdrvis::datasets::load_grid(&dir.path().join(format!("{name}.nc")), None).unwrap();
        let nodes: Vec<f64> = lats[name]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(grid.y().values, nodes, "{name}: latitudes as written");
        let opts = SurfaceOptions {
            properties: vec!["t".into(), "u".into()],
            mode: FringeMode::Direct,
            coastlines: Some(Default::default()),
            ..Default::default()
        };
        let img = r.render(&grid, &opts).unwrap().remove(0);
        assert!(img.meta("coastlines").is_some(), "{name}");
        let extent: Vec<f64> = img
            .meta("map_y_extent")
            .unwrap()
            .split_whitespace()
            .map(|v| v.parse().unwrap())
            .collect();
        // The map spans the cells: the ocean grid's CF bounds (80°N is a whole spacing beyond
        // its last node), the Gaussian grid's half end spacings (it gives no bounds).
        let n = nodes.len();
        let edges = if name == "ocean" {
            [-80.0, 80.0]
        } else {
            [
                nodes[0] - 0.5 * (nodes[1] - nodes[0]),
                nodes[n - 1] + 0.5 * (nodes[n - 1] - nodes[n - 2]),
            ]
        };
        assert_eq!(extent, edges, "{name}");
        let t = channel(&img, "t");
        let (w, h) = (img.width as usize, img.height as usize);
        // The finest spacing gets at least a pixel.
        let finest = nodes
            .windows(2)
            .map(|p| p[1] - p[0])
            .fold(f64::INFINITY, f64::min);
        assert!(
            (extent[1] - extent[0]) / h as f64 <= finest * 1.01,
            "{name}: {h} rows"
        );
        for j in 0..h {
            let lat = extent[1] - (j as f64 + 0.5) * (extent[1] - extent[0]) / h as f64;
            // The spacing of the cell the pixel's latitude lies in.
            let k = nodes
                .partition_point(|&y| y <= lat)
                .clamp(1, nodes.len() - 1);
            let cell = nodes[k] - nodes[k - 1];
            let inside = lat >= nodes[0] && lat <= nodes[nodes.len() - 1];
            for i in [0, w / 3, w - 1] {
                let v = t[j * w + i] as f64;
                let want = lat.clamp(nodes[0], nodes[nodes.len() - 1]);
                assert!(
                    (v - want).abs() <= 0.1 * cell,
                    "{name}: row {j} at {lat}° (inside: {inside}) shows {v}"
                );
            }
        }
        // A perspective view draws the grid sampled onto even axes, made once: a second view
        // at another ν runs no data pass.
        let orbit = SurfaceOptions {
            view: SurfaceView::Orbit {
                azimuth: -60.0,
                elevation: 35.0,
                fov: 40.0,
            },
            width: Some(48),
            height: Some(48),
            ..Default::default()
        };
        let before = r.counters().data_passes;
        r.render(&grid, &orbit).unwrap();
        let again = SurfaceOptions {
            nu: vec![3.0],
            ..orbit.clone()
        };
        r.render(&grid, &again).unwrap();
        assert_eq!(r.counters().data_passes, before + 1, "{name}");
        // The globe places them too, centred on the grid's middle.
        let globe = SurfaceOptions {
            properties: vec!["t".into(), "u".into()],
            mode: FringeMode::Direct,
            view: SurfaceView::Globe(
                hdrvis::model::Camera::geo([0.0; 3], 0.0, 10.0, 3.0, 30.0).unwrap(),
            ),
            width: Some(64),
            height: Some(64),
            ..Default::default()
        };
        let img = r.render(&grid, &globe).unwrap();
        // The pixel right of the centre looks at a hair north of the equator, at 10°E.
        let (t, u) = (channel(&img[0], "t"), channel(&img[1], "u"));
        assert!(
            t[32 * 64 + 32].abs() < 1.0,
            "{name}: {} at the centre",
            t[32 * 64 + 32]
        );
        assert!(
            (u[32 * 64 + 32] - 10.0).abs() < 1.0,
            "{name}: {}",
            u[32 * 64 + 32]
        );
    }
}

/// From a script: a framed Robinson map with coastlines and a colour bar, a Lambert map with
/// its parallels given, and a mesh in Mollweide; then what a projection cannot be asked for,
/// each refused in one line naming the option, with nothing written.
#[test]
fn scripts_draw_projected_maps_and_refuse_bad_projections_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    if uneven_grids(dir.path()).is_none() {
        return;
    }
    let script = r#"
        let g = load_grid("ocean.nc", #{ variable: "t" });
        let robin = render_surface(g, #{ mode: "direct", projection: "robinson", coastlines: true, width: 400 });
        save_png(robin, "robin.png", #{ frame: true, title: "Latitude" });
        let lcc = render_surface(g, #{ mode: "direct", projection: #{ name: "lambert", lon_0: 10.0, lat_1: 30.0, lat_2: 60.0 }, graticule: 10.0, width: 300 });
        print(lcc.meta("map_projection"));
        save_png(lcc, "lcc.png");
    "#;
    std::fs::write(dir.path().join("p.rhai"), script).unwrap();
    let (code, out, err) = crate::cli::hdrvis(&["run", "p.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        // lat_0 defaults to the middle of the cells' extent (80°S to 80°N by the file's bounds).
        out.contains("+proj=lcc +lat_0=0 +lat_1=30 +lat_2=60 +lon_0=10"),
        "{out}"
    );
    use image::GenericImageView;
    let framed = image::open(dir.path().join("o/robin.png")).unwrap();
    assert!(
        framed.width() > 400 && framed.height() > 200,
        "{:?}",
        framed.dimensions()
    );
    assert_eq!(
        image::open(dir.path().join("o/lcc.png")).unwrap().width(),
        300
    );
    let g = "load_grid(\"ocean.nc\", #{ variable: \"t\" })";
    let cases = [
        (
            "projection: \"mercator\"",
            "projection: expected one of equirectangular, robinson",
        ),
        (
            "projection: \"robinson\", view: \"perspective\"",
            "projection: a projection applies to the map view",
        ),
        (
            "projection: #{ name: \"lambert\", lat_1: -30.0, lat_2: 30.0 }",
            "must lie on one side of the equator",
        ),
        (
            "projection: #{ name: \"orthographic\", lat_0: 95.0 }",
            "lat_0 = 95: expected a latitude in [-90, 90]",
        ),
        ("projection: #{ lon_0: 10.0 }", "a map needs a name"),
        (
            "projection: #{ name: \"robinson\", centre: 10.0 }",
            "unknown key \"centre\"",
        ),
    ];
    crate::cli::surface_options_refused(dir.path(), g, &cases);
    // A grid whose axes are not longitude and latitude has nothing to project.
    let plain = Grid::from_fn("plain", 8, 8, |i, j| (i + j) as f64).unwrap();
    let opts = SurfaceOptions {
        projection: Some(MapProjection::new(ProjectionKind::Robinson)),
        ..Default::default()
    };
    let e = renderer().render(&plain, &opts).unwrap_err().to_string();
    assert!(
        e.contains("projection: a projection places longitudes and latitudes"),
        "{e}"
    );
}
