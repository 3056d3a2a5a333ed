//! The ROS 2 MCAP reader (a file, or a bag folder with metadata.yaml; CDR messages) on arbitrary bytes, with the default options and with `--salvage`:
//! never panics; a refusal is one line naming the file (`fuzz/check/log_readers.rs`).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "../check/log_readers.rs"]
mod log_readers;

fuzz_target!(|data: &[u8]| {
    thread_local! {
        static DIR: std::path::PathBuf = log_readers::scratch_dir("ros2_mcap");
    }
    DIR.with(|dir| {
        log_readers::ros2_mcap(data, dir);
    });
});
