//! The dataset cache: generated fields are stored once under a name made of the generator and a
//! hash of every parameter, so the demo, the case-study scripts and repeated CLI calls generate
//! each dataset once. The folder is [`cache_dir`]: `$HDRVIS_CACHE` when that is set, else
//! `datasets/cache` in the hdrvis checkout that contains the working directory (git-ignored),
//! else the platform's cache folder (`$XDG_CACHE_HOME/hdrvis`, `~/.cache/hdrvis`). Files appear
//! atomically: a generator writes a temporary file in the cache folder, which is renamed into
//! place only when it succeeded. [`usage`] and [`clean`] (`hdrvis cache du|clean`) manage it,
//! touching only what hdrvis itself put there.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// The cache folder and its override live in `io`, so that the GPU pipeline cache uses the same
/// folder without `gpu` depending on `datasets`.
pub(crate) use crate::io::cache_dir;

/// The cached file for (`job_kind`, `key`, `ext`) in [`cache_dir`]; `make` writes it when it is
/// missing. Returns the file's path either way.
pub(crate) fn cached(
    job_kind: &str,
    key: &str,
    ext: &str,
    make: impl FnOnce(&Path) -> Result<()>,
) -> Result<PathBuf> {
    cached_in(&cache_dir(), job_kind, key, ext, make)
}

/// [`cached`] in an explicit folder. `make` receives a temporary path in `dir` with the final
/// extension (writers choose the format from it); the file is renamed to
/// `<job_kind>-<key>.<ext>` only when `make` succeeded, and removed otherwise.
pub(crate) fn cached_in(
    dir: &Path,
    job_kind: &str,
    key: &str,
    ext: &str,
    make: impl FnOnce(&Path) -> Result<()>,
) -> Result<PathBuf> {
    for (field, value) in [("job_kind", job_kind), ("key", key), ("ext", ext)] {
        let safe = !value.is_empty()
            && value
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
        if !safe {
            return Err(Error::invalid(
                field,
                format!("'{value}' must be non-empty ASCII letters, digits, '-' or '_'"),
            ));
        }
    }
    let path = dir.join(format!("{job_kind}-{key}.{ext}"));
    if path.is_file() {
        return Ok(path);
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    // Unique per process and call, so concurrent makers never write the same temporary file.
    static CALLS: AtomicU64 = AtomicU64::new(0);
    let tmp = dir.join(format!(
        ".{job_kind}-{key}.{}-{}.partial.{ext}",
        std::process::id(),
        CALLS.fetch_add(1, Ordering::Relaxed)
    ));
    let made = make(&tmp).and_then(|()| {
        if tmp.is_file() {
            std::fs::rename(&tmp, &path).map_err(|e| Error::io(&path, e))
        } else {
            Err(Error::format(
                &path,
                "the generator finished without writing a file",
            ))
        }
    });
    if made.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    made.map(|()| path)
}

/// The compiled GPU pipelines live in this sub-folder of the cache (see `gpu`).
const PIPELINES: &str = "pipelines";

/// What the cache holds of one kind: generated datasets of one generator (`okada`, `mantle`,
/// ...), compiled `pipelines`, or `partial` files a killed generator left behind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KindUsage {
    pub kind: String,
    pub files: u64,
    pub bytes: u64,
}

/// One file hdrvis put in the cache, with its kind; anything else in the folder is no entry.
fn entries(dir: &Path) -> Result<Vec<(String, PathBuf, u64)>> {
    let mut found = Vec::new();
    let listing = match std::fs::read_dir(dir) {
        Ok(listing) => listing,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(found),
        Err(e) => return Err(Error::io(dir, e)),
    };
    for entry in listing {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().to_string();
        if name == PIPELINES && path.is_dir() {
            for file in std::fs::read_dir(&path).map_err(|e| Error::io(&path, e))? {
                let file = file.map_err(|e| Error::io(&path, e))?.path();
                if file.is_file() && crate::io::extension(&file) == "bin" {
                    found.push((PIPELINES.to_string(), file.clone(), file_size(&file)));
                }
            }
        } else if path.is_file() {
            if let Some(kind) = kind_of(&name) {
                found.push((kind, path.clone(), file_size(&path)));
            }
        }
    }
    Ok(found)
}

fn file_size(path: &Path) -> u64 {
    std::fs::metadata(path).map(|m| m.len()).unwrap_or(0)
}

/// The kind of a cache file name: `<kind>-<key>.<ext>` as [`cached`] names generated datasets
/// (the kind may hold '-'), `.…partial.…` for what a killed generator left; `None` for names
/// hdrvis does not write.
fn kind_of(name: &str) -> Option<String> {
    if name.starts_with('.') && name.contains(".partial.") {
        return Some("partial".to_string());
    }
    let (stem, ext) = name.rsplit_once('.')?;
    let (kind, key) = stem.rsplit_once('-')?;
    let ours = [super::Format::NetCdf, super::Format::Npy]
        .iter()
        .any(|f| f.extensions()[0] == ext)
        && !kind.is_empty()
        && !key.is_empty()
        && key.chars().all(|c| c.is_ascii_alphanumeric());
    ours.then(|| kind.to_string())
}

