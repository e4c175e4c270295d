//! NetCDF grids in and out. Reading covers classic (CDF-1/2/5) and NetCDF-4 (HDF5) files through
//! the pure-Rust `netcdf-reader` crate, applying the CF rules a viewer needs: values equal to
//! `_FillValue` or `missing_value` (or outside `valid_range`) become NaN, then packed integers are
//! unpacked as `stored * scale_factor + add_offset`. Writing produces CF-1.8 classic NetCDF through
//! `netcdf-writer`, into a temporary file that is renamed into place, so a failed write never
//! leaves a half-written file behind. Only the root group of a NetCDF-4 file is read.

use std::path::Path;

use netcdf_reader::{NcAttrValue, NcFile};

use crate::error::{Error, Result};

mod reader;
mod write;
pub(crate) use reader::NetcdfReader;
pub(crate) use write::{write_built, write_grid_with_aux, AuxCoord, GridAux, GridCoord, GridVar};
pub use write::{write_grid, write_volume, GridValue};

pub(crate) use super::variables::{dims_in, Dims};
pub use super::variables::{NcAttribute, NcVariable};

/// Every variable of the root group with its dimensions, in file order.
pub(crate) fn list_variables(path: impl AsRef<Path>) -> Result<Vec<(String, Dims)>> {
    let path = path.as_ref();
    let file = open(path)?;
    let vars = file.variables().map_err(|e| reader_error(path, e))?;
    vars.iter()
        .map(|v| Ok((v.name().to_string(), dims_of(path, v)?)))
        .collect()
}

/// The file's global attributes, reduced to text and numbers.
pub(crate) fn global_attributes(path: impl AsRef<Path>) -> Result<Vec<(String, NcAttribute)>> {
    let path = path.as_ref();
    let file = open(path)?;
    let attrs = file
        .global_attributes()
        .map_err(|e| reader_error(path, e))?;
    Ok(attrs
        .iter()
        .filter_map(|a| convert_attribute(&a.value).map(|v| (a.name.clone(), v)))
        .collect())
}

/// The attributes of variable `name` (of any type), without its data.
pub(crate) fn variable_attributes(path: &Path, name: &str) -> Result<Vec<(String, NcAttribute)>> {
    let file = open(path)?;
    let var = file.variable(name).map_err(|e| reader_error(path, e))?;
    Ok(var
        .attributes()
        .iter()
        .filter_map(|a| convert_attribute(&a.value).map(|v| (a.name.clone(), v)))
        .collect())
}

/// Reads one variable with CF masking and unpacking applied. A name the file lacks gives an
/// error that lists the variables it has.
pub fn read_variable(path: impl AsRef<Path>, name: &str) -> Result<NcVariable> {
    read_variable_picked(path.as_ref(), name, &[])
}

/// [`read_variable`] of a hyperslab: `picks` (one per dimension, or empty for all) takes index
/// `i` of a dimension (`Some(i)`, which drops the dimension) or all of it (`None`).
pub(crate) fn read_variable_picked(
    path: &Path,
    name: &str,
    picks: &[Option<usize>],
) -> Result<NcVariable> {
    read_variable_window(path, name, picks, None)
}

