//! NetCDF grids in and out. Reading covers classic (CDF-1/2/5) and NetCDF-4 (HDF5) files through
//! the pure-Rust `netcdf-reader` crate, applying the CF rules a viewer needs: values equal to
//! `_FillValue` or `missing_value` (or outside `valid_range`) become NaN, then packed integers are
//! unpacked as `stored * scale_factor + add_offset`. Writing produces CF-1.8 classic NetCDF through
//! `netcdf-writer`, into a temporary file that is renamed into place, so a failed write never
//! leaves a half-written file behind. Only the root group of a NetCDF-4 file is read.

use std::io::Write;
use std::path::Path;

use netcdf_reader::{NcAttrValue, NcFile};
use netcdf_writer::{NcFileBuilder, NcWriteOptions};

use crate::error::{Error, Result};

/// One attribute value, reduced to what CF metadata needs.
#[derive(Debug, Clone, PartialEq)]
pub enum NcAttribute {
    Text(String),
    Numbers(Vec<f64>),
}

/// Dimensions as `(name, length)`, slowest first.
pub(crate) type Dims = Vec<(String, usize)>;

/// A variable read with CF decoding applied: `data` is in physical units, C order (last dimension
/// fastest), with fill and missing values as NaN.
#[derive(Debug, Clone)]
pub struct NcVariable {
    pub name: String,
    pub dims: Dims,
    pub data: Vec<f64>,
    pub units: Option<String>,
    pub long_name: Option<String>,
    /// Every attribute of the variable in file order, including the CF ones already applied.
    pub attributes: Vec<(String, NcAttribute)>,
    /// Values stored as NaN (not fills: those are NaN in `data` too, but not counted here).
    pub stored_nan: usize,
}

impl NcVariable {
    pub fn attribute(&self, name: &str) -> Option<&NcAttribute> {
        self.attributes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
    }
}

/// Sample types `write_grid` stores as they are (NC_FLOAT or NC_DOUBLE).
pub trait GridValue: netcdf_writer::NcFillValueType + sealed::Sealed {
    /// NaN of this type, declared as `_FillValue` so NaN cells read back as missing everywhere.
    const NAN: Self;
}
impl GridValue for f32 {
    const NAN: Self = f32::NAN;
}
impl GridValue for f64 {
    const NAN: Self = f64::NAN;
}
mod sealed {
    pub trait Sealed {}
    impl Sealed for f32 {}
    impl Sealed for f64 {}
}

/// A data variable to write: `(name, values in C order, units, long_name)`.
pub(crate) type GridVar<'a, T> = (&'a str, &'a [T], &'a str, &'a str);
/// A coordinate axis to write: `(dimension name, coordinate values, units)`.
pub(crate) type GridCoord<'a> = (&'a str, &'a [f64], &'a str);
/// An auxiliary coordinate along one dimension, not necessarily monotonic (the latitudes of a
/// section's columns): `(name, index of its dimension in the coordinates, values, units)`.
pub(crate) type AuxCoord<'a> = (&'a str, usize, &'a [f64], &'a str);

/// The dimensions of `name` in what [`list_variables`] gave; none for a name it lacks.
pub(crate) fn dims_in(listed: &[(String, Dims)], name: &str) -> Dims {
    listed
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, d)| d.clone())
        .unwrap_or_default()
}

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
                "no variable '{name}'; the file has: {}",
                if available.is_empty() {
                    "no variables".to_string()
                } else {
                    available.join(", ")
                }
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

/// The CF decoding of a variable's values, in place, in this order: signedness (`_Unsigned`),
/// masking, unpacking (`scale_factor`, `add_offset`). Masking is the reader's (`_FillValue`,
/// `missing_value`, `valid_*`), with netCDF's default fill value of the stored type standing in
/// for an absent `_FillValue`: unwritten parts of a file hold it, and netCDF4-python and ncdump
/// treat it as missing.
fn decode_cf(var: &netcdf_reader::NcVariable, values: &mut ndarray::ArrayD<f64>) {
    use netcdf_reader::masked::MaskParams;
    use netcdf_reader::unpack::{SignParams, UnpackParams};
    if let Some(sign) = SignParams::from_variable(var) {
        sign.apply(values);
    }
    let mut mask = MaskParams::from_variable(var);
    if var.attribute("_FillValue").is_none() {
        if let Some(fill) = default_fill(var) {
            let m = mask.get_or_insert(MaskParams {
                fill_value: None,
                missing_values: Vec::new(),
                valid_min: None,
                valid_max: None,
            });
            m.fill_value = Some(fill);
        }
    }
    if let Some(mask) = mask {
        mask.apply(values);
    }
    if let Some(unpack) = UnpackParams::from_variable(var) {
        unpack.apply(values);
    }
}

