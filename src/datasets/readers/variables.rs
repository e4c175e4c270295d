//! The data model under the CF conventions: variables with named dimensions and attributes, read
//! whole or by hyperslab, as NetCDF holds them, CF describes them and xarray's `Dataset` presents
//! them. A reader whose format has this model gives a [`Variables`] ([`super::Reader::variables`]:
//! NetCDF, and HDF5 laid out as NetCDF-4, which the registry sends there). The conventions
//! (`conventions/`: coordinate roles, calendars, grid mappings, selection, placement) read
//! through the functions here, which ask the file's reader, so a format with named dimensions
//! gets all of CF by implementing this trait; one without them is refused in one line.

use std::ops::Range;
use std::path::Path;

use super::Format;
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

/// The dimensions of `name` in what [`list_variables`] gave; none for a name it lacks.
pub(crate) fn dims_in(listed: &[(String, Dims)], name: &str) -> Dims {
    listed
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, d)| d.clone())
        .unwrap_or_default()
}

/// Variables with named dimensions and attributes, in one file of a format that has them.
pub(crate) trait Variables: Sync {
    /// Every variable with its dimensions, in file order.
    fn list(&self, path: &Path) -> Result<Vec<(String, Dims)>>;

    /// A variable's attributes, in file order; a name the file lacks is an error.
    fn attributes(&self, path: &Path, name: &str) -> Result<Vec<(String, NcAttribute)>>;

    /// The file's global attributes.
    fn global_attributes(&self, path: &Path) -> Result<Vec<(String, NcAttribute)>>;

    /// Variable `name` CF-decoded (`conventions::cf_decode`): `picks` (one per dimension, or
    /// empty for all) takes index `i` of a dimension or all of it; `window` the rows of one
    /// kept dimension.
    fn read(
        &self,
        path: &Path,
        name: &str,
        picks: &[Option<usize>],
        window: Option<(usize, Range<usize>)>,
    ) -> Result<NcVariable>;

    /// The coordinate variable of dimension `dim` (1-D, named like it), decoded; `None`
    /// without one; an unknown dimension is an error. By default found among [`Variables::list`]
    /// and read whole.
    fn coordinate(&self, path: &Path, dim: &str) -> Result<Option<NcVariable>> {
        let listed = self.list(path)?;
        if !listed
            .iter()
            .any(|(_, dims)| dims.iter().any(|(d, _)| d == dim))
        {
            return Err(Error::invalid(
                "dimension",
                format!("'{dim}' is not a dimension of {}", path.display()),
            ));
        }
        let is_coordinate = |(name, dims): &(String, Dims)| name == dim && dims.len() == 1;
        match listed.iter().any(is_coordinate) {
            true => self.read(path, dim, &[], None).map(Some),
            false => Ok(None),
        }
    }

    /// Where a longitude dimension stored in numeric order across the seam begins when read in
    /// geographic order (every variable on it is read so); `None` for any other.
    fn rolled_by(&self, _path: &Path, _dim: &str) -> Result<Option<usize>> {
        Ok(None)
    }

    /// Variable `name` whole as its stored 32-bit integers, where it is one that CF decoding
    /// would only mask (no scale, offset, `_Unsigned` or valid range): the values (C order) and
    /// the ones that mark missing entries. `None` where it is not, or the format has no such
    /// read: then [`Variables::read`] it. Meshes' connectivity is tens of millions of these,
    /// and a detour through f64 costs more than the read.
    fn integers(&self, _path: &Path, _name: &str) -> Result<Option<Integers>> {
        Ok(None)
    }
}

/// [`Variables::integers`]' answer.
pub(crate) struct Integers {
    pub values: Vec<i32>,
    /// The stored values that mean "missing": `_FillValue` (netCDF's default fill without one)
    /// and `missing_value`.
    pub missing: Vec<i32>,
}

/// [`Variables::integers`] of `path`'s variable `name`.
pub(crate) fn read_integers(path: &Path, name: &str) -> Result<Option<Integers>> {
    of(path)?.integers(path, name)
}

