//! `hdrvis cache du|verify|clean` and the cache line of `hdrvis doctor`: where generated datasets
//! and compiled pipelines are kept, how much each kind takes, whether each entry still holds what
//! was written, and removing them.

use hdrvis::datasets::cache::{clean, usage, verify_all};
use hdrvis::io::cache_location;
use hdrvis::Result;

#[derive(clap::Subcommand, Debug)]
pub enum CacheCommand {
    /// Files and sizes per kind (generator, pipelines, partial, failed) in the cache folder.
    Du,
    /// Check every entry against the length and checksum written with it; entries that fail
    /// are set aside (made again when next used) and the command exits with status 1.
    Verify,
    /// Remove cached files: all of them, or only the kinds named (as `du` lists them).
    Clean {
        /// Kinds to remove, e.g. `okada mantle`; all kinds when none are given.
        kinds: Vec<String>,
    },
}

/// The doctor's line: `cache: PATH (RULE)`.
pub fn cache_line() -> String {
    let (dir, rule) = cache_location();
    format!("cache: {} ({rule})", dir.display())
}

/// Runs a `hdrvis cache` command and returns what it prints, and whether every entry passed
/// (`verify` only; the other commands always pass).
pub fn run_cache(cmd: &CacheCommand) -> Result<(String, bool)> {
    let (dir, _) = cache_location();
    let mut out = format!("{}\n", cache_line());
    match cmd {
        CacheCommand::Du => {
            let kinds = usage(&dir)?;
            let (mut files, mut bytes) = (0, 0);
            for k in &kinds {
                out += &format!("{:<20} {:>6} files {:>10}\n", k.kind, k.files, mib(k.bytes));
                files += k.files;
                bytes += k.bytes;
            }
            out += &format!("{:<20} {files:>6} files {:>10}\n", "total", mib(bytes));
        }
        CacheCommand::Verify => {
            let (good, failed) = verify_all(&dir)?;
            for f in &failed {
                let fate = match &f.set_aside {
                    Some(to) => format!("set aside as {}", to.display()),
                    None => "could not be set aside (the folder cannot be written)".into(),
                };
                out += &format!("failed: {}: {}; {fate}\n", f.path.display(), f.why);
            }
            out += &format!("{good} entries good, {} failed\n", failed.len());
            return Ok((out, failed.is_empty()));
        }
        CacheCommand::Clean { kinds } => {
            let (files, bytes) = clean(&dir, kinds)?;
            out += &format!("removed {files} files, {}\n", mib(bytes));
        }
    }
    Ok((out, true))
}

fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / (1u64 << 20) as f64)
}
