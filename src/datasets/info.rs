//! `hdrvis info`: what a data file holds and how high its dynamic range is. For one array it
//! reports shape, type, units, the finite minimum and maximum, the smallest non-zero magnitude,
//! the NaN, infinity and fill counts, the dynamic range D = (Vmax - Vmin) / d of Yuan et al.
//! (2008, Eq. 1), and a histogram of |v| with one row per decade.
//!
//! Eq. 1 leaves d as "the smallest increment of V" (a device limit, the noise floor or the
//! computation's precision). A file carries none of these, so d is estimated as the smallest
//! non-zero |v|: the smallest magnitude the data distinguish from zero. This is the reading of the
//! paper's Table 1, whose ranges are largest over smallest magnitude (1 cm to 10 m of wave height
//! is 10^3). The report also gives the smallest non-zero gap between distinct values, the
//! finest increment actually stored, and D with that d, as a second estimate.

use std::fmt::Write as _;
use std::path::Path;

use rayon::prelude::*;

use super::select::Selection;
use super::{cf, list_arrays, read_array_sel, ArrayData};
use crate::error::Result;

/// Widest histogram bar, in columns.
const BAR_WIDTH: usize = 60;
/// At most this many decade rows; smaller magnitudes are gathered into the first row.
const MAX_DECADE_ROWS: i32 = 40;

/// Statistics of one array's values.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ValueStats {
    pub count: usize,
    pub finite: usize,
    pub nan: usize,
    pub infinite: usize,
    pub zeros: usize,
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub min_abs_nonzero: Option<f64>,
    pub max_abs: Option<f64>,
    /// Smallest non-zero difference between two distinct finite values.
    pub min_gap: Option<f64>,
}

impl ValueStats {
    pub(crate) fn of(values: &[f64]) -> Self {
        let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let nan = values.iter().filter(|v| v.is_nan()).count();
        let zeros = finite.iter().filter(|v| **v == 0.0).count();
        finite.par_sort_unstable_by(f64::total_cmp);
        let min_abs_nonzero = finite
            .iter()
            .filter(|v| **v != 0.0)
            .map(|v| v.abs())
            .reduce(f64::min);
        let min_gap = finite
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .reduce(f64::min);
        ValueStats {
            count: values.len(),
            finite: finite.len(),
            nan,
            infinite: values.len() - finite.len() - nan,
            zeros,
            min: finite.first().copied(),
            max: finite.last().copied(),
            min_abs_nonzero,
            max_abs: match (finite.first(), finite.last()) {
                (Some(lo), Some(hi)) => Some(lo.abs().max(hi.abs())),
                _ => None,
            },
            min_gap,
        }
    }

    /// Eq. 1 with d = the smallest non-zero |v|; `None` when every value is 0 or missing.
    pub(crate) fn dynamic_range(&self) -> Option<f64> {
        Some((self.max? - self.min?) / self.min_abs_nonzero?)
    }

    /// Eq. 1 with d = the smallest gap between distinct values.
    pub(crate) fn dynamic_range_by_gap(&self) -> Option<f64> {
        Some((self.max? - self.min?) / self.min_gap?)
    }
}

/// The report `hdrvis info FILE [--variable NAME]` prints. Without `var`, an `.npz` is described
/// by its largest array and a NetCDF file by its first data variable; both list every array. An
/// OpenEXR image is described by its channels (`var` names one) and metadata. A `FILE:NAME`
/// path that is not itself a file names the variable after the last colon (`volume.h5:/a/b`).
pub fn info_report(path: &Path, var: Option<&str>) -> Result<String> {
    info_report_with(path, var, &Selection::default())
}

/// [`info_report`] of the variable with the dimensions `sel` fixes (NetCDF): the statistics
/// are those of the selected part. A NetCDF report also gives each dimension of the variable
/// with its CF role (time, vertical, latitude, longitude, other) and a time axis's dates.
pub(crate) fn info_report_with(path: &Path, var: Option<&str>, sel: &Selection) -> Result<String> {
    info_report_band(path, var, sel, None)
}

