//! What can go wrong reading a recorded log. Every error names the file; parse errors also name
//! the place in it (a line, a byte offset, a record or message index, a topic).

use std::path::{Path, PathBuf};

/// A log could not be read or turned into a sensor log.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
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

    /// A parse error on `path` at `place` (control characters of the message, which may quote
    /// the file, escaped: the error stays one line).
    pub fn parse(path: &Path, place: impl Into<String>, message: impl Into<String>) -> Self {
        ImportError::Parse {
            path: path.to_path_buf(),
            place: one_line(&place.into()),
            message: one_line(&message.into()),
        }
    }

    /// A log of `path` that cannot be used.
    pub fn unusable(path: &Path, message: impl Into<String>) -> Self {
        ImportError::Unusable { path: path.to_path_buf(), message: one_line(&message.into()) }
    }
}

/// `s` with its control characters escaped (`\n`, `\u{1b}`, …), so an error that quotes a
/// file's bytes is one line.
pub fn one_line(s: &str) -> String {
    if !s.chars().any(char::is_control) {
        return s.to_string();
    }
    s.chars().map(|c| if c.is_control() { c.escape_default().to_string() } else { c.to_string() }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_quoting_the_file_stay_one_line() {
        let e = ImportError::parse(Path::new("a.bag"), "byte 0", "'#ROSBAG V1.\n x': only 2.0 is read");
        assert_eq!(e.to_string(), "a.bag: byte 0: '#ROSBAG V1.\\n x': only 2.0 is read");
        let e = ImportError::unusable(Path::new("b.log"), "tab\there\u{1b}[1m");
        assert!(!e.to_string().contains(['\n', '\t', '\u{1b}']), "{e}");
        assert_eq!(one_line("plain"), "plain");
    }
}