/// netCDF's default fill value (netcdf.h's `NC_FILL_*`) of the type a variable's values have
/// once its `_Unsigned` attribute is applied, as f64 (the int64 ones rounded, as every value of
/// those types is when read as f64).
fn default_fill(var: &netcdf_reader::NcVariable) -> Option<f64> {
    use netcdf_reader::NcType;
    let unsigned = var
        .attribute("_Unsigned")
        .and_then(|a| a.value.as_string())
        .and_then(|s| match s.trim().to_ascii_lowercase().as_str() {
            "true" => Some(true),
            "false" => Some(false),
            _ => None,
        });
    let as_unsigned = |signed: bool| unsigned.unwrap_or(!signed);
    Some(match var.dtype() {
        NcType::Float | NcType::Double => 9.969_209_968_386_869e36,
        NcType::Byte | NcType::UByte if as_unsigned(matches!(var.dtype(), NcType::Byte)) => 255.0,
        NcType::Byte | NcType::UByte => -127.0,
        NcType::Short | NcType::UShort if as_unsigned(matches!(var.dtype(), NcType::Short)) => {
            65535.0
        }
        NcType::Short | NcType::UShort => -32767.0,
        NcType::Int | NcType::UInt if as_unsigned(matches!(var.dtype(), NcType::Int)) => {
            4_294_967_295.0
        }
        NcType::Int | NcType::UInt => -2_147_483_647.0,
        NcType::Int64 | NcType::UInt64 if as_unsigned(matches!(var.dtype(), NcType::Int64)) => {
            18_446_744_073_709_551_614_u64 as f64
        }
        NcType::Int64 | NcType::UInt64 => -9_223_372_036_854_775_806_i64 as f64,
        _ => return None,
    })
}

