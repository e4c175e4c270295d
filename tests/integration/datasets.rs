//! Generated datasets through the binary, checked by independent clients: `hdrvis gen okada`
//! read back by netCDF4-python and xarray against the library's own Okada values, `hdrvis info`
//! and a NetCDF volume rendered through `load_volume`. The files users have: one volume written by
//! VTK, pynrrd and h5py in every layout hdrvis reads loads and renders exactly like its `.npy`.

use crate::cli::{hdrvis, python_check};
use hdrvis::datasets::okada::{surface_field, Elastic, FaultSegment};
use hdrvis::datasets::{load_volume, load_volume_var};
use hdrvis::model::{Geometry, Volume};
use std::path::Path;

#[test]
fn okada_netcdf_reads_in_netcdf4_and_xarray() {
    let dir = tempfile::tempdir().unwrap();
    let (code, stdout, stderr) = hdrvis(
        &[
            "gen", "okada", "--n", "41", "--extent", "200000", "-o", "ok.nc",
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("ok.nc"));
    let field = surface_field(
        &[FaultSegment::paper_case_ii()],
        &Elastic::default(),
        200000.0,
        41,
        &mut |_| Ok(()),
    )
    .unwrap();
    let uz: Vec<f32> = field.uz.iter().map(|&v| v as f32).collect();
    let x: Vec<f32> = field.x.iter().map(|&v| v as f32).collect();
    let expect = dir.path().join("uz.npy");
    let expect_x = dir.path().join("x.npy");
    hdrvis::datasets::npy::write_npy_f32(&expect, &[41, 41], &uz).unwrap();
    hdrvis::datasets::npy::write_npy_f32(&expect_x, &[41], &x).unwrap();
    let file = dir.path().join("ok.nc");
    let coord = format!("x={}", expect_x.display());
    let args = [
        file.to_str().unwrap(),
        "--var",
        "uz",
        "--expect",
        expect.to_str().unwrap(),
        "--units",
        "m",
        "--coord",
        &coord,
        "--rtol",
        "1e-6",
        "--atol",
        "1e-9",
    ];
    if let Some(report) = python_check("check_netcdf.py", &args) {
        assert!(report.starts_with("exit 0"), "{report}");
    }
    // Our own reader agrees too, and `info` describes the file.
    let back = hdrvis::datasets::netcdf::read_variable(&file, "uz").unwrap();
    assert_eq!(back.data.len(), 41 * 41);
    assert!((back.data[20 * 41 + 20] - field.uz[20 * 41 + 20]).abs() < 1e-12);
    let (code, stdout, stderr) = hdrvis(&["info", "ok.nc", "--var", "uz"], dir.path());
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("uz") && stdout.to_lowercase().contains("dynamic range"),
        "{stdout}"
    );
    let (code, _, stderr) = hdrvis(&["info", "ok.nc", "--var", "nope"], dir.path());
    assert_ne!(code, 0);
    assert!(stderr.contains("ux") && stderr.contains("uz"), "{stderr}");
}