/// [`read_variable_picked`] of the rows `window.1` of dimension `window.0` (counted among all
/// the variable's dimensions, one that `picks` keeps): a slab, for reading in bounded memory.
///
/// A longitude axis stored in numeric order across the seam ([`seam_roll`]) is read in
/// geographic order, as if stored rolled: its coordinate variable and every variable on it alike,
/// indices counted in that order.
pub(crate) fn read_variable_window(
    path: &Path,
    name: &str,
    picks: &[Option<usize>],
    window: Option<(usize, std::ops::Range<usize>)>,
) -> Result<NcVariable> {
    let file = open(path)?;
    let var = numeric_variable(path, &file, name)?;
    let all_dims = dims_of(path, var)?;
    let picks: Vec<Option<usize>> = if picks.is_empty() {
        vec![None; all_dims.len()]
    } else {
        picks.to_vec()
    };
    let rolls: Vec<Option<usize>> = all_dims
        .iter()
        .map(|(dim, _)| seam_roll_of(&file, dim))
        .collect();
    if rolls.iter().all(Option::is_none) {
        return read_stored(path, &file, var, &picks, window);
    }
    let stored_picks: Vec<Option<usize>> = picks
        .iter()
        .zip(&rolls)
        .zip(&all_dims)
        .map(|((p, r), (_, n))| match (p, r) {
            (Some(i), Some(start)) if i < n => Some((i + start) % n),
            _ => *p,
        })
        .collect();
    // A window along a rolled axis is cut after rolling the whole axis.
    let rolled_window = window.clone().filter(|(a, _)| rolls[*a].is_some());
    let direct = window.filter(|(a, _)| rolls[*a].is_none());
    let mut v = read_stored(path, &file, var, &stored_picks, direct)?;
    let kept: Vec<usize> = (0..all_dims.len())
        .filter(|&a| picks[a].is_none())
        .collect();
    for (p, &a) in kept.iter().enumerate() {
        if let Some(start) = rolls[a] {
            let shape: Vec<usize> = v.dims.iter().map(|(_, n)| *n).collect();
            v.data = roll_axis(&v.data, &shape, p, start);
        }
        if let Some((_, rows)) = rolled_window.as_ref().filter(|(w, _)| *w == a) {
            let shape: Vec<usize> = v.dims.iter().map(|(_, n)| *n).collect();
            v.data = take_rows(&v.data, &shape, p, rows.clone());
            v.dims[p].1 = rows.len();
        }
    }
    Ok(v)
}

/// Where a longitude axis stored in numeric order across the seam begins in geographic order:
/// `Some(k)` when increasing values have one hole (a step wider than four times the median one)
/// and the step from the last value round to the first is an ordinary one (at most 1.5 times the
/// widest other step), as a region from 170.5°E to 170.5°W stored −179.5 … −170.5, 170.5 …
/// 179.5 has; its cells in order are then those from the hole on. `None` for any other axis.
pub(crate) fn seam_roll(values: &[f64]) -> Option<usize> {
    let n = values.len();
    if n < 3 || values.iter().any(|v| !v.is_finite()) {
        return None;
    }
    let steps: Vec<f64> = values.windows(2).map(|w| w[1] - w[0]).collect();
    if steps.iter().any(|&d| d <= 0.0) {
        return None;
    }
    let (hole, &widest) = steps.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1))?;
    let mut sorted = steps.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let other = steps
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != hole)
        .map(|(_, &d)| d)
        .fold(0.0, f64::max);
    let round = 360.0 - (values[n - 1] - values[0]);
    (widest > 4.0 * median && round > 0.0 && round <= 1.5 * other.max(median)).then_some(hole + 1)
}

/// Longitude units of CF (udunits spellings, lower case).
pub(crate) const LONGITUDE_UNITS: [&str; 6] = [
    "degrees_east",
    "degree_east",
    "degree_e",
    "degrees_e",
    "degreee",
    "degreese",
];

/// Where dimension `dim` of `path` begins in geographic order when its longitudes are stored in
/// numeric order across the seam ([`seam_roll`]), as every variable on it is read.
pub(crate) fn rolled_by(path: &Path, dim: &str) -> Result<Option<usize>> {
    Ok(seam_roll_of(&open(path)?, dim))
}

/// [`seam_roll`] of dimension `dim`'s coordinate variable when it is a longitude (by units or
/// standard name), read as stored.
fn seam_roll_of(file: &NcFile, dim: &str) -> Option<usize> {
    let var = file.variable(dim).ok()?;
    if var.dimensions().len() != 1 || var.dimensions()[0].name != dim {
        return None;
    }
    let text = |key: &str| {
        var.attributes()
            .iter()
            .find_map(|a| match convert_attribute(&a.value) {
                Some(NcAttribute::Text(t)) if a.name == key => Some(t.trim().to_ascii_lowercase()),
                _ => None,
            })
    };
    let longitude = text("standard_name").as_deref() == Some("longitude")
        || text("units").is_some_and(|u| LONGITUDE_UNITS.contains(&u.as_str()));
    if !longitude {
        return None;
    }
    let mut raw = file.read_variable_as_f64(dim).ok()?;
    decode_cf(var, &mut raw);
    seam_roll(&raw.iter().copied().collect::<Vec<f64>>())
}