/// The variables that other variables name as their auxiliary coordinates, bounds, grid
/// mappings, ancillary variables, climatology bounds or cell measures (CF 1.11 sections 5, 7.1,
/// 7.2, 7.4, 3.4), and the grid-mapping variables themselves.
pub(crate) fn auxiliary_names(vars: &[netcdf_reader::NcVariable]) -> Vec<String> {
    let mut names = Vec::new();
    for v in vars {
        if v.attribute("grid_mapping_name").is_some() {
            names.push(v.name().to_string());
        }
        for key in [
            "coordinates",
            "bounds",
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

/// Writes a CF-1.8 classic NetCDF file (64-bit offset, or CDF-5 when a variable is too large for
/// it). `coords` name the dimensions, slowest first (e.g. `lat`, `lon`, or `z`, `y`, `x`); every
/// variable in `vars` spans all of them, in C order. NaN values are declared missing through a
/// NaN `_FillValue`, which is what xarray writes too.
pub fn write_grid<T: GridValue>(
    path: impl AsRef<Path>,
    coords: &[GridCoord<'_>],
    vars: &[GridVar<'_, T>],
    global_attrs: &[(&str, &str)],
) -> Result<()> {
    let no_aux = GridAux {
        aux: &[],
        coord_attrs: &[],
    };
    write_grid_with_aux(path.as_ref(), coords, &no_aux, vars, global_attrs)
}

/// What a grid file carries besides its axes and data: auxiliary coordinates, and further
/// attributes of the axes' coordinate variables as `(dimension name, key, value)` (a depth
/// axis's `positive: "down"`).
pub(crate) struct GridAux<'a> {
    pub aux: &'a [AuxCoord<'a>],
    pub coord_attrs: &'a [(&'a str, &'a str, &'a str)],
}

/// [`write_grid`] with auxiliary coordinates, each a 1-D variable on one of the dimensions that
/// every data variable names in its CF `coordinates` attribute (so xarray reads them as
/// coordinates), and further attributes of the coordinate variables.
pub(crate) fn write_grid_with_aux<T: GridValue>(
    path: &Path,
    coords: &[GridCoord<'_>],
    extra: &GridAux<'_>,
    vars: &[GridVar<'_, T>],
    global_attrs: &[(&str, &str)],
) -> Result<()> {
    let aux = extra.aux;
    if coords.is_empty() {
        return Err(Error::invalid(
            "coords",
            "at least one coordinate axis is required",
        ));
    }
    let mut builder = NcFileBuilder::new();
    let mut dim_ids = Vec::with_capacity(coords.len());
    for &(name, values, units) in coords {
        check_name("coords", name)?;
        if values.is_empty() {
            // A zero length would declare the classic format's unlimited dimension.
            return Err(Error::invalid(
                format!("coords.{name}"),
                "needs at least one value",
            ));
        }
        check_monotonic(values)
            .map_err(|msg| Error::invalid(format!("coords.{name}"), format!("coordinate {msg}")))?;
        let dim = builder
            .add_dimension(name, values.len() as u64)
            .map_err(|e| Error::invalid(format!("coords.{name}"), e.to_string()))?;
        let var = builder
            .add_variable::<f64>(name, &[dim])
            .map_err(|e| Error::invalid(format!("coords.{name}"), e.to_string()))?;
        for (key, value) in coordinate_attributes(name, units) {
            add_text_attr(&mut builder, var, key, &value)?;
        }
        for (_, key, value) in extra.coord_attrs.iter().filter(|a| a.0 == name) {
            add_text_attr(&mut builder, var, key, value)?;
        }
        builder
            .write_variable(var, values)
            .map_err(|e| Error::invalid(format!("coords.{name}"), e.to_string()))?;
        dim_ids.push(dim);
    }
    add_aux_coords(&mut builder, coords, aux, &dim_ids)?;
    let aux_names: Vec<&str> = aux.iter().map(|a| a.0).collect();
    let cells = coords
        .iter()
        .try_fold(1usize, |acc, c| acc.checked_mul(c.1.len()))
        .ok_or_else(|| {
            Error::invalid("coords", "the grid has more cells than memory can address")
        })?;
    for &(name, values, units, long_name) in vars {
        check_name("vars", name)?;
        if values.len() != cells {
            return Err(Error::invalid(
                format!("vars.{name}"),
                format!("has {} values; the coordinates need {cells}", values.len()),
            ));
        }
        let var = builder
            .add_variable::<T>(name, &dim_ids)
            .map_err(|e| Error::invalid(format!("vars.{name}"), e.to_string()))?;
        builder
            .set_variable_fill_value(var, T::NAN)
            .map_err(|e| Error::invalid(format!("vars.{name}"), e.to_string()))?;
        if !units.is_empty() {
            add_text_attr(&mut builder, var, "units", units)?;
        }
        if !long_name.is_empty() {
            add_text_attr(&mut builder, var, "long_name", long_name)?;
        }
        if !aux_names.is_empty() {
            add_text_attr(&mut builder, var, "coordinates", &aux_names.join(" "))?;
        }
        builder
            .write_variable(var, values)
            .map_err(|e| Error::invalid(format!("vars.{name}"), e.to_string()))?;
    }
    let mut has_conventions = false;
    for &(key, value) in global_attrs {
        has_conventions |= key == "Conventions";
        builder
            .add_attribute(key, NcAttrValue::Chars(value.to_string()))
            .map_err(|e| Error::invalid(format!("global_attrs.{key}"), e.to_string()))?;
    }
    if !has_conventions {
        builder
            .add_attribute("Conventions", NcAttrValue::Chars("CF-1.8".into()))
            .map_err(|e| Error::invalid("global_attrs.Conventions", e.to_string()))?;
    }
    write_atomically(path, |out| {
        builder
            .write(out, NcWriteOptions::default())
            .map(|_| ())
            .map_err(|e| match e {
                netcdf_writer::Error::Io(io) => io,
                other => std::io::Error::other(other.to_string()),
            })
    })
}

/// The auxiliary coordinates `aux` as 1-D variables on their dimensions (`dim_ids`, in the order
/// of `coords`), with the CF attributes of their names less the axis, which the dimension's own
/// coordinate carries.
fn add_aux_coords(
    builder: &mut NcFileBuilder,
    coords: &[GridCoord<'_>],
    aux: &[AuxCoord<'_>],
    dim_ids: &[netcdf_writer::DimensionId],
) -> Result<()> {
    for &(name, dim, values, units) in aux {
        check_name("aux", name)?;
        let field = format!("aux.{name}");
        if coords.get(dim).map(|c| c.1.len()) != Some(values.len()) {
            return Err(Error::invalid(
                field,
                "needs one value per node of its dimension",
            ));
        }
        let var = builder
            .add_variable::<f64>(name, &[dim_ids[dim]])
            .map_err(|e| Error::invalid(field.clone(), e.to_string()))?;
        for (key, value) in coordinate_attributes(name, units) {
            if key != "axis" {
                add_text_attr(builder, var, key, &value)?;
            }
        }
        builder
            .write_variable(var, values)
            .map_err(|e| Error::invalid(field, e.to_string()))?;
    }
    Ok(())
}

/// Writes a cell-centred volume of `dims = [nx, ny, nz]` cells as one variable on dimensions
/// (z, y, x), `data` x fastest. The coordinates are the cell centres
/// `origin + (i + 0.5) * spacing`, so `origin` is the volume's minimum corner, as in `vti`.
#[allow(clippy::too_many_arguments)]
pub fn write_volume(
    path: impl AsRef<Path>,
    dims: [usize; 3],
    spacing: [f64; 3],
    origin: [f64; 3],
    length_units: &str,
    var: GridVar<'_, f32>,
    global_attrs: &[(&str, &str)],
) -> Result<()> {
    for (axis, (&n, &d)) in ["x", "y", "z"].iter().zip(dims.iter().zip(&spacing)) {
        if n == 0 {
            return Err(Error::invalid(format!("dims.{axis}"), "must be at least 1"));
        }
        if !(d.is_finite() && d > 0.0) {
            return Err(Error::invalid(
                format!("spacing.{axis}"),
                "must be finite and > 0",
            ));
        }
    }
    let centres = |a: usize| -> Vec<f64> {
        (0..dims[a])
            .map(|i| origin[a] + (i as f64 + 0.5) * spacing[a])
            .collect()
    };
    let (x, y, z) = (centres(0), centres(1), centres(2));
    let coords = [
        ("z", &z[..], length_units),
        ("y", &y[..], length_units),
        ("x", &x[..], length_units),
    ];
    write_grid(path, &coords, &[var], global_attrs)
}

/// [`crate::io::write_atomic`] for writers that speak `std::io` errors (the netCDF and VTK
/// encoders).
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    crate::io::write_atomic(path, |out| write(out).map_err(|e| Error::io(path, e)))
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
    NcFile::from_storage_with_options(std::sync::Arc::new(storage), options)
        .map_err(|e| reader_error(path, e))
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

fn check_name(field: &str, name: &str) -> Result<()> {
    let ok = !name.is_empty()
        && name
            .chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(
            format!("{field}.{name}"),
            "names must start with a letter or '_' and use only letters, digits, '_', '-', '.'",
        ))
    }
}

fn coordinate_attributes(name: &str, units: &str) -> Vec<(&'static str, String)> {
    let mut attrs = Vec::new();
    if !units.is_empty() {
        attrs.push(("units", units.to_string()));
    }
    let (standard_name, axis) = match name {
        "lat" | "latitude" => (Some("latitude"), Some("Y")),
        "lon" | "longitude" => (Some("longitude"), Some("X")),
        "x" => (None, Some("X")),
        "y" => (None, Some("Y")),
        "z" | "depth" | "height" | "radius" => (None, Some("Z")),
        "time" => (Some("time"), Some("T")),
        _ => (None, None),
    };
    if let Some(s) = standard_name {
        attrs.push(("standard_name", s.to_string()));
    }
    if let Some(a) = axis {
        attrs.push(("axis", a.to_string()));
    }
    attrs
}

fn add_text_attr(
    builder: &mut NcFileBuilder,
    var: netcdf_writer::VariableId,
    key: &str,
    value: &str,
) -> Result<()> {
    builder
        .add_variable_attribute(var, key, NcAttrValue::Chars(value.to_string()))
        .map_err(|e| Error::invalid(format!("attribute {key}"), e.to_string()))
}

#[cfg(test)]
mod tests {
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
}
