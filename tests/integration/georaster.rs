//! Georeferenced rasters against what the reference tools make of the same files
//! (tests/python/write_georaster.py): GeoTIFFs written and read by rasterio (GDAL) and MintPy
//! products written by h5py in MintPy's layout. Grids come out north up, their nodes at the
//! pixel centres rasterio's xy() gives, their values those rasterio and numpy read.

use crate::cli::hdrvis;
use crate::common::{python_reference, reference_numbers as numbers};
use hdrvis::datasets::select::{At, Selection};
use hdrvis::datasets::LoadOptions;
use hdrvis::model::{CoordKind, Grid};
use std::collections::HashMap;
use std::path::Path;

/// The files of `case` written into `dir` and the reference values, by key (write_georaster.py);
/// `None` when the Python modules are missing.
fn reference(dir: &Path, case: &str) -> Option<HashMap<String, Vec<String>>> {
    python_reference("write_georaster.py", dir, case)
}

/// Exactly equal values (NaN where the reference is masked).
fn assert_same(got: &[f64], want: &[f64], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: lengths");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (w.is_nan() && g.is_nan()) || g == w,
            "{what}[{i}]: {g}, expected {w}"
        );
    }
}

/// Checks a grid against a raster as the reference read it in storage order (`values` row-major,
/// `lon` per column, `lat` per row): the grid's latitudes increase (north at the top of a map),
/// its nodes are the pixel centres within 1e-9 degrees, and node (i, j) holds the pixel at
/// that longitude and latitude.
fn assert_north_up(grid: &Grid, values: &[f64], lon: &[f64], lat: &[f64], what: &str) {
    let (nx, ny) = (lon.len(), lat.len());
    assert_eq!((grid.nx(), grid.ny()), (nx, ny), "{what}: size");
    assert!(grid.is_geographic(), "{what}: not geographic");
    assert!(!grid.y_down(), "{what}: y drawn downward");
    let gy = &grid.y().values;
    assert!(
        gy.windows(2).all(|w| w[1] > w[0]),
        "{what}: latitudes {gy:?}"
    );
    for (g, w) in grid.x().values.iter().zip(lon) {
        assert!((g - w).abs() < 1e-9, "{what}: lon {g}, expected {w}");
    }
    let stored_north_first = lat[0] > lat[ny - 1];
    let row_of = |j: usize| if stored_north_first { ny - 1 - j } else { j };
    for j in 0..ny {
        assert!((gy[j] - lat[row_of(j)]).abs() < 1e-9, "{what}: lat {j}");
    }
    let (_, got) = grid.property_at(0);
    let want: Vec<f64> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| values[row_of(j) * nx + i]))
        .collect();
    assert_same(got, &want, what);
}

fn load(path: &Path, opts: &LoadOptions) -> hdrvis::Result<Grid> {
    hdrvis::datasets::load_grid_with(path, opts)
}

fn one_line_error(result: hdrvis::Result<Grid>, wanted: &[&str]) {
    let e = result.expect_err("an error").to_string();
    assert!(!e.contains('\n'), "{e}");
    for w in wanted {
        assert!(e.contains(w), "expected '{w}' in: {e}");
    }
}

