//! Valid files other tools write that the readers must take: HDF5 LZ4 chunks of several blocks
//! (h5py with hdf5plugin), each checked value for value against what the writing tool reads back
//! (tests/python/write_reader_cases.py).

use crate::cli::hdrvis;
use crate::common::{max_rel, python_reference, reference_numbers};
use hdrvis::datasets::load_volume_var;
use hdrvis::io::exr::read_exr;

/// LZ4 chunks cut into blocks smaller than the chunk (compressed blocks, raw blocks, a short last
/// block) and one block per chunk all read as h5py reads them.
#[test]
fn hdf5_lz4_blocks_smaller_than_the_chunk_read_like_h5py() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = python_reference("write_reader_cases.py", dir.path(), "hdf5_lz4") else {
        return;
    };
    let file = dir.path().join("lz4.h5");
    for name in ["smooth", "noise", "counts"] {
        let v = load_volume_var(&file, Some(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(v.dims, [16, 8, 4], "{name}");
        let expect: Vec<f32> = reference_numbers(&r, name)
            .iter()
            .map(|&x| x as f32)
            .collect();
        assert_eq!(v.data, expect, "{name}");
    }
}

/// A float64 HDF5 grid keeps every bit: values 1e-12 apart, 1e8 and 1e-300 as h5py wrote them.
#[test]
fn hdf5_float64_grids_keep_their_precision() {
    let dir = tempfile::tempdir().unwrap();
    let Some(r) = python_reference("write_reader_cases.py", dir.path(), "float64") else {
        return;
    };
    let opts = hdrvis::datasets::LoadOptions {
        variable: Some("z".into()),
        ..Default::default()
    };
    let grid = hdrvis::datasets::load_grid_with(&dir.path().join("float64.h5"), &opts).unwrap();
    let mut got = grid.property_at(0).1.to_vec();
    // Plain HDF5 grids keep storage order with row 0 at the bottom: the values as stored.
    let want = reference_numbers(&r, "z");
    got.sort_by(f64::total_cmp);
    let mut sorted = want.clone();
    sorted.sort_by(f64::total_cmp);
    assert_eq!(got, sorted);
}

/// One object hdrvis cannot read (a virtual dataset), a committed datatype and an attribute that
/// is not UTF-8 leave the rest of an HDF5 file readable: `info` lists the virtual dataset with
/// the reason, and naming it is a one-line error.
#[test]
fn hdf5_with_a_virtual_dataset_reads_its_other_datasets() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let Some(r) = python_reference("write_reader_cases.py", d, "partial") else {
        return;
    };
    let file = d.join("odd.h5");
    for (name, key) in [
        ("/good", "good"),
        ("/typed", "typed"),
        ("/g/inner", "inner"),
    ] {
        let v = load_volume_var(&file, Some(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let expect: Vec<f32> = reference_numbers(&r, key)
            .iter()
            .map(|&x| x as f32)
            .collect();
        assert_eq!(v.data, expect, "{name}");
    }
    let (code, stdout, stderr) = hdrvis(&["info", "odd.h5:/good"], d);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("/vds (not read: a virtual dataset (VDS)")
            && stdout.contains("/typed [3, 4, 5] float32")
            && stdout.contains("/g/inner [3, 4, 5] float32")
            && stdout.contains("units: m"),
        "{stdout}"
    );
    let (code, stdout, stderr) = hdrvis(&["info", "odd.h5:/vds"], d);
    assert_eq!(code, 1, "{stdout}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("odd.h5: dataset '/vds': not read: a virtual dataset"),
        "{stderr}"
    );
}

/// A NetCDF-4 file with a root attribute that is not UTF-8 and a dataset in a committed datatype
/// (added by h5py) still reads: `info` says what the strict reading stopped at.
#[test]
fn netcdf4_with_an_odd_attribute_and_a_committed_type_reads_its_variables() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let Some(r) = python_reference("write_reader_cases.py", d, "partial") else {
        return;
    };
    let v = load_volume_var(&d.join("odd.nc"), Some("other")).unwrap();
    let expect: Vec<f32> = reference_numbers(&r, "other")
        .iter()
        .map(|&x| x as f32)
        .collect();
    assert_eq!(v.data, expect);
    let (code, stdout, stderr) = hdrvis(&["info", "odd.nc", "--variable", "other"], d);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("(read leniently, the strict reading stopped at: "),
        "{stdout}"
    );
    // netCDF-C reads a NetCDF-4 file holding an HDF5 virtual dataset; the pure-Rust reader
    // lists a group's objects all at once and cannot pass over it: one line says so and how
    // to rewrite the file.
    let (code, stdout, stderr) = hdrvis(&["info", "vds.nc", "--variable", "other"], d);
    assert_eq!(code, 1, "{stdout}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("vds.nc: dataset 'vds' is an HDF5 virtual dataset")
            && stderr.contains("nccopy IN OUT"),
        "{stderr}"
    );
}

