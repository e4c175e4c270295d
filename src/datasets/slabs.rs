//! An array read a slab at a time along its first dimension, so that `hdrvis info` describes
//! arrays larger than memory from reads of bounded size: NetCDF variables by hyperslabs (CF
//! decoding as a whole read, the dimensions a selection fixes fixed) and `.npy` arrays by
//! positioned reads. Other formats, and selections that interpolate between levels, are read
//! whole.

use std::ops::Range;
use std::path::{Path, PathBuf};

use super::arrays::{netcdf_variable, ArrayData};
use super::bricked::NpyLayout;
use super::{netcdf, select};
use crate::error::Result;

/// Values per slab: 128 MiB as f64 (and the reader's stored copy beside them).
pub(crate) const SLAB_VALUES: usize = 1 << 24;

enum Source {
    Npy(NpyLayout),
    Netcdf {
        name: String,
        picks: Vec<Option<usize>>,
        /// The dimension slabs are cut along, among all the variable's dimensions.
        axis: usize,
    },
}

/// One slab's values and how many of them the file marks as missing (now NaN).
pub(crate) struct Slab {
    pub values: Vec<f64>,
    pub fills: usize,
}

/// An array open for reading in slabs.
pub(crate) struct Slabs {
    path: PathBuf,
    source: Source,
    /// Name, dimensions, shape, type, units and attributes; `data` empty, `fill_count` 0.
    pub meta: ArrayData,
    /// Rows along the first kept dimension, and values per row.
    pub rows: usize,
    pub row_len: usize,
}

impl Slabs {
    /// `path`'s array (`var`, under `sel`) open for slab reads, or `None` where it is read whole.
    pub(crate) fn open(
        path: &Path,
        var: Option<&str>,
        sel: &select::Selection,
    ) -> Result<Option<Slabs>> {
        let (source, meta) = match super::Format::of(path)? {
            super::Format::Npy if sel.is_empty() => {
                let Ok(layout) = NpyLayout::open(path) else {
                    // The whole read says what is wrong, or reads what this path cannot.
                    return Ok(None);
                };
                let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("array");
                let meta = super::arrays::plain_array(
                    name,
                    layout.shape.clone(),
                    layout.descr.clone(),
                    Vec::new(),
                );
                (Source::Npy(layout), meta)
            }
            super::Format::NetCdf => match netcdf_source(path, var, sel)? {
                Some(opened) => opened,
                None => return Ok(None),
            },
            _ => return Ok(None),
        };
        let rows = meta.shape.first().copied().unwrap_or(1);
        let row_len = meta.shape.iter().skip(1).product();
        Ok(Some(Slabs {
            path: path.to_path_buf(),
            source,
            meta,
            rows,
            row_len,
        }))
    }

    /// Values in the array.
    pub(crate) fn len(&self) -> u64 {
        self.rows as u64 * self.row_len as u64
    }

    /// Row ranges of at most `values` values each (one row at least) covering the array.
    pub(crate) fn ranges(&self, values: usize) -> Vec<Range<usize>> {
        let step = (values / self.row_len.max(1)).max(1);
        (0..self.rows)
            .step_by(step)
            .map(|r| r..(r + step).min(self.rows))
            .collect()
    }

    /// The values of `rows`, in C order.
    pub(crate) fn read(&self, rows: Range<usize>) -> Result<Slab> {
        match &self.source {
            Source::Npy(layout) => Ok(Slab {
                values: layout.read_f64(
                    &self.path,
                    rows.start * self.row_len,
                    rows.len() * self.row_len,
                )?,
                fills: 0,
            }),
            Source::Netcdf { name, picks, axis } => {
                let window = (!self.meta.shape.is_empty()).then_some((*axis, rows));
                let v = netcdf::read_variable_window(&self.path, name, picks, window)?;
                let nan = v.data.iter().filter(|x| x.is_nan()).count();
                Ok(Slab {
                    fills: nan.saturating_sub(v.stored_nan),
                    values: v.data,
                })
            }
        }
    }
}

/// A NetCDF variable's slab source and description, as `read_array_sel` would name and read it;
/// `None` when the selection interpolates (read whole).
fn netcdf_source(
    path: &Path,
    var: Option<&str>,
    sel: &select::Selection,
) -> Result<Option<(Source, ArrayData)>> {
    let (name, listing) = netcdf_variable(path, var, None, sel)?;
    if listing.unreadable.is_some() {
        return Ok(None);
    }
    let dims = netcdf::dims_in(&netcdf::list_variables(path)?, &name);
    let plan = select::plan(path, &name, &dims, sel)?;
    let Ok(picks) = plan.positions(path, &name) else {
        return Ok(None);
    };
    let axis = picks.iter().position(Option::is_none).unwrap_or(0);
    let kept = plan.kept(&dims);
    let attributes = netcdf::variable_attributes(path, &name)?;
    let units = attributes.iter().find_map(|(n, v)| match v {
        netcdf::NcAttribute::Text(s) if n == "units" => Some(s.clone()),
        _ => None,
    });
    let meta = ArrayData {
        name: name.clone(),
        dims: kept.iter().map(|(d, _)| d.clone()).collect(),
        shape: kept.iter().map(|(_, n)| *n).collect(),
        dtype: listing.dtype.clone(),
        units,
        data: Vec::new(),
        fill_count: 0,
        attributes,
        notes: plan.notes,
    };
    Ok(Some((Source::Netcdf { name, picks, axis }, meta)))
}
