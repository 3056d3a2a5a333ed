//! The CARMEN reader (plain, gzipped, damaged gzip) on arbitrary bytes, with the default options and with `--salvage`:
//! never panics; a refusal is one line naming the file (`fuzz/check/log_readers.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "../check/log_readers.rs"]
mod log_readers;

fuzz_target!(|data: &[u8]| {
    thread_local! {
        static DIR: std::path::PathBuf = log_readers::scratch_dir("carmen");
    }
    DIR.with(|dir| {
        log_readers::carmen(data, dir);
    });
});
