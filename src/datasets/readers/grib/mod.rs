//! GRIB (WMO FM 92, editions 1 and 2), the format of weather services' forecasts and analyses,
//! as a reader of the data model: a file's messages become variables with named dimensions and
//! CF attributes ([`index`], [`dataset`]), so selection by level and step (`at: #{
//! isobaricInhPa: 500 }`), CF time, geographic and curvilinear placement, maps and globes work as
//! on NetCDF. Edition 2 is decoded by the `grib` crate ([`grib2`]), edition 1 here ([`grib1`]).
//! `index: #{ message: k }` reads message k (0-based, in file order) whatever variable it
//! belongs to.

mod dataset;
mod grib1;
mod grib2;
mod index;
mod model;
mod names;

use std::path::Path;

use super::variables::{Dims, NcAttribute, NcVariable};
use crate::datasets::select::Selection;
use crate::datasets::{ArrayData, ArrayListing};
use crate::error::{Error, Result};
use model::{Content, GribIndex, GribVariable};

/// The GRIB reader (editions 1 and 2).
pub(crate) struct GribReader;

/// Whether `head` holds a GRIB message start: "GRIB" then edition 1 or 2 at octet 8, at the
/// start or after a WMO bulletin header.
pub(crate) fn is_grib(head: &[u8]) -> bool {
    head.windows(8)
        .any(|w| &w[..4] == b"GRIB" && matches!(w[7], 1 | 2))
}

fn variable<'a>(path: &Path, index: &'a GribIndex, name: &str) -> Result<&'a GribVariable> {
    index
        .variables
        .iter()
        .find(|v| v.name == name)
        .ok_or_else(|| {
            let names: Vec<&str> = index.variables.iter().map(|v| v.name.as_str()).collect();
            Error::invalid(
                "variable",
                format!(
                    "'{name}' is not in {}; it holds {}",
                    path.display(),
                    names.join(", ")
                ),
            )
        })
}

/// The values of message `k`, decoded, in the grid's row order.
fn message_values(path: &Path, index: &GribIndex, k: usize) -> Result<Vec<f64>> {
    let m = &index.messages[k];
    // Only this message's bytes: a variable reads its messages one by one.
    let msg = {
        use std::io::{Read, Seek, SeekFrom};
        let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let mut msg = vec![0u8; m.length];
        file.seek(SeekFrom::Start(m.offset as u64))
            .and_then(|_| file.read_exact(&mut msg))
            .map_err(|_| {
                Error::format(
                    path,
                    format!("message {k}: the file changed while it was read"),
                )
            })?;
        msg
    };
    let grid = &m.field.grid;
    let points = grid.stored_points();
    let mut values = match m.field.edition {
        1 => grib1::values(&msg, points),
        _ => grib2::values(&msg, m.sub),
    }
    .map_err(|why| {
        Error::format(
            path,
            format!("message {k} (GRIB{}): {why}", m.field.edition),
        )
    })?;
    if values.len() != points {
        return Err(Error::format(
            path,
            format!(
                "message {k}: {} values for a grid of {points} points",
                values.len()
            ),
        ));
    }
    if grid.alternate_rows {
        model::turn_alternate_rows(&mut values, grid.ni);
    }
    Ok(grid.fill_rows(values))
}

/// Every combination of `sel` in C order, as flat indices into an array of `dims`.
fn flat_indices(dims: &Dims, sel: &[Vec<usize>]) -> Vec<usize> {
    let mut out = vec![0usize];
    for ((_, n), keep) in dims.iter().zip(sel) {
        out = out
            .iter()
            .flat_map(|&base| keep.iter().map(move |&i| base * n + i))
            .collect();
    }
    out
}

