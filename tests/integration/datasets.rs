//! Generated datasets through the binary, checked by independent clients: `hdrvis gen okada`
//! read back by netCDF4-python and xarray against the library's own Okada values, `hdrvis info`
//! and a NetCDF volume rendered through `load_volume`.

use crate::cli::{hdrvis, python_check};
use hdrvis::datasets::okada::{surface_field, Elastic, FaultSegment};

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
