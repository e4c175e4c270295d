//! Unit tests of NetCDF reading and writing: CF decoding, seams, windows, errors.

use super::*;

#[test]
fn numeric_order_across_the_seam_rolls_and_nothing_else_does() {
    let across = [-177.5, -172.5, -167.5, 162.5, 167.5, 172.5, 177.5];
    assert_eq!(seam_roll(&across), Some(3));
    // Across Greenwich in 0 .. 360: 0.5 .. 10.5, 350.5 .. 359.5.
    let greenwich: Vec<f64> = (0..11)
        .map(|i| 0.5 + f64::from(i))
        .chain((0..10).map(|i| 350.5 + f64::from(i)))
        .collect();
    assert_eq!(seam_roll(&greenwich), Some(11));
    // A global axis, a regional one, a global one missing a column, storage-order wraps,
    // decreasing axes, a hole that does not close round the circle: left as stored.
    let global: Vec<f64> = (0..36).map(|i| 5.0 + 10.0 * f64::from(i)).collect();
    let mut missing = global.clone();
    missing.remove(7);
    for values in [
        global.as_slice(),
        &[10.0, 12.0, 14.0, 16.0],
        &missing,
        &[350.0, 355.0, 0.0, 5.0],
        &[177.5, 172.5, -172.5, -177.5],
        &[0.0, 1.0, 2.0, 100.0, 101.0, 102.0],
    ] {
        assert_eq!(seam_roll(values), None, "{values:?}");
    }
    // Rolling an axis of a C-ordered (2, 3, 2) array, and cutting rows of it.
    let data: Vec<f64> = (0..12).map(f64::from).collect();
    assert_eq!(
        roll_axis(&data, &[2, 3, 2], 1, 2),
        [4.0, 5.0, 0.0, 1.0, 2.0, 3.0, 10.0, 11.0, 6.0, 7.0, 8.0, 9.0]
    );
    assert_eq!(
        take_rows(&data, &[2, 3, 2], 1, 1..3),
        [2.0, 3.0, 4.0, 5.0, 8.0, 9.0, 10.0, 11.0]
    );
}
use std::path::PathBuf;

fn read_coordinate(path: impl AsRef<Path>, dim: &str) -> Result<Option<Vec<f64>>> {
    Ok(crate::datasets::cf::read_coordinate(path.as_ref(), dim)?.map(|v| v.data))
}

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("datasets/fixtures")
        .join(name)
}

// The formulas below are the ones datasets/fixtures/make_fixtures.py wrote.
const LAT: [f64; 5] = [-60.0, -30.0, 0.0, 30.0, 60.0];
fn sst_truth(lat: f64, lon: f64) -> f64 {
    15.0 + 10.0 * lat.to_radians().cos() + 2.0 * (2.0 * lon.to_radians()).sin()
}
fn sst_is_land(i: usize, j: usize) -> bool {
    (i * 8 + j) % 7 == 3
}

#[test]
fn netcdf4_fixture_is_unpacked_and_masked() {
    let path = fixture("sst_packed_nc4.nc");
    let listed = list_variables(&path).unwrap();
    let names: Vec<&str> = listed.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["lat", "lon", "sst"]);
    let sst = read_variable(&path, "sst").unwrap();
    assert_eq!(sst.dims, [("lat".to_string(), 5), ("lon".to_string(), 8)]);
    assert_eq!(sst.units.as_deref(), Some("degC"));
    assert_eq!(sst.long_name.as_deref(), Some("sea surface temperature"));
    assert_eq!(
        sst.attribute("_FillValue"),
        Some(&NcAttribute::Numbers(vec![-32767.0]))
    );
    let lat = read_coordinate(&path, "lat").unwrap().unwrap();
    let lon = read_coordinate(&path, "lon").unwrap().unwrap();
    assert_eq!(lat, LAT);
    assert_eq!(lon, (0..8).map(|j| 45.0 * j as f64).collect::<Vec<_>>());
    let (mut masked, mut checked) = (0, 0);
    for (i, &lat_i) in lat.iter().enumerate() {
        for (j, &lon_j) in lon.iter().enumerate() {
            let got = sst.data[i * 8 + j];
            if sst_is_land(i, j) {
                assert!(got.is_nan(), "({i},{j}) should be fill, got {got}");
                masked += 1;
            } else {
                // Packing rounds to the nearest 0.01 (scale_factor); unpacking in f64 from
                // the f32 attributes adds at most ~1e-6 more.
                let want = sst_truth(lat_i, lon_j);
                assert!(
                    (got - want).abs() <= 0.005 + 1e-5,
                    "({i},{j}): {got} vs {want}"
                );
                checked += 1;
            }
        }
    }
    assert_eq!((masked, checked), (6, 34));
}

