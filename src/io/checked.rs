//! Files that prove themselves: a length and an xxh3-64 checksum of a file's bytes, written when
//! the file is made and compared when it is used, so that a cache entry cut short (a crashed
//! node, a full quota) or changed on disk (a bad copy, bit rot) is noticed instead of read. A
//! dataset entry keeps its check in a small text file beside it ([`Sum::write_beside`]); a blob
//! that hdrvis alone reads (compiled GPU pipelines) carries it in a header ([`seal`]). Entries
//! that fail are moved into a `failed` folder ([`set_aside`]) where `hdrvis cache du` counts
//! them, rather than deleted, so that a damaged file can still be looked at.

use crate::error::{Error, Result};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The extension of the check file beside an entry: `okada-….nc` is checked by `okada-….nc.check`.
pub(crate) const CHECK_EXTENSION: &str = "check";

/// The folder, inside a cache folder, that entries which failed their check are moved to.
pub(crate) const FAILED_FOLDER: &str = "failed";

/// First line of a check file; a future format changes the version.
const CHECK_HEADER: &str = "hdrvis cache check v1";

/// A file's length in bytes and the xxh3-64 hash of its bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Sum {
    pub len: u64,
    pub xxh3: u64,
}

impl Sum {
    /// The sum of bytes in memory.
    pub(crate) fn of_bytes(bytes: &[u8]) -> Sum {
        Sum {
            len: bytes.len() as u64,
            xxh3: xxhash_rust::xxh3::xxh3_64(bytes),
        }
    }

    /// The sum of a file, read in 4 MiB pieces (one pass; the page cache keeps the bytes for
    /// the reader that follows).
    pub(crate) fn of_file(path: &Path) -> Result<Sum> {
        let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
        let mut hasher = xxhash_rust::xxh3::Xxh3::new();
        let mut buf = vec![0u8; 4 << 20];
        let mut len = 0u64;
        loop {
            let n = file.read(&mut buf).map_err(|e| Error::io(path, e))?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
            len += n as u64;
        }
        Ok(Sum {
            len,
            xxh3: hasher.digest(),
        })
    }

    /// The check file of `entry`.
    pub(crate) fn path_beside(entry: &Path) -> PathBuf {
        let mut name = entry.as_os_str().to_os_string();
        name.push(".");
        name.push(CHECK_EXTENSION);
        PathBuf::from(name)
    }

    fn to_text(self) -> String {
        format!(
            "{CHECK_HEADER}\nlength {}\nxxh3 {:016x}\n",
            self.len, self.xxh3
        )
    }

    fn from_text(text: &str) -> Option<Sum> {
        let mut lines = text.lines();
        if lines.next()? != CHECK_HEADER {
            return None;
        }
        let len = lines.next()?.strip_prefix("length ")?.parse().ok()?;
        let xxh3 = u64::from_str_radix(lines.next()?.strip_prefix("xxh3 ")?, 16).ok()?;
        Some(Sum { len, xxh3 })
    }

    /// Writes the check file `check` (atomically, so it is whole or absent).
    pub(crate) fn write_to(self, check: &Path) -> Result<()> {
        super::write_text(check, &self.to_text())
    }

    /// The sum recorded in `check`; `None` when it is missing or not a check file.
    pub(crate) fn read_from(check: &Path) -> Option<Sum> {
        std::fs::read_to_string(check)
            .ok()
            .and_then(|t| Sum::from_text(&t))
    }
}

/// What checking a file against its recorded sum found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// Length and checksum match.
    Good,
    /// No file there.
    Missing,
    /// The file is there but fails: why, in a few words.
    Failed(String),
}

/// Checks `entry` against its check file: the length first (a truncated entry costs a `stat`),
/// then every byte.
pub(crate) fn verify(entry: &Path) -> Verdict {
    let meta = match std::fs::metadata(entry) {
        Ok(m) if m.is_file() => m,
        Ok(_) => return Verdict::Failed("is not a regular file".into()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Verdict::Missing,
        Err(e) => return Verdict::Failed(format!("cannot be read ({e})")),
    };
    let Some(recorded) = Sum::read_from(&Sum::path_beside(entry)) else {
        return Verdict::Failed(
            "has no check file (an older hdrvis wrote it, or it was cut short while made)".into(),
        );
    };
    if meta.len() != recorded.len {
        return Verdict::Failed(format!(
            "is {} bytes long where {} were written",
            meta.len(),
            recorded.len
        ));
    }
    match Sum::of_file(entry) {
        Ok(sum) if sum == recorded => Verdict::Good,
        Ok(_) => Verdict::Failed("its bytes changed since it was written (checksum)".into()),
        Err(e) => Verdict::Failed(format!("cannot be read ({e})")),
    }
}

/// Moves `entry` and its check file into the `failed` folder of `cache_dir`, named with the time,
/// so the next maker starts afresh and the damaged file can still be inspected. Returns where it
/// went.
pub(crate) fn set_aside(cache_dir: &Path, entry: &Path) -> Result<PathBuf> {
    let failed = cache_dir.join(FAILED_FOLDER);
    std::fs::create_dir_all(&failed).map_err(|e| Error::io(&failed, e))?;
    let stamp = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let name = entry.file_name().unwrap_or_default().to_string_lossy();
    let to = failed.join(format!("{name}.{stamp}-{}", std::process::id()));
    match std::fs::rename(entry, &to) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(Error::io(entry, e)),
    }
    let check = Sum::path_beside(entry);
    match std::fs::remove_file(&check) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(Error::io(&check, e)),
    }
    Ok(to)
}