#[test]
fn geotiffs_load_north_up_at_rasterios_pixel_centres() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "geotiff") else {
        return;
    };
    // North up with nodata, south up (positive y pixel size), PixelIsPoint, band 2 of
    // pixel-interleaved bands and band 3 of band-interleaved ones.
    for (case, file, band) in [
        ("north", "north.tif", None),
        ("south", "south.tif", None),
        ("point", "point.tif", None),
        ("bands2", "bands.tif", Some(2)),
        ("planar3", "planar.tif", Some(3)),
        ("packed", "packed.tif", None),
    ] {
        let opts = LoadOptions {
            band,
            ..LoadOptions::default()
        };
        let grid = load(&dir.path().join(file), &opts).unwrap_or_else(|e| panic!("{case}: {e}"));
        let key = |k: &str| numbers(&r, &format!("{case}.{k}"));
        assert_north_up(&grid, &key("values"), &key("lon"), &key("lat"), case);
        let missing = grid.property_at(0).1.iter().filter(|v| v.is_nan()).count();
        assert_eq!(missing as f64, key("masked")[0], "{case}: masked");
    }
    // The nodata value is what rasterio masks; info counts it as fill.
    assert_eq!(numbers(&r, "north.masked")[0], 2.0);
    let path = dir.path().join("north.tif");
    let (code, out, err) = hdrvis(&["info", path.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    for line in [
        "missing: 2 NaN (of which 2 fill values)",
        "CRS: EPSG:4326 (WGS 84)",
        "nodata (GDAL_NODATA): -9999",
        "rows run north to south (drawn north up)",
    ] {
        assert!(out.contains(line), "{line}\n{out}");
    }
    let point = dir.path().join("point.tif");
    let (code, out, err) = hdrvis(&["info", point.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("PixelIsPoint"), "{out}");
    let bands = dir.path().join("bands.tif");
    let (code, out, err) = hdrvis(
        &["info", bands.to_str().unwrap(), "--band", "2"],
        dir.path(),
    );
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("variable: bands band 2"), "{out}");
    // GDAL's scale, offset and unit (GDAL_METADATA): the values above are stored x 0.01 - 5 as
    // rasterio computes them, nodata matched in stored units, the unit reaches the grid.
    assert_eq!(numbers(&r, "packed.scale"), vec![0.01, -5.0]);
    let packed = dir.path().join("packed.tif");
    let grid = load(&packed, &LoadOptions::default()).unwrap();
    assert_eq!(grid.units(0), r["packed.units"][0]);
    let (code, out, err) = hdrvis(&["info", packed.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("values = stored x 0.01 + -5 (GDAL scale and offset, GDAL_METADATA)"),
        "{out}"
    );
}

#[test]
fn bad_geotiffs_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    if reference(dir.path(), "geotiff").is_none() {
        return;
    }
    let at = |f: &str| dir.path().join(f);
    let plain = LoadOptions::default();
    one_line_error(
        load(&at("utm.tif"), &plain),
        &["utm.tif", "projected CRS EPSG:32654", "EPSG:4326"],
    );
    one_line_error(
        load(&at("rotated.tif"), &plain),
        &["rotated.tif", "rotates"],
    );
    one_line_error(load(&at("plain.tif"), &plain), &["plain.tif", "EPSG:4326"]);
    one_line_error(
        load(&at("truncated.tif"), &plain),
        &["truncated.tif", "TIFF"],
    );
    one_line_error(
        load(&at("bands.tif"), &plain),
        &["bands.tif", "has 3 bands", "band: N"],
    );
    let band4 = LoadOptions {
        band: Some(4),
        ..LoadOptions::default()
    };
    one_line_error(
        load(&at("bands.tif"), &band4),
        &["band 4 is out of range", "1 to 3"],
    );
    let variable = LoadOptions {
        variable: Some("elevation".into()),
        ..LoadOptions::default()
    };
    one_line_error(
        load(&at("north.tif"), &variable),
        &["no variables", "'elevation'"],
    );
    // A GeoTIFF is no volume; through the CLI the error is one line and the exit non-zero.
    let e = hdrvis::datasets::load_volume(&at("north.tif"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("load_grid"), "{e}");
    let (code, out, err) = hdrvis(&["info", at("utm.tif").to_str().unwrap()], dir.path());
    assert_ne!(code, 0, "{out}");
    assert!(
        err.contains("EPSG:32654") && err.trim().lines().count() == 1,
        "{err}"
    );
}

fn time_opts(index: Option<i64>, at: Option<&str>) -> LoadOptions {
    LoadOptions {
        select: Selection {
            index: index.map(|i| ("time".to_string(), i)).into_iter().collect(),
            at: at
                .map(|d| ("time".to_string(), At::Date(d.into())))
                .into_iter()
                .collect(),
        },
        ..LoadOptions::default()
    }
}

#[test]
fn mintpy_products_load_north_up_with_their_units_and_dates() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "mintpy") else {
        return;
    };
    let (lon, lat) = (numbers(&r, "velocity.lon"), numbers(&r, "velocity.lat"));
    let velocity = dir.path().join("velocity.h5");
    let grid = load(&velocity, &LoadOptions::default()).unwrap();
    assert_north_up(
        &grid,
        &numbers(&r, "velocity.values"),
        &lon,
        &lat,
        "velocity",
    );
    assert_eq!(grid.units(0), "m/year");
    let (code, out, err) = hdrvis(&["info", velocity.to_str().unwrap()], dir.path());
    assert_eq!(code, 0, "{err}");
    for line in [
        "units: m/year",
        "MintPy product: FILE_TYPE velocity",
        "WAVELENGTH: 0.05546576 m",
        "λ/2 = 0.02773288 m",
        "reference point: REF_LAT 33.1875, REF_LON 130.525",
        "drawn north up",
    ] {
        assert!(out.contains(line), "{line}\n{out}");
    }

    // A time series: index and at equal numpy's slices, north up; times() lists the dates.
    let ts = dir.path().join("timeseries.h5");
    let dates: Vec<String> = r["timeseries.dates"]
        .iter()
        .map(|d| format!("{}-{}-{}T00:00:00", &d[..4], &d[4..6], &d[6..]))
        .collect();
    assert_eq!(hdrvis::datasets::time_steps(&ts, None).unwrap(), dates);
    let g = load(&ts, &time_opts(Some(3), None)).unwrap();
    assert_north_up(&g, &numbers(&r, "timeseries.index3"), &lon, &lat, "index 3");
    assert!(
        g.name().contains("time index 3 (2020-02-06T00:00:00)"),
        "{}",
        g.name()
    );
    let g = load(&ts, &time_opts(None, Some("2020-01-15"))).unwrap();
    assert_north_up(
        &g,
        &numbers(&r, "timeseries.at"),
        &lon,
        &lat,
        "at 2020-01-15",
    );
    let near = numbers(&r, "timeseries.near")[0] as usize;
    assert!(
        g.name().contains(&format!("(index {near})")),
        "{}",
        g.name()
    );
    assert_eq!(g.units(0), "m");

    // One colour range over the series' dates: numpy's extremes, and its 2nd/98th percentiles
    // over dates 1 and 3.
    use hdrvis::datasets::series::{series_range, SeriesOptions};
    let series = dir.path().join("timeseries.h5");
    let all = series_range(&series, &SeriesOptions::default()).unwrap();
    assert_eq!(all.to_vec(), numbers(&r, "timeseries.range"));
    let robust = SeriesOptions {
        steps: Some(vec![1, 3]),
        robust: true,
        ..SeriesOptions::default()
    };
    let got = series_range(&series, &robust).unwrap();
    let want = numbers(&r, "timeseries.robust13");
    for k in 0..2 {
        assert!(
            (got[k] - want[k]).abs() <= 1e-12 * want[k].abs(),
            "{got:?} vs {want:?}"
        );
    }
    let e = series_range(
        &series,
        &SeriesOptions {
            steps: Some(vec![5]),
            ..SeriesOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("step 5 is out of range; expected 0..=4"), "{e}");

    // Radar coordinates keep storage order: row 0 is the grid's first (bottom) row.
    let radar = load(&dir.path().join("radar.h5"), &LoadOptions::default()).unwrap();
    assert_eq!(radar.x().kind, CoordKind::Plain);
    assert_same(
        radar.property_at(0).1,
        &numbers(&r, "radar.values"),
        "radar",
    );
}

#[test]
fn mintpy_time_series_selections_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    if reference(dir.path(), "mintpy").is_none() {
        return;
    }
    let ts = dir.path().join("timeseries.h5");
    one_line_error(
        load(&ts, &LoadOptions::default()),
        &["variable 'timeseries': dimension 'time' is time (5 steps, 2020-01-01T00:00:00 to 2020-02-18T00:00:00", "index: #{ time: 0 }"],
    );
    one_line_error(
        load(&ts, &time_opts(Some(5), None)),
        &[
            "dimension 'time'",
            "index 5 is out of range; expected 0..=4",
        ],
    );
    one_line_error(
        load(&ts, &time_opts(None, Some("2021-06-01"))),
        &["dimension 'time'", "outside the axis"],
    );
    one_line_error(
        load(&ts, &time_opts(None, Some("13/01/2020"))),
        &["not an ISO 8601 date"],
    );
    let depth = LoadOptions {
        select: Selection {
            index: vec![("depth".into(), 0)],
            at: Vec::new(),
        },
        ..LoadOptions::default()
    };
    one_line_error(load(&ts, &depth), &["no dimension 'depth'", "time, y, x"]);
    // Incomplete geocoding and a truncated file.
    let partial = dir.path().join("partial.h5");
    one_line_error(
        load(&partial, &LoadOptions::default()),
        &[
            "partial.h5",
            "MintPy geocoding is incomplete: Y_FIRST, Y_STEP missing",
        ],
    );
    let truncated = dir.path().join("truncated.h5");
    one_line_error(load(&truncated, &LoadOptions::default()), &["truncated.h5"]);
    // Not a volume: time is never a vertical axis.
    let e = hdrvis::datasets::load_volume(&ts).unwrap_err().to_string();
    assert!(e.contains("MintPy") && e.contains("load_grid"), "{e}");
}