/// Files and bytes per kind in the cache folder `dir`, kinds in alphabetical order.
pub fn usage(dir: &Path) -> Result<Vec<KindUsage>> {
    let mut kinds: Vec<KindUsage> = Vec::new();
    for (kind, _, bytes) in entries(dir)? {
        match kinds.iter_mut().find(|k| k.kind == kind) {
            Some(k) => {
                k.files += 1;
                k.bytes += bytes;
            }
            None => kinds.push(KindUsage {
                kind,
                files: 1,
                bytes,
            }),
        }
    }
    kinds.sort_by(|a, b| a.kind.cmp(&b.kind));
    Ok(kinds)
}

/// Removes the cache files hdrvis wrote in `dir` (of the given kinds, or all when `kinds` is
/// empty) and returns how many files and bytes went. Other files in the folder stay, so a
/// `HDRVIS_CACHE` pointed at a shared folder loses nothing of anyone else's.
pub fn clean(dir: &Path, kinds: &[String]) -> Result<(u64, u64)> {
    let (mut files, mut bytes) = (0, 0);
    for (kind, path, size) in entries(dir)? {
        if kinds.is_empty() || kinds.contains(&kind) {
            std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            files += 1;
            bytes += size;
        }
    }
    Ok((files, bytes))
}

/// 64-bit FNV-1a hash (Fowler, Noll and Vo; offset basis 0xcbf29ce484222325, prime
/// 0x100000001b3): stable across runs, platforms and compiler versions, unlike std's hasher.
pub(crate) fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for &byte in bytes {
        hash ^= byte as u64;
        hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
    }
    hash
}

/// A cache key from a canonical text form of a job's parameters: 16 lower-case hex digits.
pub(crate) fn key_of(canonical: &str) -> String {
    format!("{:016x}", fnv1a64(canonical.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The extension NetCDF entries are written with (the registry's).
    fn netcdf_extension() -> &'static str {
        crate::datasets::Format::NetCdf.extensions()[0]
    }
    use std::cell::Cell;

    #[test]
    fn fnv1a_matches_published_vectors() {
        // Test vectors of the FNV reference page (isthe.com/chongo/tech/comp/fnv): "" and "a".
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x85944171f73967e8);
        assert_eq!(key_of("a"), "af63dc4c8601ec8c");
    }

    #[test]
    fn miss_makes_once_then_hits() {
        let dir = tempfile::tempdir().unwrap();
        let calls = Cell::new(0);
        let make = |p: &Path| {
            calls.set(calls.get() + 1);
            assert_eq!(p.extension().unwrap(), "npy");
            std::fs::write(p, b"data").map_err(|e| Error::io(p, e))
        };
        let first = cached_in(dir.path(), "okada", "0123abcd", "npy", make).unwrap();
        assert_eq!(first, dir.path().join("okada-0123abcd.npy"));
        let second = cached_in(dir.path(), "okada", "0123abcd", "npy", make).unwrap();
        assert_eq!((first, calls.get()), (second, 1));
        // A different key is a miss.
        cached_in(dir.path(), "okada", "ffff", "npy", make).unwrap();
        assert_eq!(calls.get(), 2);
    }

    #[test]
    fn failed_make_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let err = cached_in(dir.path(), "mantle", "k", netcdf_extension(), |p| {
            std::fs::write(p, b"half").unwrap();
            Err(Error::invalid("n", "too large"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("too large"));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let err = cached_in(dir.path(), "mantle", "k", netcdf_extension(), |_| Ok(())).unwrap_err();
        assert!(err.to_string().contains("without writing"), "{err}");
    }

    #[test]
    fn usage_counts_each_kind_and_clean_removes_only_ours() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let put = |name: &str, len: usize| {
            let p = d.join(name);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, vec![0u8; len]).unwrap();
        };
        put("okada-0123456789abcdef.nc", 100);
        put("okada-fedcba9876543210.npy", 50);
        put("bench-large-blobs-64.npy", 7);
        put(".mantle-k.12-0.partial.nc", 3);
        put("pipelines/abc_llvmpipe.bin", 20);
        put("notes.txt", 1000);
        put("pipelines/readme.md", 1000);
        let kinds = usage(d).unwrap();
        let summary: Vec<_> = kinds
            .iter()
            .map(|k| (k.kind.as_str(), k.files, k.bytes))
            .collect();
        assert_eq!(
            summary,
            [
                ("bench-large-blobs", 1, 7),
                ("okada", 2, 150),
                ("partial", 1, 3),
                ("pipelines", 1, 20)
            ]
        );
        assert_eq!(clean(d, &["okada".to_string()]).unwrap(), (2, 150));
        assert_eq!(clean(d, &[]).unwrap(), (3, 30));
        assert!(usage(d).unwrap().is_empty());
        assert!(d.join("notes.txt").is_file() && d.join("pipelines/readme.md").is_file());
        assert!(usage(&d.join("absent")).unwrap().is_empty());
    }

    #[test]
    fn refuses_names_that_escape_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let err = cached_in(dir.path(), "../x", "k", netcdf_extension(), |_| Ok(())).unwrap_err();
        assert!(err.to_string().starts_with("job_kind:"), "{err}");
    }
}
