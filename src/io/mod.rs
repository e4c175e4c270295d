//! Image files — OpenEXR (the linear HDR master) and PNG (display views) — and the one way every output is written: to a temporary file in the destination folder
//! that is renamed into place, so no reader ever sees a half-written file. The terminal is a sink
//! too: [`terminal`] prints pictures inline, once.

pub mod exr;
pub mod png;
pub mod terminal;

use crate::error::{Error, Result};
use std::io::Write;
use std::path::Path;

/// Writes a file atomically: `fill` writes into a temporary file beside `path`, which is renamed
/// over `path` only when `fill` succeeded.
pub fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut tmp = tempfile::Builder::new()
        .prefix(".hdrvis-")
        .suffix(".tmp")
        .tempfile_in(dir)
        .map_err(|e| Error::io(dir, e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w)?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// Lower-case extension of a path, or "" when it has none.
pub fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default()
}
