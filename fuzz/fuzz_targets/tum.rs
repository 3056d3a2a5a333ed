//! The TUM trajectory reader: never panics; every rejection names the file on one line.
#![no_main]
use libfuzzer_sys::fuzz_target;
use mapkeeper_sensor::tum::parse_tum;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Err(e) = parse_tum(text, Path::new("fuzz.tum")) {
        let m = e.to_string();
        assert!(m.starts_with("fuzz.tum") && !m.contains('\n'), "{m}");
    }
});
