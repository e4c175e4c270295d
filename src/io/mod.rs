//! Image files — OpenEXR (the linear HDR master) and PNG (display views) — and movies of frame
//! sequences ([`animation`]), and the one way every output is written: to a temporary file in the
//! destination folder that is renamed into place, so no reader ever sees a half-written file. The
//! terminal is a sink too: [`terminal`] prints pictures inline, once. Also the one folder hdrvis
//! caches things in (generated datasets, compiled GPU pipelines): [`cache_location`].

pub mod animation;
pub(crate) mod checked;
pub mod exr;
pub mod png;
pub mod progress;
pub mod terminal;
pub(crate) mod terminal_query;

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
    // Errors name the output, whichever step failed: the user asked for that file.
    std::fs::create_dir_all(dir).map_err(|e| Error::io(path, e))?;
    // tempfile's error names the temporary file; the system's own error says it plainly.
    let mut tmp = temporary_beside(dir).map_err(|e| match e {
        Error::Io { source, .. } => match source.raw_os_error() {
            Some(code) => Error::io(path, std::io::Error::from_raw_os_error(code)),
            None => Error::io(path, source),
        },
        other => other,
    })?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        fill(&mut w)?;
        w.flush().map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    persist(tmp, path)
}

/// Where [`notice`] lines go: stderr unless a front end (the terminal viewer) takes them.
type NoticeSink = Box<dyn Fn(&str) + Send + Sync>;
static NOTICES: std::sync::Mutex<(Option<NoticeSink>, Vec<String>)> =
    std::sync::Mutex::new((None, Vec::new()));

/// Tells the user, in one line, something hdrvis did on their behalf that they would want to
/// know (a damaged cache entry made again, a cache folder it could not write): on stderr as
/// `note: …`, or to the sink a front end installed. Each distinct line is told once per process.
pub fn notice(line: &str) {
    let mut notices = NOTICES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if notices.1.iter().any(|told| told == line) {
        return;
    }
    notices.1.push(line.to_string());
    match &notices.0 {
        Some(sink) => sink(line),
        None => eprintln!("note: {line}"),
    }
}

/// Sends [`notice`] lines to `sink` instead of stderr (a full-screen front end shows them itself).
pub fn set_notice_sink(sink: impl Fn(&str) + Send + Sync + 'static) {
    NOTICES
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .0 = Some(Box::new(sink));
}

/// Held while a finished file takes its final name and, for a script's output, while the run
/// records it: a run stopped by a signal holds it too before it lists what it wrote, so the
/// list names exactly the outputs that exist (see [`hold_outputs`]).
static OUTPUTS: std::sync::Mutex<()> = std::sync::Mutex::new(());

std::thread_local! {
    /// The output [`recording_output`] expects on this thread and what records it.
    static RECORDER: std::cell::RefCell<Option<(PathBuf, Recorder)>> =
        const { std::cell::RefCell::new(None) };
}

/// What records an output (a script run's list and its observer).
pub(crate) type Recorder = Box<dyn Fn(&Path)>;

/// Renames a complete temporary file to `path`, the one way an output appears; an output that
/// [`recording_output`] expects is recorded before anyone holding [`hold_outputs`] can look.
pub(crate) fn persist(tmp: tempfile::NamedTempFile, path: &Path) -> Result<()> {
    let _held = OUTPUTS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    let expected = RECORDER.with(|slot| {
        let mut slot = slot.borrow_mut();
        match slot.as_ref() {
            Some((expected, _)) if expected == path => slot.take(),
            _ => None,
        }
    });
    if let Some((_, record)) = expected {
        record(path);
    }
    Ok(())
}

/// Runs `write`, which writes the output `path`, and calls `record(path)` the moment the file
/// has its final name, without letting go of [`OUTPUTS`] in between.
pub(crate) fn recording_output(
    path: &Path,
    record: Recorder,
    write: impl FnOnce() -> Result<()>,
) -> Result<()> {
    RECORDER.with(|slot| *slot.borrow_mut() = Some((path.to_path_buf(), record)));
    let result = write();
    // Still here if `write` failed, or wrote `path` without [`persist`] (then it is recorded now).
    let unrecorded = RECORDER.with(|slot| slot.borrow_mut().take());
    if let (Ok(()), Some((_, record))) = (&result, unrecorded) {
        record(path);
    }
    result
}

/// Stops outputs from appearing while the guard lives and waits for one that is appearing to be
/// recorded. A run stopped by a signal takes it, never to give it back, before it says what the
/// run wrote: every file under its final name is then in that list, and a file still being
/// written stays a temporary, which `--resume` sweeps away.
pub fn hold_outputs() -> std::sync::MutexGuard<'static, ()> {
    OUTPUTS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// [`write_atomic`] for writers that speak `std::io` errors (the netCDF and VTK
/// encoders).
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<()> {
    write_atomic(path, |out| write(out).map_err(|e| Error::io(path, e)))
}

/// Writes a text file atomically (see [`write_atomic`]): job scripts, reports.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |w| {
        w.write_all(text.as_bytes()).map_err(|e| Error::io(path, e))
    })
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