/// C-ordered `data` of `shape` with axis `axis` rolled to begin at index `start`.
fn roll_axis(data: &[f64], shape: &[usize], axis: usize, start: usize) -> Vec<f64> {
    let n = shape[axis];
    let inner: usize = shape[axis + 1..].iter().product();
    let mut out = Vec::with_capacity(data.len());
    for block in data.chunks(n * inner) {
        out.extend_from_slice(&block[start * inner..]);
        out.extend_from_slice(&block[..start * inner]);
    }
    out
}

/// C-ordered `data` of `shape` cut to `rows` of axis `axis`.
fn take_rows(data: &[f64], shape: &[usize], axis: usize, rows: std::ops::Range<usize>) -> Vec<f64> {
    let inner: usize = shape[axis + 1..].iter().product();
    data.chunks(shape[axis] * inner)
        .flat_map(|block| &block[rows.start * inner..rows.end * inner])
        .copied()
        .collect()
}

/// [`read_variable_window`] in storage order.
fn read_stored(
    path: &Path,
    file: &NcFile,
    var: &netcdf_reader::NcVariable,
    picks: &[Option<usize>],
    window: Option<(usize, std::ops::Range<usize>)>,
) -> Result<NcVariable> {
    let name = var.name();
    let mut all_dims = dims_of(path, var)?;
    let mut ranges: Vec<(u64, u64)> = all_dims.iter().map(|(_, n)| (0, *n as u64)).collect();
    if let Some((axis, rows)) = &window {
        if picks.get(*axis) != Some(&None) || rows.end > all_dims[*axis].1 {
            return Err(Error::format(
                path,
                format!("variable '{name}': rows {rows:?} of dimension {axis} are not in it"),
            ));
        }
        ranges[*axis] = (rows.start as u64, rows.end as u64);
        all_dims[*axis].1 = rows.len();
    }
    let dims: Dims = all_dims
        .iter()
        .zip(picks)
        .filter(|(_, p)| p.is_none())
        .map(|(d, _)| d.clone())
        .collect();
    let count = dims
        .iter()
        .try_fold(1u64, |acc, (_, n)| acc.checked_mul(*n as u64))
        .unwrap_or(u64::MAX);
    // The reader decodes into f64 beside the stored values (up to 8 bytes each): the peak.
    crate::model::volume::check_allocation(
        count.saturating_mul(16),
        &format!("{}: variable '{name}'", path.display()),
    )?;
    let mut raw = if picks.iter().all(Option::is_none) && window.is_none() {
        file.read_variable_as_f64(name)
    } else {
        let selections = picks
            .iter()
            .zip(&ranges)
            .map(|(p, &(start, end))| match p {
                Some(i) => netcdf_reader::NcSliceInfoElem::Index(*i as u64),
                None => netcdf_reader::NcSliceInfoElem::Slice {
                    start,
                    end,
                    step: 1,
                },
            })
            .collect();
        file.read_variable_slice_as_f64(name, &netcdf_reader::NcSliceInfo { selections })
    }
    .map_err(|e| reader_error(path, e))?;
    // NaN stored as data is not a fill value: counted before the CF decoding marks fills.
    let stored_nan = raw.iter().filter(|v| v.is_nan()).count();
    decode_cf(var, &mut raw);
    // Arrays come back in C order: the standard layout hands its buffer over without a copy.
    let data: Vec<f64> = if raw.is_standard_layout() {
        raw.into_raw_vec_and_offset().0
    } else {
        raw.iter().copied().collect()
    };
    let expected = dims
        .iter()
        .try_fold(1usize, |acc, (_, n)| acc.checked_mul(*n));
    if expected != Some(data.len()) {
        return Err(Error::format(
            path,
            format!(
                "variable '{name}' holds {} values, its dimensions need {expected:?}",
                data.len()
            ),
        ));
    }
    let attributes: Vec<(String, NcAttribute)> = var
        .attributes()
        .iter()
        .filter_map(|a| convert_attribute(&a.value).map(|v| (a.name.clone(), v)))
        .collect();
    let text = |key: &str| {
        attributes.iter().find_map(|(n, v)| match v {
            NcAttribute::Text(s) if n == key => Some(s.clone()),
            _ => None,
        })
    };
    Ok(NcVariable {
        name: name.to_string(),
        units: text("units"),
        long_name: text("long_name"),
        dims,
        data,
        attributes,
        stored_nan,
    })
}