/// [`info_report_with`] of band `band` (counted from 1) of a GeoTIFF. A GeoTIFF's report adds
/// its CRS, georeferencing and nodata value; a MintPy product's its type, geography, `UNIT`,
/// `WAVELENGTH`, reference point and dates.
pub fn info_report_band(
    path: &Path,
    var: Option<&str>,
    sel: &Selection,
    band: Option<usize>,
) -> Result<String> {
    let shorthand = (!path.exists() && var.is_none())
        .then(|| path.to_str()?.rsplit_once(':'))
        .flatten()
        .filter(|(file, name)| !name.is_empty() && Path::new(file).is_file());
    if let Some((file, name)) = shorthand {
        return info_report_band(Path::new(file), Some(name), sel, band);
    }
    let ext = crate::io::extension(path);
    if super::geotiff::EXTENSIONS.contains(&ext.as_str()) {
        return geotiff_report(path, var, sel, band);
    }
    if let Some(b) = band.filter(|&b| b != 1) {
        return Err(crate::error::Error::format(
            path,
            format!("band {b}: only GeoTIFF files (.tif, .tiff) have several bands"),
        ));
    }
    if crate::io::extension(path) == "exr" {
        if !sel.is_empty() {
            return Err(crate::error::Error::format(
                path,
                "selecting by dimension (index, at) needs a NetCDF file",
            ));
        }
        return exr_report(path, var);
    }
    let array = read_array_sel(path, var, None, sel)?;
    let mut out = String::new();
    let _ = writeln!(out, "file: {}", path.display());
    let ext = crate::io::extension(path);
    if matches!(ext.as_str(), "npz" | "nc" | "nc4" | "cdf" | "netcdf")
        || super::hdf5::EXTENSIONS.contains(&ext.as_str())
    {
        let listed = list_arrays(path)?;
        let _ = writeln!(out, "arrays ({}):", listed.len());
        for a in &listed {
            let mark = if a.name == array.name { "*" } else { " " };
            let role = if a.is_coordinate {
                " (coordinate)"
            } else if a.is_auxiliary {
                " (auxiliary)"
            } else {
                ""
            };
            match &a.unreadable {
                Some(why) => {
                    let _ = writeln!(out, "  {mark} {} (not read: {why})", a.name);
                }
                None => {
                    let _ = writeln!(out, "  {mark} {} {:?} {}{role}", a.name, a.shape, a.dtype);
                }
            }
        }
        if matches!(ext.as_str(), "nc" | "nc4" | "cdf" | "netcdf") {
            if let (_, Some(why)) = super::netcdf::open_noting(path)? {
                let _ = writeln!(
                    out,
                    "  (read leniently, the strict reading stopped at: {why})"
                );
            }
        }
    }
    describe_array(&mut out, &array);
    if super::hdf5::EXTENSIONS.contains(&ext.as_str()) {
        if let Some(product) = super::mintpy::open(path)? {
            for line in super::mintpy::describe(path, &product)? {
                let _ = writeln!(out, "{line}");
            }
            for note in &array.notes {
                let _ = writeln!(out, "selected: {note}");
            }
        }
    }
    if matches!(ext.as_str(), "nc" | "nc4" | "cdf" | "netcdf") {
        dimension_lines(&mut out, path, &array)?;
        if array.shape.len() >= 3 {
            let _ = writeln!(out, "geometry: {}", super::netcdf_geometry(path, &array)?);
        }
    }
    Ok(out)
}

/// The report of one band of a GeoTIFF.
fn geotiff_report(
    path: &Path,
    var: Option<&str>,
    sel: &Selection,
    band: Option<usize>,
) -> Result<String> {
    if var.is_some() || !sel.is_empty() {
        return Err(crate::error::Error::format(
            path,
            "a GeoTIFF has no variables or dimensions to select; choose a band with --band N",
        ));
    }
    let raster = super::geotiff::read(path, band)?;
    let mut out = String::new();
    let _ = writeln!(out, "file: {}", path.display());
    describe_array(&mut out, &raster.array());
    for line in raster.describe() {
        let _ = writeln!(out, "{line}");
    }
    Ok(out)
}

