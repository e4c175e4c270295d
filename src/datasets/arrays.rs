//! Arrays by name across the formats: what a file holds (`list_arrays`: name, shape, on-disk
//! type) and one array read as f64 with its axes and CF metadata (`read_array`, with a
//! selection: `read_array_sel`), for NumPy `.npy`/`.npz`, NetCDF, HDF5 and MintPy, GeoTIFF,
//! NRRD and VTK files; and the one-line errors that list what a file has when a name is wrong.

use super::readers::variables;
use super::{select, Format, Volume};
use crate::error::{Error, Result};
use std::path::Path;

/// Name, shape and on-disk type of one array or variable in a file.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ArrayListing {
    pub name: String,
    pub shape: Vec<usize>,
    pub dtype: String,
    /// A NetCDF coordinate variable (1-D, named like its dimension).
    pub is_coordinate: bool,
    /// A NetCDF variable that describes others rather than being data: named in another
    /// variable's `coordinates`, `bounds`, `grid_mapping`, `ancillary_variables`, `climatology`
    /// or `cell_measures`, or a grid mapping (`grid_mapping_name`).
    pub is_auxiliary: bool,
    /// Why an object the file lists cannot be read (an HDF5 virtual dataset), so that the rest of
    /// the file still reads; `None` for every readable array.
    pub unreadable: Option<String>,
}

impl ArrayListing {
    /// Data a reader may pick by default: numeric, neither a coordinate nor auxiliary.
    pub(crate) fn is_data(&self) -> bool {
        !self.is_coordinate
            && !self.is_auxiliary
            && self.dtype != "char"
            && self.dtype != "string"
            && self.unreadable.is_none()
    }
}

/// One array read in full, values converted to f64 (C order), NaN for missing values.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ArrayData {
    pub name: String,
    /// Dimension names (NetCDF); `dim0`, `dim1`, ... elsewhere.
    pub dims: Vec<String>,
    pub shape: Vec<usize>,
    pub dtype: String,
    pub units: Option<String>,
    pub data: Vec<f64>,
    /// Values the file marks as missing (`_FillValue`, `missing_value`, outside `valid_range`),
    /// already turned into NaN; 0 for formats without such a convention.
    pub fill_count: usize,
    /// The variable's attributes (NetCDF), for the CF metadata that places it in the world.
    pub attributes: Vec<(String, variables::NcAttribute)>,
    /// How each dimension a selection fixed was chosen.
    pub notes: Vec<String>,
}

/// The arrays a file holds: every variable of a NetCDF file, every member of an `.npz`, the one
/// array of `.npy`, `.vti`, `.nhdr`/`.nrrd` files.
pub(crate) fn list_arrays(path: &Path) -> Result<Vec<ArrayListing>> {
    Format::of(path)?.reader().list(path)
}

/// A variable's values as the file stores them, decoded (CF scale, offset and fills applied) but
/// not regridded, flipped or rolled, with its dimensions (name, length) after `sel`: what a
/// library user compares with another reader's array.
pub fn read_values(
    path: &Path,
    var: Option<&str>,
    sel: &select::Selection,
) -> Result<(variables::Dims, Vec<f64>)> {
    let array = read_array_sel(path, var, None, sel)?;
    Ok((
        array.dims.into_iter().zip(array.shape).collect(),
        array.data,
    ))
}

/// Reads one array. `var` picks it by name (an error lists the available ones); without it an
/// `.npz` gives its largest array and a NetCDF file its first numeric variable that is not a
/// coordinate. With `rank`, leading length-1 dimensions are dropped down to that rank and an
/// array of another rank is refused (or, without `var`, skipped).
pub(crate) fn read_array(path: &Path, var: Option<&str>, rank: Option<usize>) -> Result<ArrayData> {
    read_array_sel(path, var, rank, &select::Selection::default())
}