impl GribReader {
    /// Variable `var` of the file with `picks` and `window` applied.
    fn read_variable(
        &self,
        path: &Path,
        var: &GribVariable,
        picks: &[Option<usize>],
        window: Option<(usize, std::ops::Range<usize>)>,
    ) -> Result<NcVariable> {
        let sel = super::variables::kept(&var.dims, picks, &window)?;
        let data = match &var.content {
            Content::Stored(values) => flat_indices(&var.dims, &sel)
                .into_iter()
                .map(|i| values[i])
                .collect(),
            Content::Messages(holders) | Content::ExpOfMessages(holders) => {
                let index = index::index_of(path)?;
                let outer = var.dims.len() - 2;
                let (grid_dims, grid_sel) = (var.dims[outer..].to_vec(), &sel[outer..]);
                let cells = flat_indices(&grid_dims, grid_sel);
                let mut data = Vec::new();
                for o in flat_indices(&var.dims[..outer].to_vec(), &sel[..outer]) {
                    match holders[o] {
                        Some(k) => {
                            let values = message_values(path, &index, k)?;
                            data.extend(cells.iter().map(|&c| values[c]));
                        }
                        None => data.extend(std::iter::repeat_n(f64::NAN, cells.len())),
                    }
                }
                if matches!(var.content, Content::ExpOfMessages(_)) {
                    data.iter_mut().for_each(|v| *v = v.exp());
                }
                data
            }
        };
        Ok(super::variables::picked_variable(
            &var.name,
            &var.dims,
            (&sel, picks),
            data,
            &var.attributes,
        ))
    }

    /// Message `k` alone, as a 2-D array on its grid.
    fn read_message(&self, path: &Path, k: i64) -> Result<ArrayData> {
        let index = index::index_of(path)?;
        let count = index.messages.len();
        let k = usize::try_from(k)
            .ok()
            .filter(|&k| k < count)
            .ok_or_else(|| {
                Error::invalid(
                    "message",
                    format!("index {k} is outside the file's messages 0..{count}"),
                )
            })?;
        let var = index
            .variables
            .iter()
            .find(|v| matches!(&v.content, Content::Messages(h) if h.contains(&Some(k))))
            .expect("every message is in a variable");
        let grid = var.dims[var.dims.len() - 2..].to_vec();
        let data = message_values(path, &index, k)?;
        let fill_count = data.iter().filter(|v| v.is_nan()).count();
        let f = &index.messages[k].field;
        Ok(ArrayData {
            name: var.name.clone(),
            dims: grid.iter().map(|(d, _)| d.clone()).collect(),
            shape: grid.iter().map(|(_, n)| *n).collect(),
            dtype: "float64".into(),
            units: f.param.units.clone(),
            data,
            fill_count,
            attributes: var.attributes.clone(),
            notes: vec![format!(
                "message {k}: {} on {} {}, step {} h, reference {}",
                f.param.name,
                f.level.type_name,
                f.level.value.map_or(String::new(), |v| v.to_string()),
                f.step_hours,
                f.reference
            )],
        })
    }
}

impl super::Reader for GribReader {
    fn list(&self, path: &Path) -> Result<Vec<ArrayListing>> {
        // Every variable is decoded to double precision.
        super::variables::listing(self, path, &|_| "float64".into())
    }

    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        rank: Option<usize>,
        sel: &Selection,
    ) -> Result<ArrayData> {
        if let Some((_, k)) = sel.index.iter().find(|(d, _)| d == "message") {
            if sel.index.len() > 1 || !sel.at.is_empty() {
                return Err(Error::invalid(
                    "index",
                    "message: k picks one message; give no other index or at",
                ));
            }
            let array = self.read_message(path, *k)?;
            if let Some(v) = var.filter(|v| *v != array.name) {
                return Err(Error::invalid(
                    "variable",
                    format!(
                        "message {k} of {} holds '{}', not '{v}'",
                        path.display(),
                        array.name
                    ),
                ));
            }
            return Ok(array);
        }
        crate::datasets::read_netcdf_array(path, var, rank, sel)
    }

    fn variables(&self) -> Option<&dyn super::variables::Variables> {
        Some(self)
    }
}

impl super::variables::Variables for GribReader {
    fn list(&self, path: &Path) -> Result<Vec<(String, Dims)>> {
        let index = index::index_of(path)?;
        Ok(index
            .variables
            .iter()
            .map(|v| (v.name.clone(), v.dims.clone()))
            .collect())
    }

    fn attributes(&self, path: &Path, name: &str) -> Result<Vec<(String, NcAttribute)>> {
        let index = index::index_of(path)?;
        Ok(variable(path, &index, name)?.attributes.clone())
    }

    fn global_attributes(&self, path: &Path) -> Result<Vec<(String, NcAttribute)>> {
        Ok(index::index_of(path)?.globals.clone())
    }

    fn read(
        &self,
        path: &Path,
        name: &str,
        picks: &[Option<usize>],
        window: Option<(usize, std::ops::Range<usize>)>,
    ) -> Result<NcVariable> {
        let index = index::index_of(path)?;
        self.read_variable(path, variable(path, &index, name)?, picks, window)
    }
}
