//! What can go wrong reading a recorded log. Every error names the file; parse errors also name
//! the place in it (a line, a byte offset, a record or message index, a topic).

use std::path::{Path, PathBuf};

/// A log could not be read or turned into a sensor log.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The file could not be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file's content is malformed at a place.
    #[error("{path}: {place}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where in the file: `line 12`, `byte 4096`, `message 17 on /scan`, …
        place: String,
        /// What is wrong.
        message: String,
    },
    /// The project's own sensor log is malformed (the error names the file and line).
    #[error(transparent)]
    Log(#[from] mapkeeper_sensor::LogError),
    /// The file is readable but cannot give a usable sensor log (no scans, a topic that is not
    /// there, a transform that is missing, …).
    #[error("{path}: {message}")]
    Unusable {
        /// The file.
        path: PathBuf,
        /// What is missing or inconsistent, with what would fix it.
        message: String,
    },
}

impl ImportError {
    /// An I/O error on `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        ImportError::Io { path: path.to_path_buf(), source }
    }

    /// A parse error on `path` at `place`.
    pub fn parse(path: &Path, place: impl Into<String>, message: impl Into<String>) -> Self {
        ImportError::Parse { path: path.to_path_buf(), place: place.into(), message: message.into() }
    }

    /// A log of `path` that cannot be used.
    pub fn unusable(path: &Path, message: impl Into<String>) -> Self {
        ImportError::Unusable { path: path.to_path_buf(), message: message.into() }
    }
}