#[test]
fn scripts_choose_bands_and_dates() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = reference(dir.path(), "mintpy") else {
        return;
    };
    if reference(dir.path(), "geotiff").is_none() {
        return;
    }
    let script = r#"
        let steps = times("timeseries.h5");
        if steps.len() != 5 || steps[1].date != "2020-01-13T00:00:00" { throw `times: ${steps}`; }
        let g = load_grid("timeseries.h5", #{ at: #{ time: steps[3].date } });
        let b = load_grid("bands.tif", #{ band: 2 });
        print(`${g.name} | ${b.name}`);
    "#;
    std::fs::write(dir.path().join("t.rhai"), script).unwrap();
    let (code, out, err) = hdrvis(&["run", "t.rhai", "--out", "out"], dir.path());
    assert_eq!(code, 0, "{out}\n{err}");
    let text = format!("{out}{err}");
    assert!(
        text.contains("time 2020-02-06T00:00:00 (index 3)"),
        "{text}"
    );
    assert_eq!(r["timeseries.dates"][3], "20200206");
    let script = r#"load_grid("bands.tif", #{ band: 0 });"#;
    std::fs::write(dir.path().join("bad.rhai"), script).unwrap();
    let (code, _, err) = hdrvis(&["run", "bad.rhai", "--out", "out"], dir.path());
    assert_ne!(code, 0);
    assert!(err.contains("band"), "{err}");
}

#[test]
fn mintpy_wavelength_reaches_grids_scripts_and_the_fringe_legend() {
    use hdrvis::render::surface::{legend, FringeMode, SurfaceOptions};
    let dir = tempfile::tempdir().unwrap();
    if reference(dir.path(), "mintpy").is_none() {
        return;
    }
    let ts = dir.path().join("timeseries.h5");
    let g = load(&ts, &time_opts(Some(2), None)).unwrap();
    let w = 0.05546576;
    assert_eq!(g.wavelength(), Some(w));
    // One fringe per half wavelength of line-of-sight displacement (m): the legend says so.
    let at = |nu: f64| {
        let o = SurfaceOptions {
            nu: vec![nu],
            mode: FringeMode::Cyclic,
            ..Default::default()
        };
        legend(&g, &o, 400).unwrap()
    };
    let half = at(2.0 / w);
    assert_eq!(half.meta("legend"), Some("1 fringe = 0.02773 m = λ/2"));
    assert_eq!(at(100.0).meta("legend"), Some("1 fringe = 0.01 m"));
    // Scripts see it as grid.wavelength (a product in radar coordinates has one too).
    let script = r#"
        let g = load_grid("timeseries.h5", #{ index: #{ time: 0 } });
        if g.wavelength != 0.05546576 { throw `wavelength ${g.wavelength}`; }
        let v = load_grid("radar.h5");
        if type_of(v.wavelength) != "f64" { throw "radar wavelength"; }
    "#;
    std::fs::write(dir.path().join("w.rhai"), script).unwrap();
    let (code, out, err) = hdrvis(&["run", "w.rhai", "--out", "out"], dir.path());
    assert_eq!(code, 0, "{out}\n{err}");
}
