//! hdrvis's reading of every numeric variable of real archives, set beside xarray's: the files
//! climate, ocean and weather projects publish inside their PyPI packages (Met Office, CMIP6
//! models through ESMValTool, ARM, NCEP/NCAR reanalyses, GFDL), the GRIB files of cfgrib's
//! source distribution (ECMWF, NCEP, DWD), the Zarr stores of cfdm and earthkit-data (v2 and
//! v3, consolidated, one with Python's bare NaN) and unstructured meshes (LFRic, FESOM2, ICON,
//! UGRID 0.9, and NCL's ICON, CAM-SE, SCRIP and coastal examples from Debian), pinned with their
//! hashes in
//! tests/python/conformance.py, fetched once into `target/conformance-corpus` by the test (never
//! by the tool). For each variable `hdrvis info --json` must give xarray + cf_xarray's dims,
//! roles, shape, units, coordinates, dates, missing count, minimum and maximum (cfgrib's for
//! GRIB), or netCDF4-python's masking where xarray's leaves default fills and valid ranges, or a
//! difference docs/formats.md explains; a refusal only of a file docs/formats.md names; and
//! docs/formats.md holds the table this run makes.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The corpus's folder (`target/conformance-corpus`), fetched once for every test that reads it
/// (`conformance.py fetch`); `None` when Python or its packages are missing.
pub fn corpus() -> Option<&'static Path> {
    static CORPUS: OnceLock<Option<PathBuf>> = OnceLock::new();
    CORPUS
        .get_or_init(|| {
            let cache = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/conformance-corpus");
            let fetched =
                crate::cli::python_check("conformance.py", &["fetch", cache.to_str().unwrap()])?;
            assert!(fetched.starts_with("exit 0\n"), "fetch: {fetched}");
            Some(cache)
        })
        .as_deref()
}

#[test]
fn every_variable_of_real_archives_reads_as_xarray_reads_it() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let Some(cache) = corpus() else {
        return;
    };
    let cache = cache.to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let table = dir.path().join("conformance.md");
    let args = [
        "compare",
        env!("CARGO_BIN_EXE_hdrvis"),
        cache,
        "--table",
        table.to_str().unwrap(),
    ];
    let Some(report) = crate::cli::python_check("conformance.py", &args) else {
        return;
    };
    assert!(report.starts_with("exit 0\n"), "compare: {report}");
    let summary = report
        .lines()
        .find_map(|l| l.strip_prefix("SUMMARY "))
        .unwrap_or_else(|| panic!("no SUMMARY line: {report}"));
    let count = |key: &str| -> usize {
        summary
            .split_whitespace()
            .find_map(|w| w.strip_prefix(&format!("{key}=")))
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no {key} in {summary}"))
    };
    let problems: Vec<&str> = report
        .lines()
        .filter(|l| l.contains(": disagree: ") || l.contains(": refused: "))
        .collect();
    // Refusals are allowed only where docs/formats.md names the file and says why.
    let docs = std::fs::read_to_string(root.join("docs/formats.md")).unwrap();
    let unexplained: Vec<&&str> = problems
        .iter()
        .filter(|l| {
            l.contains(": disagree: ")
                || l.split_whitespace()
                    .next()
                    .and_then(|f| f.rsplit('/').next())
                    .is_none_or(|file| !docs.contains(&format!("`{file}`")))
        })
        .collect();
    assert!(
        count("disagree") == 0 && unexplained.is_empty(),
        "{summary}\n{}",
        problems.join("\n")
    );
    assert!(
        count("files") >= 183 && count("variables") >= 2300,
        "{summary}"
    );
    // docs/formats.md shows this run's table.
    let made = std::fs::read_to_string(&table).unwrap();
    for row in made.lines().filter(|l| l.starts_with("| ")) {
        assert!(
            docs.contains(row),
            "docs/formats.md lacks the conformance row\n{row}\n(paste the table `python3 tests/python/conformance.py compare target/debug/hdrvis target/conformance-corpus --table T.md` writes)"
        );
    }
}