/// [`read_array`] with the dimensions `sel` fixes (NetCDF only), which the array then lacks;
/// without one, a NetCDF time axis of several steps among the array's dimensions is refused
/// when a `rank` is asked for (it would be read as space).
pub(crate) fn read_array_sel(
    path: &Path,
    var: Option<&str>,
    rank: Option<usize>,
    sel: &select::Selection,
) -> Result<ArrayData> {
    let reader = Format::of(path)?.reader();
    let selects = reader.selects(path)?;
    if !selects && !sel.is_empty() {
        return Err(Error::format(
            path,
            "selecting by dimension (index, at) needs a NetCDF file or a MintPy time series",
        ));
    }
    let mut array = reader.read(path, var, rank, sel)?;
    if let Some(r) = rank {
        let kept = squeezed(&array.shape, r).len();
        if kept != r {
            let dims: Vec<String> = array
                .dims
                .iter()
                .zip(&array.shape)
                .map(|(d, n)| format!("{d}={n}"))
                .collect();
            let selected = if sel.is_empty() {
                ""
            } else {
                " after the selection"
            };
            let hint = if kept > r && selects {
                format!("; fix {} more dimension(s) with index or at", kept - r)
            } else {
                String::new()
            };
            return Err(Error::format(
                path,
                format!(
                    "'{}' has shape {:?} ({}){selected}; expected a {r}-D array{hint}",
                    array.name,
                    array.shape,
                    dims.join(", ")
                ),
            ));
        }
        let dropped = array.shape.len() - kept;
        array.shape.drain(..dropped);
        array.dims.drain(..dropped);
    }
    Ok(array)
}

/// Whether an array of `shape` has `rank` dimensions once leading length-1 ones are dropped
/// (any shape fits no rank).
pub(crate) fn fits_rank(shape: &[usize], rank: Option<usize>) -> bool {
    rank.is_none_or(|r| squeezed(shape, r).len() == r)
}

/// "2-D " for rank 2, "" for none: how "no array" errors name what was looked for.
pub(crate) fn rank_name(rank: Option<usize>) -> String {
    rank.map(|r| format!("{r}-D ")).unwrap_or_default()
}

/// The variable a NetCDF file is read for when none is named: of its data variables (not
/// coordinates, not auxiliary) that have every dimension `sel` fixes, the first of `rank` once
/// those are fixed (leading length-1 dimensions dropped), else the first of a higher rank (whose
/// read then says which dimensions are left to fix); without a rank the first of the highest
/// rank.
fn default_netcdf_variable(
    path: &Path,
    listed: &[ArrayListing],
    rank: Option<usize>,
    sel: &select::Selection,
) -> Result<String> {
    let all_dims = variables::list_variables(path)?;
    let dims_of = |name: &str| variables::dims_in(&all_dims, name);
    let candidates: Vec<(&ArrayListing, Vec<usize>)> = listed
        .iter()
        .filter(|a| a.is_data())
        .filter_map(|a| {
            let dims = dims_of(&a.name);
            sel.dims()
                .all(|s| dims.iter().any(|(d, _)| d == s))
                .then(|| {
                    let kept = dims
                        .iter()
                        .filter(|(d, _)| !sel.dims().any(|s| s == d))
                        .map(|(_, n)| *n)
                        .collect();
                    (a, kept)
                })
        })
        .collect();
    let found = match rank {
        Some(r) => candidates
            .iter()
            .find(|(_, kept)| squeezed(kept, r).len() == r)
            .or_else(|| {
                candidates
                    .iter()
                    .find(|(_, kept)| squeezed(kept, r).len() > r)
            }),
        None => candidates.iter().rev().max_by_key(|(_, kept)| kept.len()),
    };
    found
        .map(|(a, _)| a.name.clone())
        .ok_or_else(|| no_array(path, &rank_name(rank), listed))
}

/// [`read_array`] of a NetCDF variable: `var`, else [`default_netcdf_variable`], with the
/// dimensions `sel` fixes; values the file marks as missing are counted.
pub(crate) fn read_netcdf_array(
    path: &Path,
    var: Option<&str>,
    rank: Option<usize>,
    sel: &select::Selection,
) -> Result<ArrayData> {
    let (name, listing) = netcdf_variable(path, var, rank, sel)?;
    let dims = variables::list_variables(path)?
        .into_iter()
        .find(|(n, _)| *n == name)
        .map(|(_, d)| d)
        .unwrap_or_default();
    let (variable, notes) =
        match crate::datasets::conventions::vertical::at_level(path, &name, &dims, sel)? {
            // A level on a parametric vertical coordinate (`at: #{ pressure: 500 }`).
            Some((variable, notes)) => {
                if rank.is_some() {
                    let kept: Vec<&(String, usize)> = variable.dims.iter().collect();
                    select::refuse_time(path, &name, &kept)?;
                }
                (variable, notes)
            }
            None => {
                let plan = select::plan(path, &name, &dims, sel)?;
                if rank.is_some() {
                    select::refuse_time(path, &name, &plan.kept(&dims))?;
                }
                (select::read(path, &name, &plan)?, plan.notes)
            }
        };
    // Missing values become NaN when decoded; NaN already stored raw is not a fill.
    let raw_nan = variable.stored_nan;
    let decoded_nan = variable.data.iter().filter(|v| v.is_nan()).count();
    Ok(ArrayData {
        name,
        dims: variable.dims.iter().map(|(d, _)| d.clone()).collect(),
        shape: variable.dims.iter().map(|(_, n)| *n).collect(),
        dtype: listing.dtype.clone(),
        units: variable.units,
        fill_count: decoded_nan.saturating_sub(raw_nan),
        data: variable.data,
        attributes: variable.attributes,
        notes,
    })
}