/// Refuses anything but a regular file (symlinks followed) before a reader opens `path`: opening
/// a FIFO that has no writer blocks forever, and a device or socket holds no data file. Every
/// reader of input files checks here first; a missing file is the usual "no such file".
pub(crate) fn check_regular_file(path: &Path) -> Result<()> {
    let meta = match std::fs::metadata(path) {
        Ok(meta) => meta,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(Error::io(
                path,
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            ))
        }
        Err(e) => return Err(Error::io(path, e)),
    };
    if meta.is_file() {
        return Ok(());
    }
    let kind = meta.file_type();
    #[cfg(unix)]
    let special = {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_fifo() {
            Some("a FIFO (named pipe)")
        } else if kind.is_char_device() || kind.is_block_device() {
            Some("a device")
        } else if kind.is_socket() {
            Some("a socket")
        } else {
            None
        }
    };
    #[cfg(not(unix))]
    let special: Option<&str> = None;
    let what = special.unwrap_or(if kind.is_dir() {
        "a folder"
    } else {
        "not a file"
    });
    Err(Error::format(
        path,
        format!("is {what}, not a regular file; expected a data file to read"),
    ))
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

/// The folder hdrvis caches generated datasets and compiled pipelines in; see [`cache_location`].
pub(crate) fn cache_dir() -> PathBuf {
    cache_location().0
}

/// The cache folder and the rule that chose it, in words (`hdrvis doctor` shows both):
/// `$HDRVIS_CACHE` when set; else `datasets/cache` of the hdrvis checkout the working directory
/// lies in (a folder whose `Cargo.toml` names the package `hdrvis`: developers and the tests
/// share what they generated); else the platform's cache folder, `$XDG_CACHE_HOME/hdrvis` or
/// `~/.cache/hdrvis`. Never the working directory itself, where an installed tool has no
/// business leaving files.
pub fn cache_location() -> (PathBuf, &'static str) {
    let set = |name: &str| std::env::var_os(name).filter(|d| !d.is_empty());
    if let Some(dir) = set(CACHE_ENV) {
        return (PathBuf::from(dir), "from HDRVIS_CACHE");
    }
    let cwd = std::env::current_dir().ok();
    if let Some(root) = cwd
        .iter()
        .flat_map(|cwd| cwd.ancestors())
        .find(|dir| is_hdrvis_checkout(dir))
    {
        return (
            root.join("datasets").join("cache"),
            "datasets/cache of the hdrvis checkout around the working directory",
        );
    }
    // The XDG base-directory rules ignore a relative XDG_CACHE_HOME.
    if let Some(xdg) = set("XDG_CACHE_HOME").filter(|d| Path::new(d).is_absolute()) {
        return (PathBuf::from(xdg).join("hdrvis"), "$XDG_CACHE_HOME/hdrvis");
    }
    match set("HOME") {
        Some(home) => (
            PathBuf::from(home).join(".cache").join("hdrvis"),
            "~/.cache/hdrvis",
        ),
        None => (
            std::env::temp_dir().join("hdrvis-cache"),
            "the temporary folder (no HOME or XDG_CACHE_HOME)",
        ),
    }
}

fn is_hdrvis_checkout(dir: &Path) -> bool {
    std::fs::read_to_string(dir.join("Cargo.toml"))
        .map(|text| {
            text.lines()
                .any(|line| line.replace(' ', "") == "name=\"hdrvis\"")
        })
        .unwrap_or(false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// A recorder that keeps what it was told, and checks that it is told while no one can
    /// hold the outputs (so a stop handler never lists without it).
    fn keeping(list: &Arc<Mutex<Vec<PathBuf>>>) -> Recorder {
        let list = list.clone();
        Box::new(move |p: &Path| {
            assert!(OUTPUTS.try_lock().is_err(), "recorded outside the lock");
            list.lock().unwrap().push(p.to_path_buf());
        })
    }

    #[test]
    fn an_output_appears_only_once_the_holder_lets_go_and_is_recorded_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        let list = Arc::new(Mutex::new(Vec::new()));
        let held = hold_outputs();
        let writer = {
            let (path, list) = (path.clone(), list.clone());
            std::thread::spawn(move || {
                recording_output(&path, keeping(&list), || write_text(&path, "x"))
            })
        };
        std::thread::sleep(std::time::Duration::from_millis(200));
        assert!(!path.exists() && list.lock().unwrap().is_empty());
        drop(held);
        writer.join().unwrap().unwrap();
        assert_eq!(*list.lock().unwrap(), std::slice::from_ref(&path));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "x");
        // Only the expected output is recorded: a file written on the way is not.
        let other = dir.path().join("b.txt");
        let path_c = dir.path().join("c.txt");
        recording_output(&path_c, keeping(&list), || {
            write_text(&other, "side")?;
            write_text(&path_c, "y")
        })
        .unwrap();
        assert_eq!(*list.lock().unwrap(), [path, path_c]);
    }

    #[test]
    fn a_failed_write_records_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        let list = Arc::new(Mutex::new(Vec::new()));
        let failed = recording_output(&path, keeping(&list), || {
            write_atomic(&path, |_| Err(Error::invalid("test", "no")))
        });
        assert!(failed.is_err() && !path.exists() && list.lock().unwrap().is_empty());
        // Nothing is left expected: a later write of the same name is not recorded.
        write_text(&path, "z").unwrap();
        assert!(list.lock().unwrap().is_empty());
    }
}