/// String variables (NC_STRING and char arrays) are listed but never picked by default, and
/// naming one is a one-line error, in NetCDF-4 and classic files.
#[test]
fn netcdf_string_variables_are_passed_over_and_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let Some(r) = python_reference("write_reader_cases.py", d, "strings") else {
        return;
    };
    let expect: Vec<f32> = reference_numbers(&r, "temp")
        .iter()
        .map(|&x| x as f32)
        .collect();
    for file in ["strings.nc", "strings3.nc"] {
        let v = hdrvis::datasets::load_volume(&d.join(file)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(v.data, expect, "{file}");
        let (code, stdout, stderr) = hdrvis(&["info", file], d);
        assert_eq!(code, 0, "{stderr}");
        assert!(stdout.contains("variable: temp"), "{stdout}");
        let names: &[&str] = if file == "strings.nc" {
            &["station_name", "label"]
        } else {
            &["label"]
        };
        for name in names {
            let (code, _, stderr) = hdrvis(&["info", file, "--variable", name], d);
            assert_eq!(code, 1, "{stderr}");
            assert_eq!(stderr.lines().count(), 1, "{stderr}");
            let want = format!("{file}: variable '{name}' holds strings; expected numbers");
            assert!(stderr.contains(&want), "{stderr}");
        }
    }
}

/// OpenEXR images with only some colour channels: Y or one of R, G, B alone as grey, a missing
/// colour channel 0 with a note, luminance-chroma converted to RGB with the file's primaries, and a
/// ZSTD-compressed file and one with subsampled chroma refused in one line naming what is not read.
#[test]
fn exr_channel_subsets_and_luminance_chroma_read_as_documented() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let Some(r) = python_reference("write_reader_cases.py", d, "exr") else {
        return;
    };
    let plane = |file: &str, c: usize| -> Vec<f64> {
        let img = read_exr(&d.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        img.pixels.iter().map(|p| f64::from(p[c])).collect()
    };
    let zero = vec![0.0; 24];
    let cases: [(&str, [&str; 3]); 5] = [
        ("y.exr", ["y_Y", "y_Y", "y_Y"]),
        ("r.exr", ["r_R", "r_R", "r_R"]),
        ("rg.exr", ["rg_R", "rg_G", ""]),
        ("yc.exr", ["yc_R", "yc_G", "yc_B"]),
        ("yc_p3.exr", ["yc_p3_R", "yc_p3_G", "yc_p3_B"]),
    ];
    for (file, keys) in cases {
        for (c, key) in keys.iter().enumerate() {
            let expect = if key.is_empty() {
                zero.clone()
            } else {
                reference_numbers(&r, key)
            };
            let rel = max_rel(&plane(file, c), &expect, 1e-3);
            assert!(rel < 2e-6, "{file} channel {c}: {rel}");
        }
    }
    let rg = read_exr(&d.join("rg.exr")).unwrap();
    assert!(rg
        .metadata
        .contains(&("read".into(), "no B channel: read as 0".into())));
    assert_eq!(rg.extra_channels[0].0, "Z");
    let (code, stdout, stderr) = hdrvis(&["info", "zstd.exr"], d);
    assert_eq!(code, 1, "{stdout}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("zstd.exr: ZSTD compression (method 13) is not read"),
        "{stderr}"
    );
    let (code, stdout, stderr) = hdrvis(&["info", "yc_sub.exr"], d);
    assert_eq!(code, 1, "{stdout}");
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains(
            "yc_sub.exr: channels BY (1 in 2 x 2), RY (1 in 2 x 2) are stored subsampled"
        ),
        "{stderr}"
    );
}
