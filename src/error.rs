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