/// The paths of every group below the root of an open file (`/PRODUCT`, `/PRODUCT/SUPPORT`),
/// each with its number of variables: NetCDF-4 files of satellite products keep their data
/// there, and hdrvis reads the root group's variables only.
fn group_paths(file: &NcFile) -> Vec<String> {
    let Ok(root) = file.root_group() else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut pending: Vec<(String, &netcdf_reader::NcGroup)> = root
        .groups
        .iter()
        .map(|g| (format!("/{}", g.name), g))
        .collect();
    while let Some((at, group)) = pending.pop() {
        let n = group.variables.len();
        out.push(format!(
            "{at} ({n} variable{})",
            if n == 1 { "" } else { "s" }
        ));
        pending.extend(group.groups.iter().map(|g| (format!("{at}/{}", g.name), g)));
    }
    out.sort();
    out
}

/// What a "no such variable" error adds when the file has groups: that their variables are not
/// read yet; empty without groups.
fn group_note(groups: &[String]) -> String {
    if groups.is_empty() {
        return String::new();
    }
    format!(
        "; variables in groups ({}) are not read yet, only the root group's",
        groups.join(", ")
    )
}

/// [`group_paths`] of the file at `path`.
pub(crate) fn groups(path: &Path) -> Result<Vec<String>> {
    Ok(group_paths(&open(path)?))
}

/// A "no such variable" or "no data array" error with [`group_note`] added: a name the root
/// group lacks may be a group's.
pub(crate) fn with_group_note(e: Error) -> Error {
    match e {
        Error::Format { path, msg } if msg.starts_with("no ") => {
            let note = groups(&path).map_or(String::new(), |g| group_note(&g));
            Error::Format {
                msg: format!("{msg}{note}"),
                path,
            }
        }
        other => other,
    }
}

/// Variable `name` of an open file, which must be numeric; a name the file lacks gives an error
/// that lists the variables it has.
fn numeric_variable<'f>(
    path: &Path,
    file: &'f NcFile,
    name: &str,
) -> Result<&'f netcdf_reader::NcVariable> {
    let vars = file.variables().map_err(|e| reader_error(path, e))?;
    let Some(var) = vars.iter().find(|v| v.name() == name) else {
        let available: Vec<&str> = vars.iter().map(|v| v.name()).collect();
        return Err(Error::format(
            path,
            format!(
                "no variable '{name}'; the file has: {}{}",
                if available.is_empty() {
                    "no variables".to_string()
                } else {
                    available.join(", ")
                },
                group_note(&group_paths(file))
            ),
        ));
    };
    if matches!(
        var.dtype(),
        netcdf_reader::NcType::Char | netcdf_reader::NcType::String
    ) {
        return Err(Error::format(
            path,
            format!("variable '{name}' holds strings; expected numbers"),
        ));
    }
    if !var.dtype().is_primitive() {
        return Err(Error::format(
            path,
            format!(
                "variable '{name}' has type {:?}; only numeric variables can be read",
                var.dtype()
            ),
        ));
    }
    Ok(var)
}

/// Variable `name` as its stored 32-bit integers ([`Variables::integers`]), where it is an `int`
/// variable that CF decoding would only mask.
///
/// [`Variables::integers`]: crate::datasets::readers::variables::Variables::integers
pub(crate) fn read_integers(
    path: &Path,
    name: &str,
) -> Result<Option<crate::datasets::readers::variables::Integers>> {
    let file = open(path)?;
    let var = numeric_variable(path, &file, name)?;
    if !matches!(var.dtype(), netcdf_reader::NcType::Int) {
        return Ok(None);
    }
    // The CF decoding's own fill and missing values (netCDF's default fill without _FillValue).
    let Some(masks) = decoding_of(var).masks_only() else {
        return Ok(None);
    };
    let missing = masks.into_iter().map(|v| v as i32).collect();
    let values = file
        .read_variable::<i32>(name)
        .map_err(|e| reader_error(path, e))?;
    let values = if values.is_standard_layout() {
        values.into_raw_vec_and_offset().0
    } else {
        values.iter().copied().collect()
    };
    Ok(Some(crate::datasets::readers::variables::Integers {
        values,
        missing,
    }))
}

