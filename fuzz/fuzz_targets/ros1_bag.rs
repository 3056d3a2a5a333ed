//! The ROS 1 bag reader on arbitrary bytes, with the default options and with `--salvage`:
//! never panics; a refusal is one line naming the file (`fuzz/check/log_readers.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "../check/log_readers.rs"]
mod log_readers;

fuzz_target!(|data: &[u8]| {
    thread_local! {
        static DIR: std::path::PathBuf = log_readers::scratch_dir("ros1_bag");
    }
    DIR.with(|dir| {
        log_readers::ros1_bag(data, dir);
    });
});
