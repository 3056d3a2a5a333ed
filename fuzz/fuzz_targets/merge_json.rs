//! The files of a validation folder that `mapkeeper merge` reads back (`runs.json`, then a NUL
//! byte and `summary.json`), checked as `load_result_dir` checks them: never panics; a refusal
//! is one line naming the folder, and for bad JSON the file, line and column; a folder merged
//! with itself is refused for the duplicate seed. The property is `fuzz/check/merge_json.rs`,
//! shared with the replay test `crates/scenario/tests/fuzz_corpus.rs`.
#![no_main]
use libfuzzer_sys::fuzz_target;

// The replay test uses the parts this target does not (the counts).
#[allow(dead_code)]
#[path = "../check/merge_json.rs"]
mod property;

fuzz_target!(|data: &[u8]| {
    property::check(data);
});