/// A hyperslab of variable `name` of an open file, CF-decoded as [`read_variable`] decodes, in C
/// order.
pub(crate) fn read_slice(
    file: &NcFile,
    name: &str,
    selection: &netcdf_reader::NcSliceInfo,
) -> std::result::Result<Vec<f64>, netcdf_reader::Error> {
    let var = file.variable(name)?;
    let mut raw = file.read_variable_slice_as_f64(name, selection)?;
    decode_cf(var, &mut raw);
    Ok(raw.iter().copied().collect())
}

/// The CF decoding of a variable's values, in place (`conventions::cf_decode`, as for every
/// format with attributes).
fn decode_cf(var: &netcdf_reader::NcVariable, values: &mut ndarray::ArrayD<f64>) {
    let decoding = decoding_of(var);
    values.mapv_inplace(|v| decoding.value(v));
}

/// How a variable's stored values are CF-decoded (`conventions::cf_decode`).
fn decoding_of(
    var: &netcdf_reader::NcVariable,
) -> crate::datasets::conventions::cf_decode::CfDecoding {
    use crate::datasets::conventions::cf_decode::{CfDecoding, Stored};
    use netcdf_reader::NcType;
    let stored = match var.dtype() {
        NcType::Float => Stored::Float32,
        NcType::Double => Stored::Float64,
        NcType::Byte => Stored::Int {
            bits: 8,
            unsigned: false,
        },
        NcType::UByte => Stored::Int {
            bits: 8,
            unsigned: true,
        },
        NcType::Short => Stored::Int {
            bits: 16,
            unsigned: false,
        },
        NcType::UShort => Stored::Int {
            bits: 16,
            unsigned: true,
        },
        NcType::Int => Stored::Int {
            bits: 32,
            unsigned: false,
        },
        NcType::UInt => Stored::Int {
            bits: 32,
            unsigned: true,
        },
        NcType::Int64 => Stored::Int {
            bits: 64,
            unsigned: false,
        },
        NcType::UInt64 => Stored::Int {
            bits: 64,
            unsigned: true,
        },
        _ => Stored::Other,
    };
    let attributes: Vec<(String, NcAttribute)> = var
        .attributes()
        .iter()
        .filter_map(|a| convert_attribute(&a.value).map(|v| (a.name.clone(), v)))
        .collect();
    CfDecoding::of(&attributes, stored)
}

/// The variables that other variables name as their auxiliary coordinates, bounds, grid
/// mappings, ancillary variables, climatology bounds or cell measures (CF 1.11 sections 5, 7.1,
/// 7.2, 7.4, 3.4), the grid-mapping variables themselves, and a UGRID mesh's topology variable
/// with the coordinates and connectivity it names.
pub(crate) fn auxiliary_names(vars: &[netcdf_reader::NcVariable]) -> Vec<String> {
    let mut names = Vec::new();
    for v in vars {
        let topology = v
            .attribute("cf_role")
            .and_then(|a| a.value.as_string())
            .is_some_and(|r| r.trim() == "mesh_topology");
        if v.attribute("grid_mapping_name").is_some() || topology {
            names.push(v.name().to_string());
        }
        for key in [
            "coordinates",
            "bounds",
            "node_coordinates",
            "face_node_connectivity",
            "face_coordinates",
            "edge_node_connectivity",
            "face_edge_connectivity",
            "face_face_connectivity",
            "edge_coordinates",
            "grid_mapping",
            "ancillary_variables",
            "climatology",
            "cell_measures",
        ] {
            let Some(text) = v.attribute(key).and_then(|a| a.value.as_string()) else {
                continue;
            };
            // `grid_mapping` and `cell_measures` may read "crs: lat lon" or "area: cell_area":
            // the words ending in ':' are a mapping's name or a measure, the others variables.
            for word in text.split_whitespace() {
                let name = match (key, word.strip_suffix(':')) {
                    ("cell_measures", Some(_)) => continue,
                    (_, Some(name)) => name,
                    (_, None) => word,
                };
                names.push(name.to_string());
            }
        }
    }
    names
}

