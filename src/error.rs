//! The one error type of the library. Every variant renders as a single line that names the
//! file, field or option at fault and says what was expected, so the binary can print it as is
//! and exit non-zero.

use std::path::{Path, PathBuf};

/// Result alias used across the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file was read but its contents are not what the format requires.
    #[error("{path}: {msg}")]
    Format { path: PathBuf, msg: String },
    /// A parameter, option or field has a value outside what is allowed.
    #[error("{field}: {msg}")]
    Invalid { field: String, msg: String },
    /// No usable GPU adapter, or a GPU operation failed.
    #[error("gpu: {0}")]
    Gpu(String),
    /// A script failed; the message already carries file:line:column and a caret.
    #[error("{0}")]
    Script(String),
}

impl Error {
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    pub fn format(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Error::Format {
            path: path.as_ref().to_path_buf(),
            msg: msg.into(),
        }
    }

    pub fn invalid(field: impl Into<String>, msg: impl Into<String>) -> Self {
        Error::Invalid {
            field: field.into(),
            msg: msg.into(),
        }
    }
}

/// The candidate closest to a misspelt `word` (letters swapped, dropped, added or changed, case
/// ignored), for "did you mean ...?" hints; `None` when nothing is close.
pub fn closest_name<'a>(
    word: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let word = word.to_ascii_lowercase();
    // One edit per three letters, at least one: "rnu" -> "run", "sizee" -> "size".
    let allowed = (word.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| {
            (
                strsim::damerau_levenshtein(&word, &c.to_ascii_lowercase()),
                c,
            )
        })
        .filter(|(d, _)| *d <= allowed)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// `text` quoted for a one-line message: control characters and quotes escaped, and cut after
/// `max_chars` characters with the length of the rest, so that a corrupt file's megabyte-long
/// "line" cannot flood the terminal.
pub(crate) fn excerpt(text: &str, max_chars: usize) -> String {
    let mut out = String::from("\"");
    let mut chars = text.char_indices();
    for (_, c) in chars.by_ref().take(max_chars) {
        out.extend(c.escape_debug());
    }
    out.push('"');
    if let Some((at, _)) = chars.next() {
        out.push_str(&format!("... ({} more bytes)", text.len() - at));
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn closest_name_finds_swapped_dropped_and_added_letters() {
        let names = ["run", "info", "tonemap", "output"];
        assert_eq!(super::closest_name("rnu", names), Some("run"));
        assert_eq!(super::closest_name("ouput", names), Some("output"));
        assert_eq!(super::closest_name("TONEMAPP", names), Some("tonemap"));
        assert_eq!(super::closest_name("xyz", names), None);
    }

    #[test]
    fn excerpts_escape_control_characters_and_stop_after_the_limit() {
        assert_eq!(super::excerpt("a\tb\"c", 60), r#""a\tb\"c""#);
        let nuls = "\0".repeat(1 << 20);
        let e = super::excerpt(&nuls, 60);
        assert_eq!(
            e,
            format!("\"{}\"... (1048516 more bytes)", "\\0".repeat(60))
        );
        assert_eq!(super::excerpt("ab", 1), r#""a"... (1 more bytes)"#);
    }
}
