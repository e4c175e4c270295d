//! The dataset cache: generated fields are stored once under a name made of the generator and a
//! hash of every parameter, so the demo, the case-study scripts and repeated CLI calls generate
//! each dataset once. The folder is [`cache_dir`]: `$HDRVIS_CACHE` when that is set, else
//! `datasets/cache` in the hdrvis checkout that contains the working directory (git-ignored),
//! else the platform's cache folder (`$XDG_CACHE_HOME/hdrvis`, `~/.cache/hdrvis`).
//!
//! The cache never lies and never stops a run. Each entry has a check file with its length and
//! checksum ([`crate::io::checked`]), verified when the entry is used; one that fails is set
//! aside and made again, with a [`notice`]. Makers of one entry take a lock, so concurrent runs
//! make it once (twice, harmlessly, where the file system has no locks); files appear atomically
//! (a temporary file renamed into place, its check file first). A cache folder that cannot be
//! written (read-only, permissions, quota, a full disk) sends the entry to a private folder for
//! this run ([`private_dir`]). Temporary files of killed makers are swept away by age. [`usage`],
//! [`verify_all`] and [`clean`] (`hdrvis cache du|verify|clean`) manage the folder, touching only
//! what hdrvis itself put there.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, SystemTime};

use crate::error::{Error, Result};
use crate::io::checked::{self, Sum, Verdict, FAILED_FOLDER};
use crate::io::notice;

/// The cache folder and its override live in `io`, so that the GPU pipeline cache uses the same
/// folder without `gpu` depending on `datasets`.
pub(crate) use crate::io::cache_dir;

/// A temporary file left in the cache folder longer than this untouched is the remains of a
/// killed maker (writers touch their file continuously, and a maker computes before it writes).
const STALE_AFTER: Duration = Duration::from_secs(3600);

/// The cached file for (`job_kind`, `key`, `ext`) in [`cache_dir`]; `make` writes it when it is
/// missing or fails its check. Returns the file's path either way: in the cache folder, or in
/// [`private_dir`] when the cache folder cannot be written.
pub(crate) fn cached(
    job_kind: &str,
    key: &str,
    ext: &str,
    make: impl FnMut(&Path) -> Result<()>,
) -> Result<PathBuf> {
    cached_in(&cache_dir(), job_kind, key, ext, make)
}

/// [`cached`] in an explicit folder. `make` receives a temporary path in the folder with the
/// final extension (writers choose the format from it); the file is renamed to
/// `<job_kind>-<key>.<ext>` only when `make` succeeded, and removed otherwise. `make` runs a
/// second time, in [`private_dir`], only when the cache folder could not take its file.
pub(crate) fn cached_in(
    dir: &Path,
    job_kind: &str,
    key: &str,
    ext: &str,
    mut make: impl FnMut(&Path) -> Result<()>,
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
    let name = format!("{job_kind}-{key}.{ext}");
    let entry = dir.join(&name);
    // The common case, a good entry, needs no lock and works in a read-only cache.
    if check(&entry) == Verdict::Good {
        return Ok(entry);
    }
    let why = match make_in(dir, &name, &mut make) {
        Ok(path) => return Ok(path),
        Err(Refused::Failed(e)) => return Err(e),
        Err(Refused::Unwritable(why)) => why,
    };
    let cannot = |again: String| {
        Error::format(
            &entry,
            format!(
                "cannot be made: the cache folder cannot be written ({why}), nor a private temporary folder ({again})"
            ),
        )
    };
    let private = private_dir().map_err(cannot)?;
    notice(&format!(
        "cache: {} cannot be written ({why}); {name} is made in {} for this run",
        dir.display(),
        private.display()
    ));
    make_in(private, &name, &mut make).map_err(|refused| match refused {
        Refused::Failed(e) => e,
        Refused::Unwritable(again) => cannot(again),
    })
}

/// Why an entry was not made in a folder: the folder would not take it (try elsewhere), or the
/// maker itself failed (an error for the user).
enum Refused {
    Unwritable(String),
    Failed(Error),
}

