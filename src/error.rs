//! The one error type of the library. Every variant names what was wrong (the file, the
//! configuration key, the argument) and, where it helps, what is allowed instead.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The operating system refused a read or a write.
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },

    /// A file exists but is not what it claims to be (truncated, foreign, unsupported variant).
    #[error("{}: {reason}", path.display())]
    Format { path: PathBuf, reason: String },

    /// A configuration key or a command-line value is out of what is allowed.
    #[error("{key}: {reason}")]
    Invalid { key: String, reason: String },
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }

    pub fn format(path: impl Into<PathBuf>, reason: impl Into<String>) -> Self {
        Error::Format { path: path.into(), reason: reason.into() }
    }

    pub fn invalid(key: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Invalid { key: key.into(), reason: reason.into() }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