#[test]
fn generated_mantle_renders_from_netcdf() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, stderr) = hdrvis(
        &[
            "gen",
            "mantle",
            "--n",
            "24",
            "--field",
            "fluctuation",
            "-o",
            "m.nc",
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    let script = r#"
        let v = load_volume("m.nc");
        let img = render_volume(v, #{ tf: tf_lut(#{ scale: "symlog", linthresh: 1e-3, colormap: "spectral" }),
                                      width: 32, height: 32 });
        save_exr(img, "m.exr");
    "#;
    std::fs::write(dir.path().join("m.rhai"), script).unwrap();
    let (code, _, stderr) = hdrvis(&["run", "m.rhai", "--out", "o"], dir.path());
    assert_eq!(code, 0, "{stderr}");
    let img = hdrvis::io::exr::read_exr(&dir.path().join("o/m.exr")).unwrap();
    assert!(img.pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
    assert!(img.pixels.iter().any(|p| p[3] > 0.0));
}

#[test]
fn tsunami_on_real_bathymetry() {
    // matplotlib's topobathy.npz (Cascadia margin, see datasets/README.md): land cells are walls
    // with no sea surface, so the wave height is missing (NaN) there and positive and finite over
    // the sea.
    let dir = tempfile::tempdir().unwrap();
    let bathy = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("datasets/topobathy.npz");
    let (code, _, stderr) = hdrvis(
        &[
            "gen",
            "tsunami",
            "--bathymetry",
            bathy.to_str().unwrap(),
            "--duration",
            "1800",
            "-o",
            "t.nc",
        ],
        dir.path(),
    );
    assert_eq!(code, 0, "{stderr}");
    let file = dir.path().join("t.nc");
    let eta = hdrvis::datasets::netcdf::read_variable(&file, "max_abs_eta").unwrap();
    let depth = hdrvis::datasets::netcdf::read_variable(&file, "depth").unwrap();
    assert_eq!(eta.data.len(), 91 * 120);
    assert!(eta
        .data
        .iter()
        .zip(&depth.data)
        .all(|(v, d)| *d <= 0.0 || (v.is_finite() && *v >= 0.0)));
    let sea: Vec<f64> = eta
        .data
        .iter()
        .zip(&depth.data)
        .filter(|(_, d)| **d > 0.0)
        .map(|(e, _)| *e)
        .collect();
    let land = eta
        .data
        .iter()
        .zip(&depth.data)
        .filter(|(_, d)| **d <= 0.0)
        .map(|(e, _)| *e);
    assert!(sea.len() > 1000 && sea.iter().filter(|e| **e > 0.0).count() > sea.len() / 2);
    assert!(land.into_iter().all(|e| e.is_nan()));
}

/// What tests/python/write_formats.py writes: spacing and minimum corner of every file with
/// geometry.
const FORMAT_SPACING: [f64; 3] = [0.5, 0.25, 2.0];
const FORMAT_CORNER: [f64; 3] = [-1.0, 2.0, 0.5];

/// Every reference file of tests/python/write_formats.py in a fresh folder; `None` when the
/// Python modules are missing (and HDRVIS_REQUIRE_PYTHON is not set).
fn reference_files() -> Option<tempfile::TempDir> {
    let dir = tempfile::tempdir().unwrap();
    let report = python_check("write_formats.py", &[dir.path().to_str().unwrap()])?;
    assert!(report.starts_with("exit 0"), "{report}");
    Some(dir)
}

fn bits(data: &[f32]) -> Vec<u32> {
    data.iter().map(|v| v.to_bits()).collect()
}

/// `v` holds exactly the values and dims of `expect` (the `.npy`), with `spacing` and `origin`.
fn assert_same_volume(
    file: &str,
    v: &Volume,
    expect: &Volume,
    spacing: [f64; 3],
    origin: [f64; 3],
) {
    assert_eq!(v.dims, expect.dims, "{file} dims");
    assert_eq!(bits(&v.data), bits(&expect.data), "{file} values");
    assert_eq!(
        (v.spacing, v.origin),
        (spacing, origin),
        "{file} spacing and origin"
    );
}

#[test]
fn every_reference_format_loads_exactly_like_the_npy() {
    let Some(dir) = reference_files() else { return };
    let d = dir.path();
    let expect = load_volume(&d.join("expect.npy")).unwrap();
    assert_eq!(expect.dims, [5, 4, 3]);
    let with_geometry = [
        "vti_zlib.vti",
        "vti_zlib_binary.vti",
        "vti_zlib_raw.vti",
        "vti_zlib_uint32.vti",
        "vti_zlib_blocks.vti",
        "vti_lz4.vti",
        "vti_lzma.vti",
        "vti_ascii.vti",
        "vti_raw.vti",
        "vti_points.vti",
        "vtk_points_binary.vtk",
        "vtk_points_ascii.vtk",
        "vtk_cells_binary.vtk",
        "vtk_cells_ascii.vtk",
        "rect_uniform_binary.vtk",
        "rect_uniform_ascii.vtk",
        "nrrd_raw.nrrd",
        "nrrd_raw.nhdr",
        "nrrd_gzip.nrrd",
        "nrrd_gzip.nhdr",
        "nrrd_bzip2.nrrd",
        "nrrd_bzip2.nhdr",
        "nrrd_ascii.nrrd",
        "nrrd_ascii.nhdr",
    ];
    for file in with_geometry {
        let v = load_volume(&d.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(v.geometry, Geometry::Regular, "{file}");
        assert_same_volume(file, &v, &expect, FORMAT_SPACING, FORMAT_CORNER);
    }
    // HDF5 datasets carry no geometry, like a .npy; f32 chunked + gzip + shuffle, f64 contiguous.
    for name in ["/fields/density", "fields/density_f64"] {
        let v = load_volume_var(&d.join("volume.h5"), Some(name)).unwrap();
        assert_same_volume(name, &v, &expect, [1.0; 3], [0.0; 3]);
    }
    let density = load_volume_var(&d.join("volume.h5"), Some("/fields/density")).unwrap();
    assert_eq!(density.units, "kg m-3");
    let counts = load_volume_var(&d.join("volume.h5"), Some("/counts")).unwrap();
    let expect_counts = load_volume(&d.join("counts.npy")).unwrap();
    assert_eq!(bits(&counts.data), bits(&expect_counts.data));
    // Non-uniform z centres 1, 2, 4 make a rectilinear volume; x and y keep their centres.
    let v = load_volume(&d.join("rect_stretched_binary.vtk")).unwrap();
    assert_eq!(bits(&v.data), bits(&expect.data));
    let Geometry::Rectilinear(axes) = &v.geometry else {
        panic!("rect_stretched_binary.vtk: {:?}", v.geometry)
    };
    assert_eq!(axes[2].centres, [1.0, 2.0, 4.0]);
    assert_eq!(axes[0].centres, [-0.75, -0.25, 0.25, 0.75, 1.25]);
    assert_eq!((axes[2].lo, axes[2].hi), (1.0, 4.0));
}

/// Data after a `line skip` or `byte skip`, as pynrrd reads them (tests/python/write_nrrd_skips.py
/// checks each file with pynrrd before this test reads it).
#[test]
fn nrrd_line_and_byte_skips_read_like_pynrrd() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let Some(report) = python_check("write_nrrd_skips.py", &[d.to_str().unwrap()]) else {
        return;
    };
    assert!(report.starts_with("exit 0"), "{report}");
    let expect = load_volume(&d.join("expect.npy")).unwrap();
    assert_eq!((expect.data[0], expect.data[23]), (-28.3, 1234.5));
    for file in [
        "lineskip.nhdr",
        "lineskip_gzip.nrrd",
        "byteskip.nhdr",
        "byteskip_end.nhdr",
    ] {
        let v = load_volume(&d.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(v.dims, [4, 3, 2], "{file}");
        assert_eq!(bits(&v.data), bits(&expect.data), "{file} values");
    }
}

/// A few kilobytes that declare gigabytes (a never-written chunked NetCDF-4 variable of 1024^3
/// floats, 8 GiB as f64): under a 4 GB memory limit `info` reads it in slabs and reports every
/// value a fill value, where it used to abort (SIGABRT) part-way through the allocation.
#[test]
fn a_small_file_declaring_more_than_the_memory_limit_is_described_in_slabs() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("unwritten.nc");
    let Some(report) = python_check("write_unwritten_nc.py", &[file.to_str().unwrap()]) else {
        return;
    };
    assert!(report.starts_with("exit 0"), "{report}");
    assert!(std::fs::metadata(&file).unwrap().len() < 100_000);
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 4000000; exec {} info {}",
            env!("CARGO_BIN_EXE_hdrvis"),
            file.display()
        ))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    for line in [
        "values: 1073741824 (0 finite)",
        "missing: 1073741824 NaN (of which 1073741824 fill values), 0 infinite",
        "read: in 64 slab(s) of at most 16 rows along 'z' (1073741824 values in all)",
    ] {
        assert!(stdout.contains(line), "{line:?} in\n{stdout}");
    }
}

