//! The script sandbox: reads resolve against the script's folder and must fall inside the
//! script folder, the output folder or a folder the user allowed with `--allow-path`; writes
//! must fall inside the output folder. Paths are compared after resolving `..` and symlinks of
//! the existing part, so `../x` or a link cannot escape.

use crate::datasets::access::resolve;
use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub(crate) struct Sandbox {
    script_dir: PathBuf,
    out_dir: PathBuf,
    readable: Vec<PathBuf>,
}

impl Sandbox {
    pub fn new(script_dir: &Path, out_dir: &Path, allowed: &[PathBuf]) -> Result<Sandbox> {
        std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
        let script_dir = resolve(script_dir)?;
        let out_dir = resolve(out_dir)?;
        let mut readable = vec![script_dir.clone(), out_dir.clone()];
        for a in allowed {
            readable.push(resolve(a)?);
        }
        Ok(Sandbox {
            script_dir,
            out_dir,
            readable,
        })
    }

    /// The folders the script may read, resolved (for [`crate::datasets::access::ReadScope`]).
    pub(crate) fn readable(&self) -> &[PathBuf] {
        &self.readable
    }

    /// A path the script wants to read, relative to the script's folder.
    pub(crate) fn read_path(&self, requested: &str) -> Result<PathBuf> {
        let p = resolve(&self.script_dir.join(requested))?;
        if self.readable.iter().any(|r| p.starts_with(r)) {
            Ok(p)
        } else {
            Err(Error::invalid(
                "path",
                format!(
                    "{requested:?} is outside the folders this script may read (its own folder, the output folder and --allow-path folders)"
                ),
            ))
        }
    }

    /// A data file the script wants to read, with the variable a `FILE:VARIABLE` shorthand names
    /// (`box.nc:T`) when the whole text is not itself an existing file but the part before the
    /// last colon is.
    pub(crate) fn read_data_path(&self, requested: &str) -> Result<(PathBuf, Option<String>)> {
        let whole = self.read_path(requested);
        if whole.as_ref().is_ok_and(|p| p.is_file()) {
            return Ok((whole?, None));
        }
        if let Some((file, variable)) = requested.rsplit_once(':') {
            // A path inside an HDF5 file starts with '/' (`volume.h5:/group/name`).
            let names_variable = !variable.is_empty()
                && (variable.starts_with('/') || !variable.contains(['/', '\\']));
            if names_variable && !file.is_empty() {
                if let Some(p) = self.read_path(file).ok().filter(|p| p.is_file()) {
                    return Ok((p, Some(variable.to_string())));
                }
            }
        }
        Ok((whole?, None))
    }

    /// A path the script wants to write, relative to the output folder.
    pub(crate) fn write_path(&self, requested: &str) -> Result<PathBuf> {
        if Path::new(requested).is_absolute() {
            return Err(Error::invalid(
                "path",
                format!("{requested:?}: outputs are named relative to the output folder, not absolutely"),
            ));
        }
        let p = resolve(&self.out_dir.join(requested))?;
        if p.starts_with(&self.out_dir) && p != self.out_dir {
            Ok(p)
        } else {
            Err(Error::invalid(
                "path",
                format!(
                    "{requested:?} would be written outside the output folder {}",
                    self.out_dir.display()
                ),
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_writes_stay_inside() {
        let root = tempfile::tempdir().unwrap();
        let scripts = root.path().join("scripts");
        std::fs::create_dir_all(&scripts).unwrap();
        std::fs::write(scripts.join("a.npy"), b"x").unwrap();
        let sb = Sandbox::new(&scripts, &root.path().join("out"), &[]).unwrap();
        assert!(sb.read_path("a.npy").is_ok());
        assert!(sb.read_path("/etc/passwd").is_err());
        assert!(sb.read_path("../../etc/passwd").is_err());
        assert!(sb.write_path("sub/x.exr").is_ok());
        assert!(sb.write_path("../x").is_err());
        assert!(sb.write_path("/tmp/x").is_err());
        assert!(sb.write_path("a/../../x").is_err());
    }
}
