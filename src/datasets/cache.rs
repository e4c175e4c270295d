//! The dataset cache: generated fields are stored once under a name made of the generator and a
//! hash of every parameter, so the demo, the case-study scripts and repeated CLI calls generate
//! each dataset once. The folder is [`cache_dir`]: `$HDRVIS_CACHE` when that is set, else
//! `datasets/cache` in the hdrvis checkout that contains the working directory, else
//! `datasets/cache` under the working directory. `datasets/cache` is git-ignored. Files appear
//! atomically: a generator writes a temporary file in the cache folder, which is renamed into
//! place only when it succeeded.

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
        let err = cached_in(dir.path(), "mantle", "k", "nc", |p| {
            std::fs::write(p, b"half").unwrap();
            Err(Error::invalid("n", "too large"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("too large"));
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let err = cached_in(dir.path(), "mantle", "k", "nc", |_| Ok(())).unwrap_err();
        assert!(err.to_string().contains("without writing"), "{err}");
    }

    #[test]
    fn refuses_names_that_escape_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let err = cached_in(dir.path(), "../x", "k", "nc", |_| Ok(())).unwrap_err();
        assert!(err.to_string().starts_with("job_kind:"), "{err}");
    }
}