/// Makes (or finds, made meanwhile by another run) the entry `name` in `dir` under its lock.
fn make_in(
    dir: &Path,
    name: &str,
    make: &mut impl FnMut(&Path) -> Result<()>,
) -> std::result::Result<PathBuf, Refused> {
    let unwritable = |e: std::io::Error| Refused::Unwritable(e.to_string());
    std::fs::create_dir_all(dir).map_err(unwritable)?;
    sweep_stale(dir);
    let _lock = EntryLock::take(&dir.join(format!(".{name}.lock"))).map_err(unwritable)?;
    let entry = dir.join(name);
    match check(&entry) {
        Verdict::Good => return Ok(entry),
        Verdict::Missing => {}
        Verdict::Failed(why) => {
            let to = checked::set_aside(dir, &entry).map_err(|e| storage(e, dir))?;
            notice(&format!(
                "cache: {} {why}; set aside as {} and made again",
                entry.display(),
                to.display()
            ));
        }
    }
    // Unique per process and call, so makers without a lock never write the same file.
    static CALLS: AtomicU64 = AtomicU64::new(0);
    let (stem, ext) = name.rsplit_once('.').unwrap_or((name, ""));
    let tmp = dir.join(format!(
        ".{stem}.{}-{}.partial.{ext}",
        std::process::id(),
        CALLS.fetch_add(1, Ordering::Relaxed)
    ));
    let published = make(&tmp).map_err(|e| storage(e, dir)).and_then(|()| {
        if !tmp.is_file() {
            return Err(Refused::Failed(Error::format(
                &entry,
                "the generator finished without writing a file",
            )));
        }
        // The check file goes first: whoever sees the entry sees its check.
        let sum = Sum::of_file(&tmp).map_err(|e| storage(e, dir))?;
        sum.write_to(&Sum::path_beside(&entry))
            .map_err(|e| storage(e, dir))?;
        std::fs::rename(&tmp, &entry).map_err(unwritable)?;
        remember_good(&entry);
        Ok(entry.clone())
    });
    if published.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    published
}

/// A maker's error as the folder refusing the file (an I/O error on a path inside `dir`: no
/// space, quota, permissions, a read-only file system) or as the maker's own failure.
fn storage(e: Error, dir: &Path) -> Refused {
    match e {
        Error::Io { path, source } if path.starts_with(dir) => {
            Refused::Unwritable(source.to_string())
        }
        other => Refused::Failed(other),
    }
}

/// Entries this process verified, with the length and time they had then: a dataset used many
/// times in one run (a sweep, the terminal viewer's re-runs) is read in full to check it once.
static VERIFIED: Mutex<Option<HashMap<PathBuf, (u64, SystemTime)>>> = Mutex::new(None);

fn stamp(path: &Path) -> Option<(u64, SystemTime)> {
    let meta = std::fs::metadata(path).ok()?;
    Some((meta.len(), meta.modified().ok()?))
}

fn remember_good(entry: &Path) {
    if let Some(stamp) = stamp(entry) {
        let mut verified = VERIFIED.lock().unwrap_or_else(|e| e.into_inner());
        verified
            .get_or_insert_with(HashMap::new)
            .insert(entry.to_path_buf(), stamp);
    }
}

/// [`checked::verify`], skipped for an entry this process already verified unchanged.
fn check(entry: &Path) -> Verdict {
    let known = VERIFIED
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .as_ref()
        .and_then(|v| v.get(entry).copied());
    if known.is_some() && known == stamp(entry) {
        return Verdict::Good;
    }
    let verdict = checked::verify(entry);
    if verdict == Verdict::Good {
        remember_good(entry);
    }
    verdict
}

/// An exclusive lock on an entry's lock file, held while the entry is made; released on drop.
struct EntryLock {
    _held: Option<std::fs::File>,
}

impl EntryLock {
    /// Waits for the lock. An error means the folder cannot take the lock file (it cannot take
    /// the entry either); a file system without locks (some NFS mounts) gives no lock, and two
    /// makers then both make the entry, the second rename replacing the first's equal file.
    fn take(path: &Path) -> std::io::Result<EntryLock> {
        loop {
            let file = std::fs::OpenOptions::new()
                .create(true)
                .truncate(false)
                .write(true)
                .open(path)?;
            if file.lock().is_err() {
                return Ok(EntryLock { _held: None });
            }
            // `cache clean` may have removed the lock file while we waited on it: then the lock
            // we hold is on a file nobody else can open, so take the new one.
            if same_file(&file, path) {
                return Ok(EntryLock { _held: Some(file) });
            }
        }
    }
}

