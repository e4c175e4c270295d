//! Datasets: readers for the formats geoscientists have (NumPy, NRRD raw headers) and, as the
//! datasets work lands, the generators of the paper's case studies. `load_volume` picks the
//! reader from the file name.

pub mod mantle;
pub mod netcdf;
pub mod nhdr;
pub mod npy;
pub mod okada;
pub mod tsunami;
pub mod vti;

use crate::error::{Error, Result};
use crate::model::Volume;
use std::path::Path;

/// Loads a scalar volume, choosing the reader by extension: `.npy` (shape (nz, ny, nx)),
/// `.nhdr`/`.nrrd`.
pub fn load_volume(path: &Path) -> Result<Volume> {
    if !path.exists() {
        return Err(Error::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        ));
    }
    match crate::io::extension(path).as_str() {
        "npy" => volume_from_npy(path),
        "nhdr" | "nrrd" => nhdr::read_nrrd(path),
        other => Err(Error::format(
            path,
            format!("unknown volume format {other:?}; expected .npy, .nhdr or .nrrd"),
        )),
    }
}

fn volume_from_npy(path: &Path) -> Result<Volume> {
    let arr = npy::read_npy::<f32>(path)?;
    if arr.shape.len() != 3 {
        return Err(Error::format(
            path,
            format!(
                "expected a 3-D array of shape (nz, ny, nx), got shape {:?}",
                arr.shape
            ),
        ));
    }
    let dims = [arr.shape[2], arr.shape[1], arr.shape[0]];
    crate::model::volume::check_dims(&dims, &format!("{}: shape", path.display()))?;
    let name = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("volume");
    Volume::new(name, dims, [1.0; 3], [0.0; 3], arr.data)
        .map_err(|e| Error::format(path, e.to_string()))
}