/// The coordinate variable of a dimension (a 1-D variable named like it), CF-decoded, or `None`
/// when the dimension has no coordinate variable; an unknown dimension is an error listing the
/// file's. Its values are as stored: `cf::read_coordinate` unwraps longitudes and checks that
/// coordinates are monotonic.
pub(crate) fn coordinate_variable(path: &Path, dim_name: &str) -> Result<Option<NcVariable>> {
    let file = open(path)?;
    let dims = file.dimensions().map_err(|e| reader_error(path, e))?;
    if !dims.iter().any(|d| d.name == dim_name) {
        let names: Vec<&str> = dims.iter().map(|d| d.name.as_str()).collect();
        return Err(Error::format(
            path,
            format!(
                "no dimension '{dim_name}'; the file has: {}",
                names.join(", ")
            ),
        ));
    }
    let vars = file.variables().map_err(|e| reader_error(path, e))?;
    let is_coordinate = |v: &&netcdf_reader::NcVariable| {
        v.name() == dim_name && v.dimensions().len() == 1 && v.dimensions()[0].name == dim_name
    };
    if !vars.iter().any(|v| is_coordinate(&v)) {
        return Ok(None);
    }
    drop(file);
    read_variable(path, dim_name).map(Some)
}

/// Opens a NetCDF file for reading. Every read is a positioned read through the reader's
/// `FileStorage`, never a memory map (which `NcFile::open` makes of a classic file): a file
/// truncated while it is read is then an error instead of a SIGBUS that kills the process.
pub(crate) fn open(path: &Path) -> Result<NcFile> {
    open_noting(path).map(|(file, _)| file)
}

/// [`open`], and why part of a NetCDF-4 file's metadata was skipped: where the strict reading
/// fails on one object (an attribute that is not UTF-8, a dataset in a committed datatype without
/// NetCDF's dimension list), the file is read again leniently, which drops that attribute or
/// places that dataset by its sizes, so the other variables still read.
pub(crate) fn open_noting(path: &Path) -> Result<(NcFile, Option<String>)> {
    let strict = open_mode(path, netcdf_reader::NcMetadataMode::Strict)?;
    use netcdf_reader::NcFormat;
    if matches!(
        strict.format(),
        NcFormat::Classic | NcFormat::Offset64 | NcFormat::Cdf5
    ) {
        return Ok((strict, None));
    }
    let Err(why) = strict.root_group() else {
        return Ok((strict, None));
    };
    let why = why.to_string().replace(['\n', '\r'], " ");
    let lenient = open_mode(path, netcdf_reader::NcMetadataMode::Lossy)?;
    lenient.root_group().map_err(|e| reader_error(path, e))?;
    Ok((lenient, Some(why)))
}

fn open_mode(path: &Path, mode: netcdf_reader::NcMetadataMode) -> Result<NcFile> {
    // Distinguish "cannot open" (an I/O error) from "not a valid NetCDF file" (a format error).
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    check_hdf5_length(path, &mut file)?;
    let storage = netcdf_reader::FileStorage::from_file(file)
        .map_err(|e| Error::format(path, format!("not a readable NetCDF file: {e}")))?;
    let options = netcdf_reader::NcOpenOptions {
        filter_registry: Some(super::hdf5::filters()),
        metadata_mode: mode,
        ..Default::default()
    };
    match NcFile::from_storage_with_options(std::sync::Arc::new(storage), options) {
        Err(netcdf_reader::Error::InvalidData(msg))
            if msg.starts_with("classic attribute claims") =>
        {
            open_long_classic_header(path)
                .map_err(|_| reader_error(path, netcdf_reader::Error::InvalidData(msg)))
        }
        other => other.map_err(|e| reader_error(path, e)),
    }
}

/// A classic file whose header outgrows the reader's first 64 KiB read (long `history` or
/// comment attributes, common in old archives): netcdf-reader 0.12 grows that read only when
/// the header's parse runs out of bytes, not when an attribute's length reaches past its end,
/// which it reports as invalid data. netCDF-C reads such files, so they are opened from a memory
/// map of the whole file, which the reader parses at once; only this case gives up the
/// positioned reads [`open`] prefers.
fn open_long_classic_header(path: &Path) -> std::result::Result<NcFile, netcdf_reader::Error> {
    let file = NcFile::open(path)?;
    use netcdf_reader::NcFormat;
    match file.format() {
        NcFormat::Classic | NcFormat::Offset64 | NcFormat::Cdf5 => Ok(file),
        _ => Err(netcdf_reader::Error::InvalidData("not classic".into())),
    }
}

