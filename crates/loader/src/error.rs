//! The one error type of the library. Every variant names what was wrong (the file, the
//! configuration key, the argument) and, where it helps, what is allowed instead.

use std::path::PathBuf;

/// What went wrong reading, verifying or sampling a table, with the file or key it concerns.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The operating system refused a read or a write.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder the operation was on.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },

    /// A file exists but is not what it claims to be (malformed, foreign, an unsupported variant,
    /// or a format this build of the crate does not read).
    #[error("{}: {reason}", path.display())]
    Format {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong with it, in words.
        reason: String,
    },

    /// A file that differs from its entry in `manifest.json` (its length, SHA-256, axes,
    /// channels, value range or sealed claims): replaced, truncated or edited after its build.
    /// Rebuild the folder, or restore the file.
    #[error("{}: {reason}", path.display())]
    Mismatch {
        /// The file that differs.
        path: PathBuf,
        /// Every way it differs, in words.
        reason: String,
    },

    /// A folder whose build was interrupted while it moved its files into place: its files and
    /// its manifest may disagree until a build into the folder completes the commit.
    #[error("{}: {reason}", path.display())]
    Unfinished {
        /// The journal the interrupted build left.
        path: PathBuf,
        /// What happened and how to complete it.
        reason: String,
    },

    /// The manifest lists no file (or no table of the kind asked for) by that name.
    #[error("{}: {reason}", path.display())]
    Missing {
        /// The manifest asked.
        path: PathBuf,
        /// What is missing, and what the manifest lists instead.
        reason: String,
    },

    /// A file holds a table, but not of the shape the handle reads (its axes or channels).
    #[error("{}: {reason}", path.display())]
    WrongTable {
        /// The file opened.
        path: PathBuf,
        /// The table it holds and the shape the handle reads.
        reason: String,
    },

    /// A text file (a form file) is wrong at one place: its line and column, 1-based, the column
    /// counted in characters, as editors count them.
    #[error("{}:{line}:{column}: {reason}", path.display())]
    At {
        /// The text file at fault.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// The column in characters, from 1.
        column: usize,
        /// What is wrong there, in words.
        reason: String,
    },

    /// A configuration key or a command-line value is out of what is allowed.
    #[error("{key}: {reason}")]
    Invalid {
        /// The key, value or argument at fault, as the caller named it.
        key: String,
        /// What is wrong and, where it helps, what is allowed.
        reason: String,
    },
}

impl Error {
    /// An [`Error::Io`] on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }

    /// An [`Error::Format`]: `path` is not what it claims to be, for `reason`.
    pub fn format(path: impl Into<PathBuf>, reason: impl Into<String>) -> Self {
        Error::Format { path: path.into(), reason: reason.into() }
    }

    /// The error at byte `offset` of `text`, the contents of `path`.
    pub fn at(path: impl Into<PathBuf>, text: &str, offset: usize, reason: impl Into<String>) -> Self {
        let mut end = offset.min(text.len());
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        let before = &text[..end];
        let line = before.matches('\n').count() + 1;
        let column = before.rsplit('\n').next().unwrap_or_default().chars().count() + 1;
        Error::At { path: path.into(), line, column, reason: reason.into() }
    }

    /// An [`Error::Invalid`]: `key` is out of what is allowed, for `reason`.
    pub fn invalid(key: impl Into<String>, reason: impl Into<String>) -> Self {
        Error::Invalid { key: key.into(), reason: reason.into() }
    }
}

/// The result of the library's fallible operations, [`Error`] unless stated.
pub type Result<T, E = Error> = std::result::Result<T, E>;