/// Each dimension of a NetCDF variable with its length and CF role (a time axis with its first
/// and last dates and calendar), then how the selected ones were chosen.
fn dimension_lines(out: &mut String, path: &Path, array: &ArrayData) -> Result<()> {
    let dims = super::netcdf::list_variables(path)?
        .into_iter()
        .find(|(n, _)| *n == array.name)
        .map(|(_, d)| d)
        .unwrap_or_default();
    let _ = writeln!(out, "dimensions:");
    let pole = cf::rotated_pole(path, &array.name)?;
    for (dim, n) in &dims {
        // A coordinate the readers refuse (not monotonic, say) is reported, not fatal here.
        let coord = match cf::read_coordinate(path, dim) {
            Ok(Some(c)) => c,
            Ok(None) => {
                let _ = writeln!(out, "  {dim} = {n}: other (no coordinate variable)");
                continue;
            }
            Err(e) => {
                let _ = writeln!(out, "  {dim} = {n}: other ({e})");
                continue;
            }
        };
        let role = cf::axis_role(path, &coord).unwrap_or(cf::AxisRole::Other);
        let units = coord.units.as_deref().unwrap_or("no units");
        let detail = match (&role, cf::time_units(path, &coord)?) {
            (_, Some(t)) => format!(
                "{} to {} ({} calendar)",
                t.date(coord.data[0]),
                t.date(coord.data[n.saturating_sub(1)]),
                t.calendar.name()
            ),
            _ if coord.data.is_empty() => units.to_string(),
            _ => format!(
                "{} to {} {units}",
                coord.data[0],
                coord.data[coord.data.len() - 1]
            ),
        };
        let role = match (cf::text(&coord, "standard_name"), &pole) {
            (Some("grid_latitude"), Some(_)) => "rotated latitude",
            (Some("grid_longitude"), Some(_)) => "rotated longitude",
            _ => role.name(),
        };
        let _ = writeln!(out, "  {dim} = {n}: {role}, {detail}");
    }
    if let Some(p) = pole {
        let _ = writeln!(
            out,
            "grid mapping: rotated_latitude_longitude, {} (maps in rotated coordinates; globes and volumes at true positions)",
            p.describe()
        );
    }
    if let Some((lat, lon)) =
        cf::curvilinear_coords(path, &array.name, &array.attributes, &array.dims)?
    {
        let grid = super::curvilinear::Curvilinear {
            shape: [lat.dims[0].1, lat.dims[1].1],
            lat: &lat.data,
            lon: &lon.data,
        };
        let _ = writeln!(
            out,
            "curvilinear grid: {} and {} are 2-D; {} (load_grid regrids it onto a regular latitude-longitude grid; volumes on it load with geometry: \"cartesian\" only)",
            lat.name,
            lon.name,
            grid.describe()
        );
    }
    for note in &array.notes {
        let _ = writeln!(out, "selected: {note}");
    }
    Ok(())
}

/// The report of an OpenEXR image: size, channels with their finite range and missing counts
/// (one channel with `var`), and the text metadata.
fn exr_report(path: &Path, channel: Option<&str>) -> Result<String> {
    let img = crate::io::exr::read_exr(path)?;
    let mut channels: Vec<(String, Vec<f64>)> = ["R", "G", "B", "A"]
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let values = img.pixels.iter().map(|p| f64::from(p[c])).collect();
            (name.to_string(), values)
        })
        .collect();
    for (name, values) in &img.extra_channels {
        channels.push((name.clone(), values.iter().map(|&v| f64::from(v)).collect()));
    }
    if let Some(wanted) = channel {
        let names: Vec<&str> = channels.iter().map(|(n, _)| n.as_str()).collect();
        if !names.contains(&wanted) {
            return Err(crate::error::Error::format(
                path,
                format!("no channel '{wanted}'; the image has: {}", names.join(", ")),
            ));
        }
        channels.retain(|(n, _)| n == wanted);
    }
    let mut out = String::new();
    let _ = writeln!(out, "file: {}", path.display());
    let _ = writeln!(out, "image: {} x {} pixels", img.width, img.height);
    let _ = writeln!(out, "channels ({}):", channels.len());
    let show = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.6e}"));
    for (name, values) in &channels {
        let stats = ValueStats::of(values);
        let _ = writeln!(
            out,
            "  {name}: min {} max {} smallest non-zero |v| {} ({} NaN, {} infinite)",
            show(stats.min),
            show(stats.max),
            show(stats.min_abs_nonzero),
            stats.nan,
            stats.infinite
        );
    }
    let _ = writeln!(out, "metadata ({}):", img.metadata.len());
    for (key, value) in &img.metadata {
        let _ = writeln!(out, "  {key}: {value}");
    }
    Ok(out)
}

