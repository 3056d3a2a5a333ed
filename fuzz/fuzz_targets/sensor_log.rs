//! The JSON Lines sensor log reader: never panics; every rejection names the file (and the
//! line, for a parse error) on one line.
#![no_main]
use libfuzzer_sys::fuzz_target;
use mapkeeper_sensor::SensorLog;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = SensorLog::from_reader(data, Path::new("fuzz.jsonl")) {
        let m = e.to_string();
        assert!(m.starts_with("fuzz.jsonl") && !m.contains('\n'), "{m}");
    }
});
