//! The robot file parser and validator: never panics; every rejection names the file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use mapkeeper_sim::RobotFile;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Err(e) = RobotFile::from_toml_str(text, "fuzz.toml") {
        let m = e.to_string();
        assert!(m.starts_with("fuzz.toml") && !m.contains('\n'), "{m}");
    }
});