#[test]
fn classic_fixture_reads_missing_value_as_nan() {
    let path = fixture("volume_classic.nc");
    let t = read_variable(&path, "temperature").unwrap();
    let dims: Vec<usize> = t.dims.iter().map(|d| d.1).collect();
    assert_eq!(dims, [2, 3, 4]);
    assert_eq!(t.units.as_deref(), Some("K"));
    for k in 0..2 {
        for j in 0..3 {
            for i in 0..4 {
                let got = t.data[(k * 3 + j) * 4 + i];
                if (k, j, i) == (1, 2, 3) {
                    assert!(got.is_nan());
                } else {
                    assert_eq!(got, (1000 + 100 * k + 10 * j + i) as f64);
                }
            }
        }
    }
    assert_eq!(
        read_coordinate(&path, "x").unwrap().unwrap(),
        [0.5, 1.5, 2.5, 3.5]
    );
}

#[test]
fn missing_variable_error_lists_the_available_ones() {
    let err = read_variable(fixture("sst_packed_nc4.nc"), "chlorophyll").unwrap_err();
    let text = err.to_string();
    assert!(text.contains("sst_packed_nc4.nc"), "{text}");
    assert!(
        text.contains("no variable 'chlorophyll'; the file has: lat, lon, sst"),
        "{text}"
    );
    assert!(!text.contains('\n'));
}

#[test]
fn non_monotonic_coordinate_is_a_format_error() {
    let err = read_coordinate(fixture("nonmonotonic_coord.nc"), "x").unwrap_err();
    assert!(matches!(err, Error::Format { .. }), "{err}");
    assert!(err.to_string().contains("not strictly monotonic"), "{err}");
    assert!(read_coordinate(fixture("volume_classic.nc"), "nope").is_err());
}

#[test]
fn truncated_files_give_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    for (name, var) in [
        ("volume_classic.nc", "temperature"),
        ("sst_packed_nc4.nc", "sst"),
    ] {
        let bytes = std::fs::read(fixture(name)).unwrap();
        let cut_path = dir.path().join(name);
        // Every cut of the small classic file; a spread of cuts of the HDF5 one.
        let step = if bytes.len() < 2000 { 1 } else { 61 };
        for len in (0..bytes.len()).step_by(step) {
            std::fs::write(&cut_path, &bytes[..len]).unwrap();
            let Err(err) = read_variable(&cut_path, var) else {
                panic!("{name} cut to {len} bytes was read without error");
            };
            let text = err.to_string();
            assert!(text.contains(name) && !text.contains('\n'), "{text}");
        }
    }
}

#[test]
fn write_grid_round_trips_with_nan_and_attributes() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grid.nc");
    let lat = [10.0, 20.0, 30.0];
    let lon = [100.0, 110.0];
    let data = [1.5, f64::NAN, -2.25, 1e30, 0.0, 7.0];
    write_grid(
        &path,
        &[
            ("lat", &lat, "degrees_north"),
            ("lon", &lon, "degrees_east"),
        ],
        &[("elevation", &data, "m", "surface elevation")],
        &[("title", "round trip")],
    )
    .unwrap();
    let v = read_variable(&path, "elevation").unwrap();
    assert_eq!(v.dims, [("lat".to_string(), 3), ("lon".to_string(), 2)]);
    assert_eq!(v.units.as_deref(), Some("m"));
    assert_eq!(v.long_name.as_deref(), Some("surface elevation"));
    for (got, want) in v.data.iter().zip(data) {
        assert!(
            got == &want || (got.is_nan() && want.is_nan()),
            "{got} vs {want}"
        );
    }
    assert_eq!(read_coordinate(&path, "lon").unwrap().unwrap(), lon);
    // Only the final file is left in the directory: the temporary one was renamed.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn write_volume_puts_coordinates_at_cell_centres() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("vol.nc");
    let data: Vec<f32> = (0..24).map(|v| v as f32 * 0.5).collect();
    write_volume(
        &path,
        [4, 3, 2],
        [1.0, 2.0, 0.5],
        [0.0, -3.0, 10.0],
        "km",
        ("rho", &data, "kg m-3", "density"),
        &[],
    )
    .unwrap();
    let v = read_variable(&path, "rho").unwrap();
    let names: Vec<&str> = v.dims.iter().map(|d| d.0.as_str()).collect();
    assert_eq!(names, ["z", "y", "x"]);
    assert_eq!(v.data, data.iter().map(|&x| x as f64).collect::<Vec<_>>());
    assert_eq!(
        read_coordinate(&path, "x").unwrap().unwrap(),
        [0.5, 1.5, 2.5, 3.5]
    );
    assert_eq!(
        read_coordinate(&path, "y").unwrap().unwrap(),
        [-2.0, 0.0, 2.0]
    );
    assert_eq!(
        read_coordinate(&path, "z").unwrap().unwrap(),
        [10.25, 10.75]
    );
}

#[test]
fn bad_writes_are_rejected_and_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.nc");
    let x = [0.0, 2.0, 1.0];
    let err = write_grid(
        &path,
        &[("x", &x, "m")],
        &[("v", &[1.0f32, 2.0, 3.0][..], "", "")],
        &[],
    )
    .unwrap_err();
    assert!(
        err.to_string()
            .starts_with("coords.x: coordinate is not strictly monotonic"),
        "{err}"
    );
    let x = [0.0, 1.0];
    let err = write_grid(
        &path,
        &[("x", &x, "m")],
        &[("v", &[1.0f32][..], "", "")],
        &[],
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "vars.v: has 1 values; the coordinates need 2"
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