/// The NetCDF variable a read takes: `var`, else the default one ([`default_netcdf_variable`]),
/// with its listing; a name the file lacks is an error listing what it has.
pub(super) fn netcdf_variable(
    path: &Path,
    var: Option<&str>,
    rank: Option<usize>,
    sel: &select::Selection,
) -> Result<(String, ArrayListing)> {
    netcdf_variable_in(path, var, rank, sel).map_err(crate::datasets::netcdf::with_group_note)
}

fn netcdf_variable_in(
    path: &Path,
    var: Option<&str>,
    rank: Option<usize>,
    sel: &select::Selection,
) -> Result<(String, ArrayListing)> {
    let listed = list_arrays(path)?;
    let name = match var {
        // An HDF5-style path to a root-group variable ("/t2m", as for plain HDF5 files).
        Some(v) => match v.strip_prefix('/') {
            Some(root) if !root.contains('/') && !listed.iter().any(|a| a.name == v) => root,
            _ => v,
        }
        .to_string(),
        None => default_netcdf_variable(path, &listed, rank, sel)?,
    };
    let listing = listed
        .iter()
        .find(|a| a.name == name)
        .cloned()
        .ok_or_else(|| missing_array(path, &name, &listed))?;
    Ok((name, listing))
}

/// The one volume of a `.vti`, `.vtk` or `.nhdr`/`.nrrd` file as an array (z, y, x).
pub(crate) fn volume_array(volume: Volume) -> ArrayData {
    let [nx, ny, nz] = volume.dims;
    let mut array = plain_array(
        &volume.name,
        vec![nz, ny, nx],
        "float32 (as loaded)".to_string(),
        volume.data.iter().map(|&v| v as f64).collect(),
    );
    array.dims = vec!["z".into(), "y".into(), "x".into()];
    array.units = (!volume.units.is_empty()).then_some(volume.units);
    array
}

/// The shape without leading length-1 dimensions beyond `rank` (a single time step, say).
fn squeezed(shape: &[usize], rank: usize) -> &[usize] {
    let mut start = 0;
    while shape.len() - start > rank && shape[start] == 1 {
        start += 1;
    }
    &shape[start..]
}

pub(crate) fn plain_array(
    name: &str,
    shape: Vec<usize>,
    dtype: String,
    data: Vec<f64>,
) -> ArrayData {
    ArrayData {
        name: name.to_string(),
        dims: (0..shape.len()).map(|a| format!("dim{a}")).collect(),
        shape,
        dtype,
        units: None,
        data,
        fill_count: 0,
        attributes: Vec::new(),
        notes: Vec::new(),
    }
}

fn describe(listed: &[ArrayListing]) -> String {
    if listed.is_empty() {
        return "no arrays".to_string();
    }
    listed
        .iter()
        .map(|a| format!("{} {:?}", a.name, a.shape))
        .collect::<Vec<_>>()
        .join(", ")
}

pub(crate) fn missing_array(path: &Path, name: &str, listed: &[ArrayListing]) -> Error {
    Error::format(
        path,
        format!("no variable '{name}'; the file has: {}", describe(listed)),
    )
}

pub(crate) fn no_array(path: &Path, rank_name: &str, listed: &[ArrayListing]) -> Error {
    Error::format(
        path,
        format!(
            "no {rank_name}data array to pick; name one with variable (--variable); the file has: {}",
            describe(listed)
        ),
    )
}
