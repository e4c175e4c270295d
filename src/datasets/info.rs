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

use super::select::Selection;
use super::slabs::{Slabs, SLAB_VALUES};
use super::stats::{histogram, streamed_min_gap, GapBuckets, GapPasses, ValueStats};
use super::{cf, list_arrays, read_array_sel, ArrayData};
use crate::error::Result;

/// Arrays of more values than this are read in slabs (where the format allows) rather than
/// whole: whole, the values and the reader's copy take 16 bytes each.
pub(crate) const STREAM_ABOVE: u64 = 1 << 24;

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

/// What `hdrvis info` is asked beyond the file and variable: the selection, a GeoTIFF's band and
/// the separate grid file of a variable on an unstructured mesh.
pub struct InfoRequest<'a> {
    pub sel: &'a Selection,
    pub band: Option<usize>,
    pub grid: Option<&'a Path>,
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
    let request = InfoRequest {
        sel,
        band,
        grid: None,
    };
    info_report_for(path, var, &request)
}

/// The report of [`info_report_band`], naming the mesh of a variable whose mesh is in
/// `request.grid`.
pub fn info_report_for(path: &Path, var: Option<&str>, request: &InfoRequest) -> Result<String> {
    let (sel, band) = (request.sel, request.band);
    let shorthand = (!path.exists() && var.is_none())
        .then(|| path.to_str()?.rsplit_once(':'))
        .flatten()
        .filter(|(file, name)| !name.is_empty() && Path::new(file).is_file());
    if let Some((file, name)) = shorthand {
        return info_report_for(Path::new(file), Some(name), request);
    }
    let format = super::Format::of(path)?;
    if format == super::Format::GeoTiff {
        return geotiff_report(path, var, sel, band);
    }
    if let Some(b) = band.filter(|&b| b != 1) {
        return Err(crate::error::Error::format(
            path,
            format!("band {b}: only GeoTIFF files (.tif, .tiff) have several bands"),
        ));
    }
    if format == super::Format::Exr {
        if !sel.is_empty() {
            return Err(crate::error::Error::format(
                path,
                "selecting by dimension (index, at) needs a NetCDF file",
            ));
        }
        return exr_report(path, var);
    }
    let (array, stats, how_read) = read_with_stats(path, var, sel, STREAM_ABOVE, SLAB_VALUES)?;
    let mut out = String::new();
    let _ = writeln!(out, "file: {}", path.display());
    use super::Format::{Hdf5, NetCdf};
    if format.reader().holds_many() {
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
        if format == NetCdf {
            let groups = super::netcdf::groups(path)?;
            if !groups.is_empty() {
                let _ = writeln!(
                    out,
                    "  groups, not read yet (only the root group's variables are): {}",
                    groups.join(", ")
                );
            }
            if let (_, Some(why)) = super::netcdf::open_noting(path)? {
                let _ = writeln!(
                    out,
                    "  (read leniently, the strict reading stopped at: {why})"
                );
            }
        }
    }
    describe_array(&mut out, &array, &stats);
    if let Some(how) = how_read {
        let _ = writeln!(out, "read: {how}");
    }
    if format == Hdf5 {
        if let Some(product) = super::mintpy::open(path)? {
            for line in super::mintpy::describe(path, &product)? {
                let _ = writeln!(out, "{line}");
            }
            for note in &array.notes {
                let _ = writeln!(out, "selected: {note}");
            }
        }
    }
    if format == NetCdf {
        dimension_lines(&mut out, path, &array, request.grid)?;
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
    let array = raster.array();
    describe_array(&mut out, &array, &ValueStats::of(&array.data));
    for line in raster.describe() {
        let _ = writeln!(out, "{line}");
    }
    Ok(out)
}

/// Each dimension of a NetCDF variable with its length and CF role (a time axis with its first
/// and last dates and calendar), then how the selected ones were chosen.
fn dimension_lines(
    out: &mut String,
    path: &Path,
    array: &ArrayData,
    grid: Option<&Path>,
) -> Result<()> {
    let dims = super::readers::variables::list_variables(path)?
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
            // A time axis need not be monotonic to be reported (all missing, say).
            Err(e) => match super::readers::variables::coordinate_variable(path, dim)? {
                Some(c) if matches!(cf::axis_role(path, &c), Ok(cf::AxisRole::Time)) => c,
                _ => {
                    let _ = writeln!(out, "  {dim} = {n}: other ({e})");
                    continue;
                }
            },
        };
        let role = cf::axis_role(path, &coord).unwrap_or(cf::AxisRole::Other);
        let units = coord.units.as_deref().unwrap_or("no units");
        let decoded = match role {
            cf::AxisRole::Time => Some(cf::time_decoding(path, &coord)),
            _ => None,
        };
        let detail = match (decoded, cf::time_units(path, &coord)) {
            (Some(cf::TimeDecoding::Dates { dates, note }), Ok(Some(t))) => format!(
                "{} to {} ({} calendar{})",
                dates[0].as_deref().unwrap_or("missing"),
                dates[n.saturating_sub(1)].as_deref().unwrap_or("missing"),
                t.calendar.name(),
                note.map_or(String::new(), |n| format!("; {n}"))
            ),
            (Some(cf::TimeDecoding::Raw { why }), _) => why,
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
    let dims: Vec<(String, usize)> = array
        .dims
        .iter()
        .cloned()
        .zip(array.shape.iter().copied())
        .collect();
    if let Some(mesh) =
        crate::datasets::conventions::mesh::read::mesh_of(path, &array.name, &dims, grid)?
    {
        let _ = writeln!(
            out,
            "mesh: {} (load_mesh draws it cell by cell; load_grid samples it onto a regular latitude-longitude grid at its cells' median size, {:.4} degrees, or at resolution)",
            mesh.describe(),
            mesh.median_size().unwrap_or(f64::NAN)
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

/// The array `info` describes and its statistics: read whole, or, above `stream_above` values
/// where the format allows, in slabs of at most `slab_values` (`data` then empty) with a line on
/// how.
pub(crate) fn read_with_stats(
    path: &Path,
    var: Option<&str>,
    sel: &Selection,
    stream_above: u64,
    slab_values: usize,
) -> Result<(ArrayData, ValueStats, Option<String>)> {
    // Before anything opens it: a FIFO without a writer would block the open.
    if !crate::datasets::readers::zarr::is_store(path) {
        crate::io::check_regular_file(path)?;
    }
    if let Some(slabs) = Slabs::open(path, var, sel)? {
        if slabs.len() > stream_above {
            return streamed_stats(slabs, slab_values);
        }
    }
    let array = read_array_sel(path, var, None, sel)?;
    let stats = ValueStats::of(&array.data);
    Ok((array, stats, None))
}

/// Statistics from one pass over the slabs, the smallest gap from as many more as sorting the
/// values a range at a time within a quarter of the available memory takes.
fn streamed_stats(
    slabs: Slabs,
    slab_values: usize,
) -> Result<(ArrayData, ValueStats, Option<String>)> {
    let ranges = slabs.ranges(slab_values);
    let mut stats = ValueStats::default();
    let mut buckets = GapBuckets::new();
    let mut fills = 0;
    for rows in &ranges {
        let slab = slabs.read(rows.clone())?;
        stats.add(&slab.values);
        buckets.add(&slab.values);
        fills += slab.fills;
    }
    let budget = crate::model::volume::available_memory_bytes()
        .unwrap_or(4 << 30)
        .min(32 << 30)
        / 4
        / 8;
    let (gap, passes) = streamed_min_gap(&buckets, budget, |visit| {
        for rows in &ranges {
            visit(&slabs.read(rows.clone())?.values);
        }
        Ok(())
    })?;
    stats.min_gap = gap;
    let gap_note = match passes {
        GapPasses::Passes(0) => "no finite values, so no gap".to_string(),
        GapPasses::Passes(1) => "the smallest gap in one more pass".to_string(),
        GapPasses::Passes(n) => {
            format!("the smallest gap in {n} more passes, a range of values at a time")
        }
        GapPasses::TooDense { bucket_values } => format!(
            "smallest gap not computed: {bucket_values} values share a range too narrow to split within the memory budget of {budget} values"
        ),
    };
    let how = format!(
        "in {} slab(s) of at most {} rows along '{}' ({} values in all); {gap_note}",
        ranges.len(),
        ranges.first().map_or(0, |r| r.len()),
        slabs.meta.dims.first().map_or("-", String::as_str),
        slabs.len()
    );
    let mut array = slabs.meta;
    array.fill_count = fills;
    Ok((array, stats, Some(how)))
}

fn describe_array(out: &mut String, array: &ArrayData, stats: &ValueStats) {
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
    out.push_str(&histogram(stats));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::datasets::netcdf;

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

    /// The slab path reads what the whole read reads: every statistic, the fill count and the
    /// description equal, for a NetCDF variable under a selection and for an `.npy` array.
    #[test]
    fn statistics_read_in_slabs_equal_those_of_the_whole_array() {
        let dir = tempfile::tempdir().unwrap();
        let (nx, ny, nz) = (7usize, 5usize, 6usize);
        let data: Vec<f32> = (0..nx * ny * nz)
            .map(|i| match i % 23 {
                0 => f32::NAN,
                1 => 0.0,
                _ => ((i as f32) * 0.37).sin() * 10f32.powi((i % 9) as i32 - 4),
            })
            .collect();
        let nc = dir.path().join("v.nc");
        netcdf::write_volume(
            &nc,
            [nx, ny, nz],
            [1.0; 3],
            [0.0; 3],
            "km",
            ("t", &data, "K", "temperature"),
            &[],
        )
        .unwrap();
        let npy = dir.path().join("v.npy");
        crate::datasets::npy::write_npy_f32(&npy, &[nz, ny, nx], &data).unwrap();
        let at_y = Selection {
            index: vec![("y".into(), 2)],
            at: Vec::new(),
        };
        for (path, sel) in [
            (&nc, Selection::default()),
            (&nc, at_y),
            (&npy, Selection::default()),
        ] {
            let (whole, whole_stats, none) =
                read_with_stats(path, None, &sel, u64::MAX, 1).unwrap();
            assert!(none.is_none());
            for slab in [1, 13, 35, 1000] {
                let (meta, stats, how) = read_with_stats(path, None, &sel, 0, slab).unwrap();
                assert_eq!(stats, whole_stats, "{} slab {slab}", path.display());
                assert_eq!(
                    (
                        &meta.name,
                        &meta.dims,
                        &meta.shape,
                        &meta.dtype,
                        &meta.units
                    ),
                    (
                        &whole.name,
                        &whole.dims,
                        &whole.shape,
                        &whole.dtype,
                        &whole.units
                    )
                );
                assert_eq!(
                    (meta.fill_count, &meta.notes),
                    (whole.fill_count, &whole.notes)
                );
                let how = how.unwrap();
                let expect_slabs = whole.shape[0]
                    .div_ceil((slab / whole.shape[1..].iter().product::<usize>()).max(1));
                assert!(
                    how.starts_with(&format!("in {expect_slabs} slab(s)")),
                    "{how}"
                );
            }
        }
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