/// Magic bytes of a sealed blob, then its length and checksum (little-endian u64s).
const SEAL_MAGIC: &[u8; 8] = b"HDRVSEAL";
const SEAL_HEADER: usize = 24;

/// `data` with a header that records its length and checksum, for [`unseal`].
pub(crate) fn seal(data: &[u8]) -> Vec<u8> {
    let sum = Sum::of_bytes(data);
    let mut out = Vec::with_capacity(SEAL_HEADER + data.len());
    out.extend_from_slice(SEAL_MAGIC);
    out.extend_from_slice(&sum.len.to_le_bytes());
    out.extend_from_slice(&sum.xxh3.to_le_bytes());
    out.extend_from_slice(data);
    out
}

/// The data of a sealed blob, or why it fails its check.
pub(crate) fn unseal(blob: &[u8]) -> std::result::Result<&[u8], String> {
    if blob.len() < SEAL_HEADER || &blob[..8] != SEAL_MAGIC {
        return Err("has no hdrvis checksum header".into());
    }
    let word = |i: usize| u64::from_le_bytes(blob[i..i + 8].try_into().expect("8 bytes"));
    let data = &blob[SEAL_HEADER..];
    let recorded = Sum {
        len: word(8),
        xxh3: word(16),
    };
    if data.len() as u64 != recorded.len {
        return Err(format!(
            "holds {} bytes where {} were written",
            data.len(),
            recorded.len
        ));
    }
    if Sum::of_bytes(data) != recorded {
        return Err("its bytes changed since it was written (checksum)".into());
    }
    Ok(data)
}

/// Checks a file that is either a sealed blob (compiled pipelines) or an entry with a check file
/// beside it, as `hdrvis cache verify` does for every entry.
pub(crate) fn verify_any(entry: &Path) -> Verdict {
    if super::extension(entry) == "bin" {
        return match std::fs::read(entry) {
            Ok(blob) => match unseal(&blob) {
                Ok(_) => Verdict::Good,
                Err(why) => Verdict::Failed(why),
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Verdict::Missing,
            Err(e) => Verdict::Failed(format!("cannot be read ({e})")),
        };
    }
    verify(entry)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn xxh3_matches_the_reference_vectors() {
        // XXH3_64bits with seed 0 of "" and "a", from the xxHash repository's sanity checks.
        assert_eq!(Sum::of_bytes(b"").xxh3, 0x2d06800538d394c2);
        assert_eq!(Sum::of_bytes(b"a").xxh3, 0xe6c632b61e964e1f);
    }

    #[test]
    fn a_file_checks_until_it_is_cut_or_changed() {
        let dir = tempfile::tempdir().unwrap();
        let entry = dir.path().join("okada-0123.nc");
        assert_eq!(verify(&entry), Verdict::Missing);
        std::fs::write(&entry, vec![7u8; 10_000]).unwrap();
        assert!(matches!(verify(&entry), Verdict::Failed(w) if w.contains("no check file")));
        Sum::of_file(&entry)
            .unwrap()
            .write_to(&Sum::path_beside(&entry))
            .unwrap();
        assert_eq!(verify(&entry), Verdict::Good);
        // Cut short: the length says so.
        let f = std::fs::OpenOptions::new()
            .write(true)
            .open(&entry)
            .unwrap();
        f.set_len(4000).unwrap();
        assert!(
            matches!(verify(&entry), Verdict::Failed(w) if w.contains("4000 bytes long where 10000"))
        );
        // Same length, one byte changed: the checksum says so.
        let mut bytes = vec![7u8; 10_000];
        bytes[5000] = 8;
        std::fs::write(&entry, &bytes).unwrap();
        assert!(matches!(verify(&entry), Verdict::Failed(w) if w.contains("checksum")));
        let to = set_aside(dir.path(), &entry).unwrap();
        assert!(to.starts_with(dir.path().join(FAILED_FOLDER)) && to.is_file());
        assert!(!entry.exists() && !Sum::path_beside(&entry).exists());
    }

    #[test]
    fn sealed_blobs_refuse_every_damage() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7) as u8).collect();
        let blob = seal(&data);
        assert_eq!(unseal(&blob).unwrap(), &data[..]);
        assert!(unseal(&blob[..500]).unwrap_err().contains("where 1000"));
        let mut changed = blob.clone();
        changed[700] ^= 1;
        assert!(unseal(&changed).unwrap_err().contains("checksum"));
        assert!(unseal(&data).unwrap_err().contains("no hdrvis checksum"));
        assert!(unseal(b"").is_err());
    }
}