#[test]
fn npz_from_numpy_savez_and_savez_compressed_loads_like_the_npy() {
    let Some(dir) = reference_files() else { return };
    let d = dir.path();
    let expect = load_volume(&d.join("expect.npy")).unwrap();
    let expect_counts = load_volume(&d.join("counts.npy")).unwrap();
    for file in ["npz_stored.npz", "npz_deflated.npz"] {
        let path = d.join(file);
        // density and counts are equally large: the first in the archive is the default.
        let v = load_volume(&path).unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(v.name, "density", "{file}");
        assert_same_volume(file, &v, &expect, [1.0; 3], [0.0; 3]);
        let counts = load_volume_var(&path, Some("counts")).unwrap();
        assert_eq!(bits(&counts.data), bits(&expect_counts.data), "{file}");
        let (code, stdout, stderr) = hdrvis(&["info", file, "--variable", "x"], d);
        assert_eq!(code, 0, "{stderr}");
        for line in [
            "arrays (4):",
            "  density [3, 4, 5] <f4",
            "  counts [3, 4, 5] <i2",
            "  map [4, 5] <f4",
            "* x [5] <f8",
            "min: -7.500000e-1",
            "max: 1.250000e0",
        ] {
            assert!(stdout.contains(line), "{file}: {line:?} in\n{stdout}");
        }
    }
}

