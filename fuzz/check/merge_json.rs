//! The property of the `merge_json` fuzz target, shared with its replay test
//! (`crates/scenario/tests/fuzz_corpus.rs` includes this file with `#[path]`): the files of a
//! validation folder that `mapkeeper merge` reads back, checked as `load_result_dir` checks
//! them, without the file system.
//!
//! An input is the text of `runs.json`, then a NUL byte and the text of `summary.json` (no NUL:
//! `summary.json` is empty). `runs.json` goes through `parse_runs_json`; if it is accepted,
//! `summary.json` through `check_summary_json`, and the record is merged with itself, which
//! must be refused for the duplicate seed.
//!
//! - Nothing panics (the recomputed summary included).
//! - Every refusal is one line that starts with the folder and names the problem; a JSON
//!   error names the file, the line and the column.
//!
//! Deterministic: no clock, no randomness.

use mapkeeper_scenario::ResultsError;
use mapkeeper_scenario::experiments::validation::merge::{check_summary_json, merge_records, parse_runs_json};
use mapkeeper_scenario::results::MergeProblem;
use std::path::{Path, PathBuf};

/// The folder the errors name.
pub const DIR: &str = "fuzz-input";

/// What one input did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Checked {
    /// `runs.json` refused as JSON (syntax or fields).
    pub bad_runs_json: usize,
    /// `runs.json` refused for its format, version or content.
    pub bad_runs: usize,
    /// `runs.json` accepted.
    pub runs_ok: usize,
    /// `summary.json` refused (JSON or disagreement).
    pub bad_summary: usize,
    /// Both accepted.
    pub accepted: usize,
}

/// Runs the property on `data`; panics if it does not hold.
pub fn check(data: &[u8]) -> Checked {
    let mut out = Checked::default();
    let (runs, summary) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let (Ok(runs), Ok(summary)) = (std::str::from_utf8(runs), std::str::from_utf8(summary)) else {
        return out;
    };
    let dir = Path::new(DIR);
    let record = match parse_runs_json(dir, runs) {
        Ok(r) => r,
        Err(e) => {
            match refusal(&e, "runs.json") {
                Kind::Json => out.bad_runs_json += 1,
                Kind::Other => out.bad_runs += 1,
            }
            return out;
        }
    };
    out.runs_ok += 1;
    match check_summary_json(dir, &record, summary) {
        Ok(()) => out.accepted += 1,
        Err(e) => {
            refusal(&e, "summary.json");
            out.bad_summary += 1;
        }
    }
    let seed = record.seeds.first().map(|s| s.seed);
    let twice = [(PathBuf::from("a"), record.clone()), (PathBuf::from("b"), record)];
    match merge_records(&twice) {
        Err(ResultsError::Merge { problem: MergeProblem::DuplicateSeed { seed: s, .. }, .. }) => {
            assert_eq!(Some(s), seed, "the duplicate named is not the first seed");
        }
        other => panic!("a folder merged with itself: {other:?}"),
    }
    out
}

enum Kind {
    Json,
    Other,
}

/// Checks the message of a refusal of `file`; says whether it is a JSON error.
fn refusal(e: &ResultsError, file: &str) -> Kind {
    let m = e.to_string();
    assert!(!m.contains('\n'), "a refusal of more than one line: {m}");
    assert!(m.starts_with(&format!("{DIR}: cannot merge: ")), "a refusal that does not name the folder: {m}");
    let ResultsError::Merge { problem, .. } = e else { panic!("not a merge problem: {m}") };
    match problem {
        MergeProblem::BadJson { file: f, message } => {
            assert_eq!(f, file, "{m}");
            assert!(message.contains(" line ") && message.contains(" column "), "a JSON error without its place: {m}");
            Kind::Json
        }
        MergeProblem::WrongFormat(_)
        | MergeProblem::Inconsistent(_)
        | MergeProblem::DuplicateSeed { .. }
        | MergeProblem::CountsOverflow { .. } => Kind::Other,
        other => panic!("{file} refused for {other:?}, which needs the file system: {m}"),
    }
}
