//! Which files a data file may pull in by name. Some formats name other files (an NRRD header's
//! `data file`); a script's sandbox must bind those names as it binds the script's own paths, or
//! a header in the script's folder could read any file of the machine. Readers therefore resolve
//! such names here: relative to the naming file's folder, with `..` and symlinks resolved, and,
//! while a [`ReadScope`] is active on the thread, refused unless the result lies in one of its
//! folders. Outside a scope (the command line, the library) every name is followed, as the user
//! who named the header may read what it names.

use crate::error::{Error, Result};
use std::cell::RefCell;
use std::path::{Component, Path, PathBuf};

thread_local! {
    /// The folders of the scope active on this thread, if any; scopes nest.
    static SCOPE: RefCell<Option<Vec<PathBuf>>> = const { RefCell::new(None) };
}

/// Absolute, `..`-free form of a path whose tail may not exist yet: the longest existing prefix
/// is canonicalised (resolving symlinks) and the rest appended lexically.
pub(crate) fn resolve(path: &Path) -> Result<PathBuf> {
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map_err(|e| Error::io(".", e))?
            .join(path)
    };
    let mut clean = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                clean.pop();
            }
            Component::CurDir => {}
            other => clean.push(other.as_os_str()),
        }
    }
    let mut existing = clean.clone();
    let mut tail = Vec::new();
    while !existing.exists() {
        match existing.file_name() {
            Some(n) => tail.push(n.to_os_string()),
            None => break,
        }
        existing.pop();
    }
    let mut out = existing.canonicalize().unwrap_or(existing);
    for t in tail.into_iter().rev() {
        out.push(t);
    }
    Ok(out)
}

/// While alive, files named by other files must resolve inside `folders` (already resolved with
/// [`resolve`]) on this thread; dropping it restores the scope that was active before.
pub(crate) struct ReadScope {
    previous: Option<Vec<PathBuf>>,
}

impl ReadScope {
    /// Limits the references of data files read on this thread to `folders`.
    pub(crate) fn enter(folders: &[PathBuf]) -> ReadScope {
        let previous = SCOPE.with(|s| s.borrow_mut().replace(folders.to_vec()));
        ReadScope { previous }
    }
}

impl Drop for ReadScope {
    fn drop(&mut self) {
        let previous = self.previous.take();
        SCOPE.with(|s| *s.borrow_mut() = previous);
    }
}

/// The file that `referrer` names as `name` in its field `field`: resolved against the
/// referrer's folder, and refused when a [`ReadScope`] is active and the file lies outside it.
pub(crate) fn referenced_file(referrer: &Path, field: &str, name: &str) -> Result<PathBuf> {
    let folder = referrer.parent().unwrap_or(Path::new("."));
    let path = resolve(&folder.join(name))?;
    let allowed = SCOPE.with(|s| {
        s.borrow()
            .as_ref()
            .is_none_or(|folders| folders.iter().any(|f| path.starts_with(f)))
    });
    if allowed {
        Ok(path)
    } else {
        Err(Error::format(
            referrer,
            format!(
                "{field}: {} lies outside the folders this script may read (its own folder, \
                 the output folder and --allow-path folders)",
                crate::error::excerpt(name, 60)
            ),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_stay_in_the_scope_and_scopes_nest() {
        let root = tempfile::tempdir().unwrap();
        let inside = root.path().join("in");
        std::fs::create_dir_all(&inside).unwrap();
        std::fs::write(inside.join("v.raw"), b"x").unwrap();
        std::os::unix::fs::symlink("/etc/passwd", inside.join("link.raw")).unwrap();
        let header = inside.join("v.nhdr");
        let folders = [resolve(&inside).unwrap()];
        // Outside any scope everything is followed.
        assert!(referenced_file(&header, "data file", "/etc/passwd").is_ok());
        {
            let _scope = ReadScope::enter(&folders);
            assert!(referenced_file(&header, "data file", "v.raw").is_ok());
            for escape in ["/etc/passwd", "../../../../etc/passwd", "link.raw"] {
                let err = referenced_file(&header, "data file", escape).unwrap_err();
                assert!(
                    err.to_string().contains("outside the folders"),
                    "{escape}: {err}"
                );
            }
            {
                let _wider = ReadScope::enter(&[PathBuf::from("/")]);
                assert!(referenced_file(&header, "data file", "/etc/passwd").is_ok());
            }
            assert!(referenced_file(&header, "data file", "/etc/passwd").is_err());
        }
        assert!(referenced_file(&header, "data file", "/etc/passwd").is_ok());
    }
}