#[test]
fn a_zlib_vti_renders_bit_identically_to_the_npy() {
    use crate::common::render;
    use hdrvis::gpu::BackendChoice;
    use hdrvis::model::{Camera, TransferFunction};
    use hdrvis::render::VolumeRenderOptions;
    let Some(dir) = reference_files() else { return };
    let vti = load_volume(&dir.path().join("vti_zlib.vti")).unwrap();
    let mut npy = load_volume(&dir.path().join("expect.npy")).unwrap();
    (npy.spacing, npy.origin) = (FORMAT_SPACING, FORMAT_CORNER);
    let cam = Camera::orbit(&vti.bounds(), 30.0, 20.0, 40.0).unwrap();
    let mut opts = VolumeRenderOptions::new(
        cam,
        TransferFunction::emission_absorption(1e-3, 1e-4).unwrap(),
    );
    (opts.width, opts.height, opts.step) = (24, 20, 0.5);
    let a = render(BackendChoice::Vulkan, &vti, &opts);
    let b = render(BackendChoice::Vulkan, &npy, &opts);
    let px = |img: &hdrvis::model::HdrImage| {
        img.pixels
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(px(&a), px(&b));
    assert!(a.pixels.iter().any(|p| p[3] > 0.0));
}

/// Writes `bytes` to `dir/name` and returns `hdrvis info name`'s exit code and stderr.
fn info_of(dir: &Path, name: &str, bytes: &[u8]) -> (i32, String) {
    std::fs::write(dir.join(name), bytes).unwrap();
    let (code, _, stderr) = hdrvis(&["info", name], dir);
    (code, stderr)
}

#[test]
fn corrupt_compressed_blocks_and_wrong_counts_are_one_line_errors() {
    let Some(dir) = reference_files() else { return };
    let d = dir.path();
    let read = |name: &str| std::fs::read(d.join(name)).unwrap();
    // A zlib block cut short: the raw appended block loses its last 8 bytes (the closing tags
    // follow, so the stream is corrupt rather than short).
    let raw = read("vti_zlib_raw.vti");
    let appended = raw.windows(13).position(|w| w == b"<AppendedData").unwrap();
    let underscore = appended + raw[appended..].iter().position(|&b| b == b'_').unwrap();
    let end = raw
        .windows(16)
        .position(|w| w == b"\n  </AppendedDat")
        .unwrap();
    let mut cut = raw[..end - 8].to_vec();
    cut.extend_from_slice(&raw[end..]);
    let mut flipped = raw.clone();
    // Bytes inside the deflate stream changed: the header (UInt64: 4 numbers) is 32 bytes.
    for b in &mut flipped[underscore + 1 + 32 + 4..underscore + 1 + 32 + 12] {
        *b ^= 0x5a;
    }
    // The deflated density member of np.savez_compressed's archive with bytes in the middle of its
    // stream changed (the local header is 30 bytes, then the name and extra field).
    let deflated = read("npz_deflated.npz");
    let le16 = |at: usize| usize::from(u16::from_le_bytes([deflated[at], deflated[at + 1]]));
    let stream = 30 + le16(26) + le16(28);
    let mut inflated_wrong = deflated.clone();
    for b in &mut inflated_wrong[stream + 120..stream + 128] {
        *b ^= 0x5a;
    }
    let mut gz = read("nrrd_gzip.raw.gz");
    gz.truncate(gz.len() / 2);
    let nhdr = read("nrrd_gzip.nhdr");
    let sp = read("vtk_points_binary.vtk");
    let wrong_count = String::from_utf8_lossy(&sp).replacen("POINT_DATA 60", "POINT_DATA 61", 1);
    let mut short_legacy = sp.clone();
    short_legacy.truncate(sp.len() - 40);
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("cut.vti", cut, "array 'density'"),
        ("flipped.vti", flipped, "array 'density'"),
        ("count.vtk", wrong_count.into_bytes(), "POINT_DATA 61"),
        ("short.vtk", short_legacy, "density"),
        ("npz_bzip2.npz", read("npz_bzip2.npz"), "Bzip2"),
        (
            "npz_cut.npz",
            deflated[..deflated.len() / 2].to_vec(),
            "not a readable .npz",
        ),
        ("npz_flipped.npz", inflated_wrong, "array 'density'"),
        (
            "npz_text.npz",
            b"density = 1\n".to_vec(),
            "not a readable .npz",
        ),
    ];
    for (name, bytes, needle) in cases {
        let (code, stderr) = info_of(d, name, &bytes);
        assert_ne!(code, 0, "{name}");
        assert!(
            stderr.contains(name) && stderr.contains(needle),
            "{name}: {stderr}"
        );
        assert_eq!(stderr.trim().lines().count(), 1, "{name}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // A truncated gzip data file named by a detached header.
    std::fs::write(d.join("half.raw.gz"), &gz).unwrap();
    let header = String::from_utf8_lossy(&nhdr).replace("nrrd_gzip.raw.gz", "half.raw.gz");
    let (code, stderr) = info_of(d, "half.nhdr", header.as_bytes());
    assert_ne!(code, 0);
    assert!(
        stderr.contains("half.raw.gz") && stderr.contains("gzip"),
        "{stderr}"
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    // The same through a script's load_volume: non-zero exit, the file named, nothing written.
    std::fs::write(d.join("s.rhai"), "let v = load_volume(\"cut.vti\");\nsave_exr(render_volume(v, #{ tf: tf_emission_absorption(1, 1) }), \"x.exr\");").unwrap();
    let (code, _, stderr) = hdrvis(&["run", "s.rhai", "--out", "o"], d);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("cut.vti") && stderr.contains("density"),
        "{stderr}"
    );
    assert!(!d.join("o/x.exr").exists());
}

#[test]
fn hdf5_without_a_dataset_path_lists_the_3d_datasets() {
    let Some(dir) = reference_files() else { return };
    let d = dir.path();
    let (code, _, stderr) = hdrvis(&["info", "volume.h5"], d);
    assert_ne!(code, 0);
    assert!(
        stderr.contains("/fields/density [3, 4, 5] float32")
            && stderr.contains("/counts [3, 4, 5] int16")
            && !stderr.contains("/map"),
        "{stderr}"
    );
    let (code, stdout, stderr) = hdrvis(&["info", "volume.h5:/fields/density"], d);
    assert_eq!(code, 0, "{stderr}");
    assert!(
        stdout.contains("kg m-3") && stdout.contains("/map"),
        "{stdout}"
    );
    // Scripts name the dataset the same way.
    std::fs::write(
        d.join("h.rhai"),
        "let v = load_volume(\"volume.h5:/fields/density\"); print(v.dims);",
    )
    .unwrap();
    let (code, stdout, stderr) = hdrvis(&["run", "h.rhai", "--out", "o"], d);
    assert_eq!(code, 0, "{stderr}");
    assert!(stdout.contains("[5, 4, 3]"), "{stdout}");
}