fn describe_array(out: &mut String, array: &ArrayData) {
    let stats = ValueStats::of(&array.data);
    let dims: Vec<String> = array
        .dims
        .iter()
        .zip(&array.shape)
        .map(|(d, n)| format!("{d}={n}"))
        .collect();
    let _ = writeln!(out, "variable: {}", array.name);
    let _ = writeln!(out, "shape: {:?} ({})", array.shape, dims.join(", "));
    let _ = writeln!(out, "dtype: {}", array.dtype);
    let _ = writeln!(out, "units: {}", array.units.as_deref().unwrap_or("(none)"));
    let _ = writeln!(out, "values: {} ({} finite)", stats.count, stats.finite);
    let _ = writeln!(
        out,
        "missing: {} NaN (of which {} fill values), {} infinite",
        stats.nan, array.fill_count, stats.infinite
    );
    let show = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.6e}"));
    let _ = writeln!(out, "min: {}", show(stats.min));
    let _ = writeln!(out, "max: {}", show(stats.max));
    let _ = writeln!(
        out,
        "smallest non-zero |v|: {}",
        show(stats.min_abs_nonzero)
    );
    let _ = writeln!(out, "zeros: {}", stats.zeros);
    let decades = |d: Option<f64>| match d {
        Some(d) if d > 0.0 => format!("{d:.4e} ({:.2} decades)", d.log10()),
        Some(d) => format!("{d:.4e}"),
        None => "undefined (no non-zero finite values)".to_string(),
    };
    let _ = writeln!(
        out,
        "dynamic range D = (Vmax - Vmin) / d (Yuan et al. 2008, Eq. 1), d = smallest non-zero |v|: {}",
        decades(stats.dynamic_range())
    );
    let _ = writeln!(
        out,
        "  with d = smallest gap between distinct values ({}): {}",
        show(stats.min_gap),
        decades(stats.dynamic_range_by_gap())
    );
    out.push_str(&histogram(&array.data, &stats));
}

