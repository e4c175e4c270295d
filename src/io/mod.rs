//! Image files — OpenEXR (the linear HDR master) and PNG (display views) — and the one way every output is written: to a temporary file in the destination folder
//! that is renamed into place, so no reader ever sees a half-written file. The terminal is a sink
//! too: [`terminal`] prints pictures inline, once. Also the one folder hdrvis caches things in
//! (generated datasets, compiled GPU pipelines).

pub mod exr;
pub mod png;
pub mod terminal;

use crate::error::{Error, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes a file atomically: `fill` writes into a temporary file beside `path`, which is renamed
/// over `path` only when `fill` succeeded. The file gets the mode a plain `open` would give it
/// (0666 less the umask, so 0644 under the usual 022): colleagues and web servers can read the
/// outputs, as they can any file the user creates.
pub(crate) fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> Result<()>,
) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let mut tmp = temporary_beside(dir)?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w)?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// A new temporary file `.hdrvis-*.tmp` in `dir` (the name a resumed run sweeps away), created
/// with mode 0666 so that the kernel applies the umask exactly as it does to any new file:
/// tempfile's default is owner-only, which the rename would keep.
pub(crate) fn temporary_beside(dir: &Path) -> Result<tempfile::NamedTempFile> {
    let mut builder = tempfile::Builder::new();
    builder.prefix(".hdrvis-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    builder.tempfile_in(dir).map_err(|e| Error::io(dir, e))
}

/// Lower-case extension of a path, or "" when it has none.
pub fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default()
}

/// Environment variable that overrides the cache folder.
pub(crate) const CACHE_ENV: &str = "HDRVIS_CACHE";

/// The folder hdrvis caches generated datasets and compiled pipelines in: `$HDRVIS_CACHE` when
/// that is set, else `datasets/cache` in the hdrvis checkout that contains the working directory
/// (found by walking up to a `Cargo.toml` naming the package `hdrvis`), else `datasets/cache`
/// under the working directory.
pub(crate) fn cache_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os(CACHE_ENV).filter(|d| !d.is_empty()) {
        return PathBuf::from(dir);
    }
    let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    let root = cwd
        .ancestors()
        .find(|dir| is_hdrvis_checkout(dir))
        .map(Path::to_path_buf)
        .unwrap_or(cwd);
    root.join("datasets").join("cache")
}

fn is_hdrvis_checkout(dir: &Path) -> bool {
    std::fs::read_to_string(dir.join("Cargo.toml"))
        .map(|text| {
            text.lines()
                .any(|line| line.replace(' ', "") == "name=\"hdrvis\"")
        })
        .unwrap_or(false)
}
