//! The map_server YAML parser: never panics; every rejection names the file on one line.
#![no_main]
use libfuzzer_sys::fuzz_target;
use mapkeeper_grid::map_io::parse_map_yaml;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Err(e) = parse_map_yaml(text, Path::new("fuzz.yaml")) {
        let m = e.to_string();
        assert!(m.starts_with("fuzz.yaml") && !m.contains('\n'), "{m}");
    }
});