/// The indices a read keeps of each of `dims`: a pick, the window's rows, or all (for readers
/// that select in memory: GRIB, Zarr).
pub(crate) fn kept(
    dims: &Dims,
    picks: &[Option<usize>],
    window: &Option<(usize, std::ops::Range<usize>)>,
) -> Result<Vec<Vec<usize>>> {
    dims.iter()
        .enumerate()
        .map(
            |(d, (name, n))| match (picks.get(d).copied().flatten(), window) {
                (Some(i), _) if i < *n => Ok(vec![i]),
                (Some(i), _) => Err(Error::invalid(
                    name.clone(),
                    format!("index {i} is outside 0..{n}"),
                )),
                (None, Some((w, rows))) if *w == d => {
                    Ok(rows.clone().filter(|&r| r < *n).collect())
                }
                _ => Ok((0..*n).collect()),
            },
        )
        .collect()
}

/// Variable `name` as read by a reader that selects in memory: `data` at the indices `sel` keeps
/// of `dims` (see [`kept`]), the dimensions `picks` fixed left out, units and long name from its
/// `attributes`.
pub(crate) fn picked_variable(
    name: &str,
    dims: &Dims,
    (sel, picks): (&[Vec<usize>], &[Option<usize>]),
    data: Vec<f64>,
    attributes: &[(String, NcAttribute)],
) -> NcVariable {
    let text = |key: &str| {
        attributes.iter().find_map(|(k, v)| match v {
            NcAttribute::Text(t) if k == key => Some(t.clone()),
            _ => None,
        })
    };
    NcVariable {
        name: name.to_string(),
        dims: dims
            .iter()
            .zip(sel)
            .enumerate()
            .filter(|(d, _)| picks.get(*d).copied().flatten().is_none())
            .map(|(_, ((dim, _), keep))| (dim.clone(), keep.len()))
            .collect(),
        data,
        units: text("units"),
        long_name: text("long_name"),
        attributes: attributes.to_vec(),
        stored_nan: 0,
    }
}

/// The arrays of a format whose variables say their roles only through `coordinates`
/// attributes (GRIB, Zarr): coordinate variables (1-D, named like their dimension), auxiliary
/// ones (named in a `coordinates` attribute) and data, with each one's stored type from `dtype`.
pub(crate) fn listing(
    vars: &dyn Variables,
    path: &Path,
    dtype: &dyn Fn(&str) -> String,
) -> Result<Vec<crate::datasets::ArrayListing>> {
    let listed = vars.list(path)?;
    let mut auxiliary: Vec<String> = Vec::new();
    for (name, _) in &listed {
        for (key, value) in vars.attributes(path, name)? {
            if let (true, NcAttribute::Text(t)) = (key == "coordinates", value) {
                auxiliary.extend(t.split_whitespace().map(str::to_string));
            }
        }
    }
    Ok(listed
        .into_iter()
        .map(|(name, dims)| crate::datasets::ArrayListing {
            shape: dims.iter().map(|(_, n)| *n).collect(),
            dtype: dtype(&name),
            is_coordinate: dims.len() == 1 && dims[0].0 == name,
            is_auxiliary: auxiliary.contains(&name),
            unreadable: None,
            name,
        })
        .collect())
}

/// The variables of the file at `path`, by its reader.
fn of(path: &Path) -> Result<&'static dyn Variables> {
    let format = Format::of(path)?;
    format.reader().variables().ok_or_else(|| {
        Error::format(
            path,
            format!(
                "is a {} file, which has no named dimensions; CF coordinates and selection by dimension need a NetCDF file",
                format.name()
            ),
        )
    })
}

pub(crate) fn list_variables(path: &Path) -> Result<Vec<(String, Dims)>> {
    of(path)?.list(path)
}

pub(crate) fn variable_attributes(path: &Path, name: &str) -> Result<Vec<(String, NcAttribute)>> {
    of(path)?.attributes(path, name)
}

pub(crate) fn global_attributes(path: &Path) -> Result<Vec<(String, NcAttribute)>> {
    of(path)?.global_attributes(path)
}

/// Variable `name`, whole.
pub(crate) fn read_variable(path: &Path, name: &str) -> Result<NcVariable> {
    of(path)?.read(path, name, &[], None)
}

/// Variable `name` with the dimensions `picks` fixes.
pub(crate) fn read_variable_picked(
    path: &Path,
    name: &str,
    picks: &[Option<usize>],
) -> Result<NcVariable> {
    of(path)?.read(path, name, picks, None)
}

pub(crate) fn coordinate_variable(path: &Path, dim: &str) -> Result<Option<NcVariable>> {
    of(path)?.coordinate(path, dim)
}

pub(crate) fn rolled_by(path: &Path, dim: &str) -> Result<Option<usize>> {
    of(path)?.rolled_by(path, dim)
}
