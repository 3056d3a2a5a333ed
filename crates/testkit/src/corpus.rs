//! The walk over the kept fuzz corpus (`fuzz/corpus/<target>/`, `docs/reliability.md`): each
//! crate's `tests/fuzz_corpus.rs` says what it feeds each file to and what it asserts; the
//! finding of the folder, the listing of its files in one order and the naming of the file
//! that failed are written here once.
//!
//! These are test helpers: a folder that cannot be read, or one that holds fewer files than the
//! test expects, is a failed test, so they panic saying which.

use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::path::{Path, PathBuf};

/// The checkout's root: this crate is `<root>/crates/testkit`.
pub fn workspace_root() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    here.parent().and_then(Path::parent).unwrap_or(here).to_path_buf()
}

/// The kept corpus of fuzz target `target`: `<root>/fuzz/corpus/<target>`.
pub fn corpus_dir(target: &str) -> PathBuf {
    workspace_root().join("fuzz").join("corpus").join(target)
}

/// Every file of the corpus of `target`, sorted by path (the same order on every machine).
///
/// # Panics
///
/// If the folder cannot be read, or holds fewer than `at_least` files (and never fewer than
/// one: a walk that sees nothing would test nothing).
pub fn corpus_files(target: &str, at_least: usize) -> Vec<PathBuf> {
    let dir = corpus_dir(target);
    let entries = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.unwrap_or_else(|err| panic!("{}: {err}", dir.display())).path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    let least = at_least.max(1);
    assert!(files.len() >= least, "{}: only {} files (the test expects at least {least})", dir.display(), files.len());
    files
}

/// Feeds each file of the corpus of `target` ([`corpus_files`]: sorted, at least `at_least`)
/// to `feed` with its bytes, in order. A panic in `feed` (a parser's, or a failed assertion) is
/// raised again with the file's path before its message, so the failure says which input.
///
/// # Panics
///
/// As [`corpus_files`]; if a file cannot be read; and when `feed` panics.
pub fn replay(target: &str, at_least: usize, mut feed: impl FnMut(&Path, &[u8])) {
    for file in corpus_files(target, at_least) {
        let bytes = std::fs::read(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        if let Err(payload) = catch_unwind(AssertUnwindSafe(|| feed(&file, &bytes))) {
            let message = panic_message(payload.as_ref());
            match message {
                Some(m) => panic!("corpus file {}: {m}", file.display()),
                None => resume_unwind(payload),
            }
        }
    }
}

/// The text of a panic's payload (`panic!` with a literal or a formatted message), if it has one.
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> Option<String> {
    payload.downcast_ref::<String>().cloned().or_else(|| payload.downcast_ref::<&str>().map(|s| (*s).to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_corpus_is_found_from_the_root_and_listed_in_order() {
        assert!(workspace_root().join("Cargo.toml").is_file());
        let files = corpus_files("params_toml", 10);
        assert!(files.windows(2).all(|w| w[0] < w[1]));
        assert!(files.iter().all(|f| f.starts_with(corpus_dir("params_toml"))));
    }

    #[test]
    fn a_failing_file_is_named() {
        let first = corpus_files("tum", 1)[0].clone();
        let got = catch_unwind(|| replay("tum", 1, |file, _| assert!(file != first, "refused")));
        let message = panic_message(got.expect_err("the first file fails").as_ref()).unwrap_or_default();
        assert_eq!(message, format!("corpus file {}: refused", first.display()));
    }

    #[test]
    fn a_missing_or_thin_corpus_fails() {
        assert!(catch_unwind(|| corpus_files("no_such_target", 0)).is_err());
        assert!(catch_unwind(|| corpus_files("tum", 100_000)).is_err());
    }
}
