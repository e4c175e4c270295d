//! NumPy `.npz` archives: a zip of `.npy` members, stored (`np.savez`) or deflated
//! (`np.savez_compressed`), each an array named after its member. A grid takes its coordinates
//! from arrays named `x`/`lon`/`longitude` and `y`/`lat`/`latitude` of matching lengths, and the
//! other arrays of its shape as properties.

use std::path::Path;

use super::{npy, ExtrasAsked, GridAxes, GridExtras, Reader};
use crate::datasets::select::Selection;
use crate::datasets::{
    fits_rank, missing_array, no_array, plain_array, rank_name, read_array, ArrayData,
    ArrayListing, GridAxis,
};
use crate::error::{Error, Result};
use crate::model::CoordKind;

pub(crate) struct NpzReader;

impl Reader for NpzReader {
    fn list(&self, path: &Path) -> Result<Vec<ArrayListing>> {
        let mut archive = open_npz(path)?;
        let names = npz_array_names(&archive, path)?;
        let mut listed = Vec::with_capacity(names.len());
        for name in names {
            // Only the member's header is read: its shape and dtype.
            let npy = npy::open_npy(npz_member(&mut archive, path, &name)?).map_err(|e| {
                Error::format(path, format!("array '{name}': {}", npy::header_error(&e)))
            })?;
            listed.push(ArrayListing {
                shape: npy.shape().iter().map(|&s| s as usize).collect(),
                // "<f4" as the array's own report spells it (descr() quotes it as Python does).
                dtype: match npy.dtype() {
                    npyz::DType::Plain(ts) => ts.to_string(),
                    other => other.descr(),
                },
                is_coordinate: false,
                is_auxiliary: false,
                unreadable: None,
                name,
            });
        }
        Ok(listed)
    }

    fn read(
        &self,
        path: &Path,
        var: Option<&str>,
        rank: Option<usize>,
        _sel: &Selection,
    ) -> Result<ArrayData> {
        read_npz_array(path, var, rank)
    }

    fn holds_many(&self) -> bool {
        true
    }

    fn grid_axes(&self, path: &Path, array: &ArrayData) -> Result<GridAxes> {
        let [ny, nx] = [array.shape[0], array.shape[1]];
        let find = |names: [&str; 3], len: usize| -> Result<Option<GridAxis>> {
            let listed = self.list(path)?;
            for name in names {
                if listed.iter().any(|a| a.name == name && a.shape == [len]) {
                    let axis = read_array(path, Some(name), Some(1))?;
                    return Ok(Some(GridAxis {
                        name: name.to_string(),
                        units: None,
                        values: axis.data,
                        kind: CoordKind::Plain,
                        edges: None,
                    }));
                }
            }
            Ok(None)
        };
        Ok(GridAxes {
            x: find(["x", "lon", "longitude"], nx)?,
            y: find(["y", "lat", "latitude"], ny)?,
            ..GridAxes::default()
        })
    }

    fn grid_extras(&self, path: &Path, ask: &ExtrasAsked) -> Result<GridExtras> {
        crate::datasets::same_shape_arrays(path, ask)
    }
}

/// [`read_array`] of an `.npz` member: `var`, else the largest array of the rank (the first of
/// equally large ones).
fn read_npz_array(path: &Path, var: Option<&str>, rank: Option<usize>) -> Result<ArrayData> {
    let listed = NpzReader.list(path)?;
    let name = match var {
        Some(v) => v.to_string(),
        None => listed
            .iter()
            .filter(|a| fits_rank(&a.shape, rank))
            // Reversed so that of equally large arrays the first in the archive wins.
            .rev()
            .max_by_key(|a| a.shape.iter().product::<usize>())
            .map(|a| a.name.clone())
            .ok_or_else(|| no_array(path, &rank_name(rank), &listed))?,
    };
    if !listed.iter().any(|a| a.name == name) {
        return Err(missing_array(path, &name, &listed));
    }
    let mut archive = open_npz(path)?;
    let mut entry = npz_member(&mut archive, path, &name)?;
    let size = entry.size();
    let npy = npy::read_npy_from::<f64, _>(&mut entry, size, path).map_err(|e| match e {
        Error::Format { path, msg } => Error::Format {
            path,
            msg: format!("array '{name}': {msg}"),
        },
        other => other,
    })?;
    // Reading on to the member's end makes zip compare its CRC-32: a damaged stored member is
    // then an error rather than wrong values.
    std::io::copy(&mut entry, &mut std::io::sink())
        .map_err(|e| Error::format(path, format!("array '{name}': {e}")))?;
    Ok(plain_array(&name, npy.shape, npy.dtype, npy.data))
}

/// An `.npz` file opened as the zip archive it is (members stored or deflated, as `np.savez`
/// and `np.savez_compressed` write them).
type NpzArchive = zip::ZipArchive<std::io::BufReader<std::fs::File>>;

fn open_npz(path: &Path) -> Result<NpzArchive> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    zip::ZipArchive::new(std::io::BufReader::new(file))
        .map_err(|e| Error::format(path, format!("not a readable .npz archive: {e}")))
}

/// The arrays of an `.npz` in archive order: its `NAME.npy` members, named without the suffix
/// (other members are not arrays and are passed over, as NumPy's `load` does).
fn npz_array_names(archive: &NpzArchive, path: &Path) -> Result<Vec<String>> {
    let mut names = Vec::with_capacity(archive.len());
    for member in archive.file_names() {
        let member =
            member.map_err(|e| Error::format(path, format!("unreadable .npz member name: {e}")))?;
        if let Some(name) = npyz::npz::array_name_from_file_name(&member) {
            names.push(name.to_string());
        }
    }
    Ok(names)
}

/// The member holding array `name`, decompressed as it is read.
fn npz_member<'a>(
    archive: &'a mut NpzArchive,
    path: &Path,
    name: &str,
) -> Result<zip::read::ZipFile<'a, std::io::BufReader<std::fs::File>>> {
    let entry = archive
        .by_name(&npyz::npz::file_name_from_array_name(name))
        .map_err(|e| Error::format(path, format!("array '{name}': {e}")))?;
    // NumPy writes only these two, and zip is built with no other decoder.
    match entry.compression() {
        zip::CompressionMethod::Stored | zip::CompressionMethod::Deflated => Ok(entry),
        other => Err(Error::format(
            path,
            format!(
                "array '{name}' is compressed with {other}; expected a stored or deflated member \
                 (np.savez, np.savez_compressed)"
            ),
        )),
    }
}