#[cfg(unix)]
fn same_file(file: &std::fs::File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(_: &std::fs::File, path: &Path) -> bool {
    path.exists()
}

/// Removes temporary files that killed makers left in `dir` (not touched for [`STALE_AFTER`]):
/// partial entries and the writers' `.hdrvis-*.tmp` files. Errors are ignored: this is tidying.
fn sweep_stale(dir: &Path) {
    let Ok(listing) = std::fs::read_dir(dir) else {
        return;
    };
    let now = SystemTime::now();
    for entry in listing.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let temporary = name.starts_with('.')
            && (name.contains(".partial.")
                || (name.starts_with(".hdrvis-") && name.ends_with(".tmp")));
        let old = entry
            .metadata()
            .and_then(|m| m.modified())
            .is_ok_and(|t| now.duration_since(t).unwrap_or_default() > STALE_AFTER);
        if temporary && old {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// The private folder (mode 0700 in the system's temporary folder) that entries are made in for
/// this run when the cache folder cannot take them: its path is fixed when first asked for (a
/// script's sandbox lets the script read it), the folder is created on first use, and the
/// binary removes it when it ends ([`remove_private_dir`]).
pub(crate) fn private_dir_path() -> &'static Path {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| {
        let nanos = SystemTime::now()
            .duration_since(SystemTime::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        std::env::temp_dir().join(format!("hdrvis-run-{}-{nanos:08x}", std::process::id()))
    })
}

/// [`private_dir_path`], created (by this process, so nobody else owns or can read it).
fn private_dir() -> std::result::Result<&'static Path, String> {
    static MADE: Mutex<bool> = Mutex::new(false);
    let dir = private_dir_path();
    let mut made = MADE.lock().unwrap_or_else(|e| e.into_inner());
    if !*made {
        let mut builder = std::fs::DirBuilder::new();
        #[cfg(unix)]
        {
            use std::os::unix::fs::DirBuilderExt;
            builder.mode(0o700);
        }
        builder
            .create(dir)
            .map_err(|e| format!("{}: {e}", dir.display()))?;
        *made = true;
    }
    Ok(dir)
}

/// Set by [`keep_private_dir`]: the run hands a file in the private folder to the user.
static KEEP_PRIVATE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether `path` lies in this run's private folder (the cache folder could not take it).
pub fn is_private(path: &Path) -> bool {
    path.starts_with(private_dir_path())
}

/// Keeps this run's private folder when the run ends: `hdrvis gen` prints a path in it.
pub fn keep_private_dir() {
    KEEP_PRIVATE.store(true, Ordering::SeqCst);
}

/// Removes this run's [`private_dir`], if one was made and is not kept ([`keep_private_dir`]).
pub fn remove_private_dir() {
    let dir = private_dir_path();
    if dir.is_dir() && !KEEP_PRIVATE.load(Ordering::SeqCst) {
        let _ = std::fs::remove_dir_all(dir);
    }
}

/// The compiled GPU pipelines live in this sub-folder of the cache (see `gpu`).
const PIPELINES: &str = "pipelines";

/// What the cache holds of one kind: generated datasets of one generator (`okada`, `mantle`,
/// ...), compiled `pipelines`, `partial` files a killed maker left behind, and `failed` entries
/// set aside because they failed their check.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KindUsage {
    pub kind: String,
    pub files: u64,
    pub bytes: u64,
}

/// Kinds that are no entry to verify: leftovers and what was set aside.
const PARTIAL: &str = "partial";
const FAILED: &str = "failed";

/// One file hdrvis put in the cache, with its kind; anything else in the folder is no entry.
/// A dataset entry's check file goes with it (see [`clean`]); lock files are not listed.
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
        if (name == PIPELINES || name == FAILED_FOLDER) && path.is_dir() {
            for file in std::fs::read_dir(&path).map_err(|e| Error::io(&path, e))? {
                let file = file.map_err(|e| Error::io(&path, e))?.path();
                let ours = name == FAILED_FOLDER || crate::io::extension(&file) == "bin";
                if file.is_file() && ours {
                    let kind = if name == PIPELINES { PIPELINES } else { FAILED };
                    found.push((kind.to_string(), file.clone(), file_size(&file)));
                }
            }
        } else if path.is_file() {
            if let Some(kind) = kind_of(&name) {
                found.push((kind, path.clone(), file_size(&path)));
            } else if let Some(of) = name.strip_suffix(&format!(".{}", checked::CHECK_EXTENSION)) {
                // A check file without its entry: a maker stopped between the two.
                if kind_of(of).is_some() && !dir.join(of).exists() {
                    found.push((PARTIAL.to_string(), path.clone(), file_size(&path)));
                }
            }
        }
    }
    Ok(found)
}

fn file_size(path: &Path) -> u64 {
    std::fs::metadata(path).map(|m| m.len()).unwrap_or(0)
}