/// One row per decade of |v| from the smallest non-zero magnitude to the largest, bars scaled
/// to the fullest row; zeros get their own row.
fn histogram(values: &[f64], stats: &ValueStats) -> String {
    let mut text = String::from("histogram of |v| (one row per decade):\n");
    let (Some(lo), Some(hi)) = (stats.min_abs_nonzero, stats.max_abs) else {
        text.push_str("  (no non-zero finite values)\n");
        return text;
    };
    let top = hi.log10().floor() as i32;
    let bottom = (lo.log10().floor() as i32).max(top - MAX_DECADE_ROWS + 1);
    let rows = (top - bottom + 1) as usize;
    let counts = values
        .par_iter()
        .filter(|v| v.is_finite() && **v != 0.0)
        .fold(
            || vec![0usize; rows],
            |mut acc, v| {
                let decade = (v.abs().log10().floor() as i32).clamp(bottom, top);
                acc[(decade - bottom) as usize] += 1;
                acc
            },
        )
        .reduce(
            || vec![0usize; rows],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                a
            },
        );
    let fullest = counts
        .iter()
        .copied()
        .max()
        .unwrap_or(0)
        .max(stats.zeros)
        .max(1);
    let bar = |count: usize| {
        // Any non-empty row shows at least one mark, so sparse decades stay visible.
        let width = (count * BAR_WIDTH).div_ceil(fullest);
        "#".repeat(width)
    };
    if stats.zeros > 0 {
        let _ = writeln!(
            text,
            "  {:>21} | {:<BAR_WIDTH$} {}",
            "0",
            bar(stats.zeros),
            stats.zeros
        );
    }
    for (row, &count) in counts.iter().enumerate() {
        let decade = bottom + row as i32;
        let label = if row == 0 && decade > lo.log10().floor() as i32 {
            format!("< 1e{}", decade + 1)
        } else {
            format!("[1e{decade}, 1e{})", decade + 1)
        };
        let _ = writeln!(text, "  {label:>21} | {:<BAR_WIDTH$} {count}", bar(count));
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datasets::netcdf;

    #[test]
    fn stats_and_dynamic_range_of_a_small_volume() {
        // Values chosen so every number is known: min -2, max 1000, smallest |v| 1e-3,
        // D = 1002 / 1e-3 = 1.002e6; distinct sorted values -2, 0, 1e-3, 1, 1000: gap 1e-3.
        let data = [-2.0, 0.0, 1e-3, 1.0, 1000.0, f64::NAN, f64::INFINITY, 1.0];
        let s = ValueStats::of(&data);
        assert_eq!((s.min, s.max), (Some(-2.0), Some(1000.0)));
        assert_eq!((s.nan, s.infinite, s.zeros, s.finite), (1, 1, 1, 6));
        assert_eq!(s.min_abs_nonzero, Some(1e-3));
        assert_eq!(s.min_gap, Some(1e-3));
        assert!((s.dynamic_range().unwrap() - 1.002e6).abs() < 1e-6);
    }

    #[test]
    fn report_on_a_netcdf_volume_counts_fills_and_draws_decades() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.nc");
        // 2 x 2 x 2 cells: magnitudes over 4 decades, one NaN stored as the NaN _FillValue.
        // Powers of two below 1 keep the values exact in f32.
        let data = [0.015625f32, 0.125, 1.0, 10.0, 100.0, -0.5, f32::NAN, 0.0];
        netcdf::write_volume(
            &path,
            [2, 2, 2],
            [1.0; 3],
            [0.0; 3],
            "km",
            ("temperature", &data, "K", "temperature"),
            &[],
        )
        .unwrap();
        let report = info_report(&path, None).unwrap();
        assert!(report.contains("variable: temperature"), "{report}");
        assert!(
            report.contains("shape: [2, 2, 2] (z=2, y=2, x=2)"),
            "{report}"
        );
        assert!(report.contains("units: K"), "{report}");
        assert!(report.contains("missing: 1 NaN"), "{report}");
        assert!(report.contains("min: -5.000000e-1"), "{report}");
        assert!(report.contains("max: 1.000000e2"), "{report}");
        // D = (100 + 0.5) / 0.015625 = 6432, log10 = 3.81.
        assert!(report.contains("6.4320e3 (3.81 decades)"), "{report}");
        // A zero row and decades 1e-2 .. 1e2; the fullest (1e-1: 0.125 and 0.5) is 60 wide.
        assert_eq!(report.matches(" | ").count(), 6, "{report}");
        assert!(
            report.contains(&format!("[1e-1, 1e0) | {} 2", "#".repeat(60))),
            "{report}"
        );
        let err = info_report(&path, Some("salinity"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("no variable 'salinity'") && err.contains("temperature"),
            "{err}"
        );
    }

    #[test]
    fn npz_lists_arrays_and_picks_the_largest() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.npz");
        let lon = [1.0f32, 2.0, 3.0];
        let elev = [-1.0f32, 1.0, 2.0, 3.0, 4.0, 5.0];
        crate::datasets::npy::write_npz(
            &path,
            &[("lon", &[3], &lon), ("elev", &[2, 3], &elev)],
            false,
        )
        .unwrap();
        let listed = list_arrays(&path).unwrap();
        let names: Vec<&str> = listed.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["lon", "elev"]);
        let report = info_report(&path, None).unwrap();
        assert!(
            report.contains("variable: elev") && report.contains("* elev [2, 3]"),
            "{report}"
        );
        assert!(report.contains("max: 5.000000e0"), "{report}");
        let report = info_report(&path, Some("lon")).unwrap();
        assert!(report.contains("shape: [3]"), "{report}");
        let err = info_report(&path, Some("lat")).unwrap_err().to_string();
        assert!(err.contains("elev [2, 3]"), "{err}");
    }
}