/// A truncated NetCDF-4 file can still decode when the lost tail held other objects, so, as the
/// HDF5 library does, compare the end-of-file address its superblock records with the file's
/// size. Classic files need no such check: their header fixes every variable's extent, which the
/// reader checks against the file size.
fn check_hdf5_length(path: &Path, file: &mut std::fs::File) -> Result<()> {
    use std::io::{Read, Seek, SeekFrom};
    const SIGNATURE: [u8; 8] = [0x89, b'H', b'D', b'F', b'\r', b'\n', 0x1a, b'\n'];
    let len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    // The superblock sits at 0 or, after a user block, at 512, 1024, 2048, ... (HDF5 file format
    // specification, section II.A).
    let mut at = 0u64;
    while at + 64 <= len {
        let mut head = [0u8; 64];
        file.seek(SeekFrom::Start(at))
            .map_err(|e| Error::io(path, e))?;
        file.read_exact(&mut head).map_err(|e| Error::io(path, e))?;
        if head[..8] == SIGNATURE {
            let version = head[8];
            let (offset_size, base_at) = match version {
                0 => (head[13] as usize, 24),
                1 => (head[13] as usize, 28),
                2 | 3 => (head[9] as usize, 12),
                _ => return Ok(()), // unknown layout: leave the verdict to the reader
            };
            if !matches!(offset_size, 2 | 4 | 8) {
                return Err(Error::format(
                    path,
                    format!("HDF5 superblock has offset size {offset_size}"),
                ));
            }
            let field = |i: usize| {
                let start = base_at + i * offset_size;
                head[start..start + offset_size]
                    .iter()
                    .rev()
                    .fold(0u64, |acc, &b| (acc << 8) | u64::from(b))
            };
            let base = field(0);
            // Fields after the base address: v0/1 free-space info then EOF; v2/3 extension then EOF.
            let eof = base.saturating_add(field(2));
            if eof > len {
                return Err(Error::format(
                    path,
                    format!("truncated NetCDF-4/HDF5 file: {len} bytes, its superblock says {eof}"),
                ));
            }
            return Ok(());
        }
        at = if at == 0 { 512 } else { at * 2 };
    }
    Ok(())
}

fn reader_error(path: &Path, e: netcdf_reader::Error) -> Error {
    let msg = e.to_string().replace(['\n', '\r'], " ");
    // The reader lists a group's objects all at once, so one HDF5 virtual dataset (layout class
    // 3, which it does not decode) stops every variable of the file; netCDF-C reads them.
    if let Some(name) = msg
        .split_once("child '")
        .and_then(|(_, rest)| rest.split_once('\''))
        .map(|(name, _)| name)
        .filter(|_| msg.contains("unsupported layout class 3"))
    {
        return Error::format(
            path,
            format!(
                "dataset '{name}' is an HDF5 virtual dataset, which hdrvis's NetCDF-4 reader (the netcdf-reader crate) cannot pass over, so none of the file's variables read; rewrite the file with netCDF's `nccopy IN OUT`, which stores it as a plain variable"
            ),
        );
    }
    Error::format(path, format!("not a readable NetCDF file: {msg}"))
}

fn dims_of(path: &Path, var: &netcdf_reader::NcVariable) -> Result<Dims> {
    var.dimensions()
        .iter()
        .map(|d| {
            let n = usize::try_from(d.size).map_err(|_| {
                Error::format(
                    path,
                    format!("dimension '{}' size {} is too large", d.name, d.size),
                )
            })?;
            Ok((d.name.clone(), n))
        })
        .collect()
}

fn convert_attribute(value: &NcAttrValue) -> Option<NcAttribute> {
    value
        .as_string()
        .map(NcAttribute::Text)
        .or_else(|| value.as_f64_vec().map(NcAttribute::Numbers))
}

pub(crate) fn check_monotonic(values: &[f64]) -> std::result::Result<(), String> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "value {i} is {}; coordinates must be finite",
            values[i]
        ));
    }
    let increasing = values.windows(2).all(|w| w[1] > w[0]);
    let decreasing = values.windows(2).all(|w| w[1] < w[0]);
    if increasing || decreasing {
        return Ok(());
    }
    if let Some(i) = values.windows(2).position(|w| w[1] == w[0]) {
        return Err(format!(
            "has duplicate coordinates at {i} and {} ({}); expected strictly monotonic values",
            i + 1,
            values[i]
        ));
    }
    Err("is not strictly monotonic".to_string())
}

#[cfg(test)]
mod tests;
