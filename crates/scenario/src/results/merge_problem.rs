//! Why a result folder cannot be read back or merged ([`MergeProblem`]), as
//! [`super::ResultsError::Merge`] carries it; the merge itself is
//! `crate::experiments::validation::merge`.

use std::fmt;
use std::path::PathBuf;

/// Why a folder cannot be read back or merged.
#[derive(Clone, Debug, PartialEq)]
pub enum MergeProblem {
    /// The path does not exist.
    NoSuchFolder,
    /// The path is not a folder.
    NotAFolder,
    /// A file or folder the merge needs is missing.
    MissingFile(String),
    /// A file is not valid JSON or does not have the expected fields.
    BadJson {
        /// The file, relative to the folder.
        file: String,
        /// The parser's message (with line and column).
        message: String,
    },
    /// `runs.json` is of another format or version.
    WrongFormat(String),
    /// The record contradicts itself (rows, edits, parameters) or `summary.json` disagrees.
    Inconsistent(String),
    /// Made by another tool version than the first folder.
    ToolMismatch {
        /// The first folder's tool.
        expected: String,
        /// This folder's.
        got: String,
    },
    /// Another number of worlds than the first folder.
    WorldsMismatch {
        /// The first folder's N.
        expected: usize,
        /// This folder's.
        got: usize,
    },
    /// Another updater preset than the first folder.
    PresetMismatch {
        /// The first folder's preset.
        expected: String,
        /// This folder's.
        got: String,
    },
    /// Another value of a parameter than the first folder.
    ParamsMismatch {
        /// The parameter, as a path into `params` (e.g. `runner.updater.n_b`).
        field: String,
    },
    /// Timed in one folder, `--no-timing` in the other.
    TimingMismatch,
    /// A counter the summary adds up over every row (or the scan-time histogram's counts) goes
    /// beyond `u64` with this seed, within the folder or with the folders before it.
    CountsOverflow {
        /// The counter, as a path into a world row (e.g. `updater.beams`).
        counter: &'static str,
        /// The seed whose counts do not fit.
        seed: u64,
    },
    /// A seed already given by another folder (or twice in this one).
    DuplicateSeed {
        /// The seed.
        seed: u64,
        /// The folder that has it already.
        first: PathBuf,
    },
    /// Nothing to merge.
    NoInput,
}

impl fmt::Display for MergeProblem {
    /// One line: keys, format and tool names come from the files, and serde_json quotes a key
    /// unescaped, so control characters (a JSON `"\n"` in a key) are escaped (`\n` as the two
    /// characters `\` `n`; the fuzz target `merge_json` found a two-line error).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let text = Unescaped(self).to_string();
        if !text.contains(char::is_control) {
            return f.write_str(&text);
        }
        text.chars()
            .try_for_each(|c| if c.is_control() { write!(f, "{}", c.escape_default()) } else { write!(f, "{c}") })
    }
}

/// [`MergeProblem`]'s message as its parts hold it, control characters and all.
struct Unescaped<'a>(&'a MergeProblem);

impl fmt::Display for Unescaped<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            MergeProblem::NoSuchFolder => write!(f, "no such folder"),
            MergeProblem::NotAFolder => write!(f, "not a folder"),
            MergeProblem::MissingFile(file) => write!(f, "{file} is missing"),
            MergeProblem::BadJson { file, message } => write!(f, "{file}: {message}"),
            MergeProblem::WrongFormat(m) => write!(f, "runs.json: {m}"),
            MergeProblem::Inconsistent(m) => write!(f, "{m}"),
            MergeProblem::ToolMismatch { expected, got } => {
                write!(f, "made by {got}, the first folder by {expected}")
            }
            MergeProblem::WorldsMismatch { expected, got } => {
                write!(f, "has {got} worlds, the first folder {expected}")
            }
            MergeProblem::PresetMismatch { expected, got } => {
                write!(f, "updater preset '{got}', the first folder '{expected}'")
            }
            MergeProblem::ParamsMismatch { field } => {
                write!(f, "parameter params.{field} differs from the first folder's")
            }
            MergeProblem::TimingMismatch => {
                write!(f, "timed and untimed (--no-timing) folders cannot be merged")
            }
            MergeProblem::CountsOverflow { counter, seed } => {
                write!(f, "the {counter} counts add up beyond 2^64 - 1 with seed {seed}")
            }
            MergeProblem::DuplicateSeed { seed, first } => {
                write!(f, "seed {seed} is also in {}", first.display())
            }
            MergeProblem::NoInput => write!(f, "no folder to merge"),
        }
    }
}