/// The kind of a cache file name: `<kind>-<key>.<ext>` as [`cached`] names generated datasets
/// (the kind may hold '-'), `.…partial.…` and `.hdrvis-….tmp` for what a killed maker left;
/// `None` for names hdrvis does not write.
fn kind_of(name: &str) -> Option<String> {
    if name.starts_with('.')
        && (name.contains(".partial.") || (name.starts_with(".hdrvis-") && name.ends_with(".tmp")))
    {
        return Some(PARTIAL.to_string());
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
    for (kind, path, bytes) in entries(dir)? {
        let bytes = bytes + file_size(&checked::Sum::path_beside(&path));
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

/// One entry that failed `hdrvis cache verify`: the file, why, and where it was set aside
/// (`None` when the folder would not let it move).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FailedEntry {
    pub path: PathBuf,
    pub why: String,
    pub set_aside: Option<PathBuf>,
}

/// Checks every dataset entry and compiled-pipeline file in `dir` against its checksum, sets
/// aside those that fail (the next use makes them again), and returns how many passed and the
/// ones that failed.
pub fn verify_all(dir: &Path) -> Result<(u64, Vec<FailedEntry>)> {
    let (mut good, mut failed) = (0, Vec::new());
    for (kind, path, _) in entries(dir)? {
        if kind == PARTIAL || kind == FAILED {
            continue;
        }
        match checked::verify_any(&path) {
            Verdict::Good => good += 1,
            Verdict::Missing => {}
            Verdict::Failed(why) => failed.push(FailedEntry {
                set_aside: checked::set_aside(dir, &path).ok(),
                path,
                why,
            }),
        }
    }
    Ok((good, failed))
}

/// Removes the cache files hdrvis wrote in `dir` (of the given kinds, or all when `kinds` is
/// empty, lock files included) and returns how many files and bytes went. Other files in the
/// folder stay, so a `HDRVIS_CACHE` pointed at a shared folder loses nothing of anyone else's.
pub fn clean(dir: &Path, kinds: &[String]) -> Result<(u64, u64)> {
    let (mut files, mut bytes) = (0, 0);
    for (kind, path, size) in entries(dir)? {
        if kinds.is_empty() || kinds.contains(&kind) {
            std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            let check = checked::Sum::path_beside(&path);
            let check_size = file_size(&check);
            if std::fs::remove_file(&check).is_ok() {
                bytes += check_size;
            }
            files += 1;
            bytes += size;
        }
    }
    if kinds.is_empty() {
        remove_lock_files(dir);
    }
    Ok((files, bytes))
}

/// Removes the entries' lock files (a maker waiting on one takes the new file, see [`EntryLock`]).
fn remove_lock_files(dir: &Path) {
    if let Ok(listing) = std::fs::read_dir(dir) {
        for entry in listing.flatten() {
            let name = entry.file_name().to_string_lossy().to_string();
            if name.starts_with('.')
                && name.ends_with(".lock")
                && kind_of(&name[1..name.len() - 5]).is_some()
            {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
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
        assert_eq!(files_but_locks(dir.path()), Vec::<String>::new());
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

    /// The names in `dir` other than entries' lock files.
    fn files_but_locks(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .filter(|n| !n.ends_with(".lock"))
            .collect();
        names.sort();
        names
    }

    #[test]
    fn a_damaged_entry_is_set_aside_and_made_again() {
        let dir = tempfile::tempdir().unwrap();
        let calls = Cell::new(0);
        let make = |p: &Path| {
            calls.set(calls.get() + 1);
            std::fs::write(p, vec![3u8; 4096]).map_err(|e| Error::io(p, e))
        };
        let entry = cached_in(dir.path(), "okada", "00aa", "npy", make).unwrap();
        assert_eq!(
            files_but_locks(dir.path()),
            ["okada-00aa.npy", "okada-00aa.npy.check"]
        );
        // Changed in place with the same length and time: only the checksum can tell, and this
        // process remembers the entry as good until its length or time changes.
        let mut bytes = std::fs::read(&entry).unwrap();
        bytes[100] = 9;
        std::fs::write(&entry, &bytes).unwrap();
        VERIFIED.lock().unwrap().take();
        cached_in(dir.path(), "okada", "00aa", "npy", make).unwrap();
        assert_eq!(calls.get(), 2);
        assert_eq!(std::fs::read(&entry).unwrap(), vec![3u8; 4096]);
        let failed = usage(dir.path()).unwrap();
        assert!(
            failed.iter().any(|k| k.kind == "failed" && k.files == 1),
            "{failed:?}"
        );
        // Cut short, and the check file lost: both found, both made again.
        std::fs::OpenOptions::new()
            .write(true)
            .open(&entry)
            .unwrap()
            .set_len(10)
            .unwrap();
        cached_in(dir.path(), "okada", "00aa", "npy", make).unwrap();
        std::fs::remove_file(checked::Sum::path_beside(&entry)).unwrap();
        VERIFIED.lock().unwrap().take(); // as a new run would see it
        cached_in(dir.path(), "okada", "00aa", "npy", make).unwrap();
        assert_eq!(calls.get(), 4);
        let (good, failed) = verify_all(dir.path()).unwrap();
        assert_eq!((good, failed.len()), (1, 0));
    }

    #[test]
    fn verify_all_sets_aside_what_fails() {
        let dir = tempfile::tempdir().unwrap();
        let make = |p: &Path| std::fs::write(p, b"0123456789").map_err(|e| Error::io(p, e));
        let a = cached_in(dir.path(), "okada", "aa", "npy", make).unwrap();
        cached_in(dir.path(), "okada", "bb", "npy", make).unwrap();
        std::fs::write(&a, b"012345678X").unwrap();
        let (good, failed) = verify_all(dir.path()).unwrap();
        assert_eq!(good, 1);
        assert_eq!(failed.len(), 1);
        assert_eq!(failed[0].path, a);
        assert!(failed[0].why.contains("checksum"), "{:?}", failed[0]);
        assert!(failed[0].set_aside.as_ref().unwrap().is_file() && !a.exists());
        assert_eq!(verify_all(dir.path()).unwrap(), (1, vec![]));
    }

    #[test]
    fn an_unwritable_cache_folder_sends_the_entry_to_a_private_folder() {
        let dir = tempfile::tempdir().unwrap();
        // A folder below a plain file can never be made, whoever runs the test (root included).
        let blocked = dir.path().join("file");
        std::fs::write(&blocked, b"").unwrap();
        let cache = blocked.join("cache");
        let make = |p: &Path| std::fs::write(p, b"data").map_err(|e| Error::io(p, e));
        let made = cached_in(&cache, "okada", "cc", "npy", make).unwrap();
        assert!(made.starts_with(private_dir_path()), "{made:?}");
        assert_eq!(std::fs::read(&made).unwrap(), b"data");
        // A folder that refuses the file mid-write (no space, quota): the maker runs again there.
        let full = dir.path().join("full");
        let tries = Cell::new(0);
        let made = cached_in(&full, "okada", "dd", "npy", |p: &Path| {
            tries.set(tries.get() + 1);
            if p.starts_with(&full) {
                let e = std::io::Error::from_raw_os_error(28);
                return Err(Error::io(p, e));
            }
            std::fs::write(p, b"data").map_err(|e| Error::io(p, e))
        })
        .unwrap();
        assert_eq!(tries.get(), 2);
        assert!(made.starts_with(private_dir_path()));
        assert_eq!(files_but_locks(&full), Vec::<String>::new());
    }

    #[test]
    fn concurrent_makers_make_an_entry_once() {
        let dir = tempfile::tempdir().unwrap();
        let calls = AtomicU64::new(0);
        std::thread::scope(|scope| {
            for _ in 0..4 {
                scope.spawn(|| {
                    cached_in(dir.path(), "mantle", "ee", "npy", |p: &Path| {
                        calls.fetch_add(1, Ordering::SeqCst);
                        std::thread::sleep(Duration::from_millis(200));
                        std::fs::write(p, b"slow").map_err(|e| Error::io(p, e))
                    })
                    .unwrap();
                });
            }
        });
        assert_eq!(calls.load(Ordering::SeqCst), 1);
    }

    #[test]
    fn stale_temporaries_are_swept_by_age() {
        let dir = tempfile::tempdir().unwrap();
        let old = dir.path().join(".okada-ff.99-0.partial.npy");
        let fresh = dir.path().join(".hdrvis-abc.tmp");
        std::fs::write(&old, b"x").unwrap();
        std::fs::write(&fresh, b"x").unwrap();
        let long_ago = SystemTime::now() - STALE_AFTER - Duration::from_secs(60);
        std::fs::File::options()
            .write(true)
            .open(&old)
            .unwrap()
            .set_modified(long_ago)
            .unwrap();
        sweep_stale(dir.path());
        assert!(!old.exists() && fresh.exists());
    }

    #[test]
    fn refuses_names_that_escape_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        let err = cached_in(dir.path(), "../x", "k", netcdf_extension(), |_| Ok(())).unwrap_err();
        assert!(err.to_string().starts_with("job_kind:"), "{err}");
    }
}
