//! Updater parameter files (`UpdaterParams`), loaded as the CLI loads them: the text laid over
//! each preset key by key and validated; with the accepted parameters of one preset (picked by
//! a hash of the input) a `MapUpdater` is built on a small room and run for eleven steps.
//! Never panics, never holds more than 64 MiB; a refusal names the line and column (syntax) or
//! the key. The property is `fuzz/check/updater_params.rs`, shared with the replay test
//! `crates/updater/tests/fuzz_corpus.rs`.
#![no_main]
use libfuzzer_sys::fuzz_target;

// The replay test uses the parts this target does not (`Run::All`, the counts).
#[allow(dead_code)]
#[path = "../check/updater_params.rs"]
mod property;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    property::check(text, property::Run::One);
});
