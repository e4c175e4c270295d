//! Coastlines and graticules from scripts: the lines drawn where the embedded Natural Earth
//! coast is (Cape of Good Hope) and nowhere near the Sahara or the mid-Atlantic, on a map and on
//! the globe, and bad options refused with nothing written.

use hdrvis::io::exr::read_exr;

/// A world grid of 1° cells, d = 0 everywhere (one colour in direct mode).
fn write_world(dir: &std::path::Path) {
    let lon: Vec<f64> = (0..360).map(|i| -179.5 + i as f64).collect();
    let lat: Vec<f64> = (0..180).map(|j| -89.5 + j as f64).collect();
    let d = vec![0.0; 360 * 180];
    hdrvis::datasets::netcdf::write_grid::<f64>(
        dir.join("world.nc"),
        &[
            ("lat", &lat, "degrees_north"),
            ("lon", &lon, "degrees_east"),
        ],
        &[("d", &d, "m", "zero")],
        &[],
    )
    .unwrap();
}

/// Pixels where `a` and `b` differ, as pixel centres (x right, y down).
fn differing(a: &hdrvis::model::HdrImage, b: &hdrvis::model::HdrImage) -> Vec<[f64; 2]> {
    let w = a.width as usize;
    (0..a.pixels.len())
        .filter(|&k| a.pixels[k] != b.pixels[k])
        .map(|k| [(k % w) as f64 + 0.5, (k / w) as f64 + 0.5])
        .collect()
}

fn near(pixels: &[[f64; 2]], x: f64, y: f64, r: f64) -> bool {
    pixels.iter().any(|p| (p[0] - x).hypot(p[1] - y) <= r)
}

#[test]
fn script_draws_coastlines_on_maps_and_globes() {
    let dir = tempfile::tempdir().unwrap();
    write_world(dir.path());
    let script = r#"
        let g = load_grid("world.nc");
        let o = #{ mode: "direct", domain: [-1.0, 1.0] };
        save_exr(render_surface(g, o + #{ width: 360 }), "plain.exr");
        save_exr(render_surface(g, o + #{ width: 360, coastlines: #{ colour: "white" }, graticule: 30 }), "coast.exr");
        let globe = o + #{ view: "globe", width: 128, height: 128 };
        save_exr(render_surface(g, globe), "globe.exr");
        save_exr(render_surface(g, globe + #{ coastlines: true }), "globe_coast.exr");
    "#;
    std::fs::write(dir.path().join("s.rhai"), script).unwrap();
    let (code, out, err) = crate::cli::hdrvis(&["run", "s.rhai"], dir.path());
    assert_eq!(code, 0, "{out}\n{err}");
    let read = |name: &str| read_exr(&dir.path().join("out").join(name)).unwrap();
    let (plain, coast) = (read("plain.exr"), read("coast.exr"));
    assert_eq!((coast.width, coast.height), (360, 180));
    assert!(coast.meta("coastlines").unwrap().contains("110m"));
    assert_eq!(coast.meta("graticule"), Some("every 30 degrees"));
    // One pixel per degree: lon → lon + 180, lat → 90 − lat.
    let lines = differing(&plain, &coast);
    assert!(near(&lines, 198.47, 124.36, 1.5), "Cape of Good Hope");
    assert!(!near(&lines, 200.0, 67.0, 5.0), "Sahara");
    // The mid-Atlantic point lies on the graticule's equator and 30°W meridian: only those
    // lines pass within 5 pixels, in their grey.
    for p in lines
        .iter()
        .filter(|p| (p[0] - 150.0).hypot(p[1] - 90.0) <= 5.0)
    {
        let on_grid = (p[0] - 150.0).abs() <= 1.0 || (p[1] - 90.0).abs() <= 1.0;
        assert!(on_grid, "mid-Atlantic line pixel at {p:?}");
    }
    // The globe above 0°N 0°E: Africa's coast in view; the image's corners, off the sphere,
    // untouched.
    let (globe, globe_coast) = (read("globe.exr"), read("globe_coast.exr"));
    let lines = differing(&globe, &globe_coast);
    assert!(lines.len() > 200, "{}", lines.len());
    assert_eq!(globe.pixels[0], globe_coast.pixels[0]);
}

#[test]
fn bad_coastline_and_graticule_options_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_world(dir.path());
    for (opts, needs) in [
        (r#"coastlines: #{ colour: "mauve" }"#, "coastlines.colour"),
        ("coastlines: #{ width: 0 }", "coastlines.width"),
        ("coastlines: #{ width: -2.0 }", "coastlines.width"),
        (
            r#"coastlines: #{ resolution: "10m" }"#,
            "coastlines.resolution",
        ),
        (r#"coastlines: #{ colur: "red" }"#, "colur"),
        (r#"coastlines: "yes""#, "coastlines"),
        ("graticule: 0", "graticule"),
        ("graticule: -5.0", "graticule"),
        (r#"coastlines: true, view: "perspective""#, "coastlines"),
    ] {
        let bad = format!(
            "save_exr(render_surface(load_grid(\"world.nc\"), #{{ {opts} }}), \"bad.exr\");"
        );
        std::fs::write(dir.path().join("bad.rhai"), &bad).unwrap();
        let (code, _, err) = crate::cli::hdrvis(&["run", "bad.rhai"], dir.path());
        assert_ne!(code, 0, "{bad}");
        assert!(err.contains(needs), "{bad}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!dir.path().join("out/bad.exr").exists());
    }
}
