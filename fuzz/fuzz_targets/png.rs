//! The PNG decoder behind the map reader, fed the image bytes as they
//! would be on disk. Never panics; every rejection names the image file on one line.
#![no_main]
use libfuzzer_sys::fuzz_target;
use mapkeeper_grid::map_io::{map_from_image_bytes, parse_map_yaml};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let meta = parse_map_yaml(
        "image: fuzz.png\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
        Path::new("fuzz.yaml"),
    )
    .expect("fixed YAML");
    if let Err(e) = map_from_image_bytes(&meta, data, Path::new("fuzz.png"), Path::new("fuzz.yaml")) {
        let m = e.to_string();
        assert!(m.starts_with("fuzz.png") && !m.contains('\n'), "{m}");
    }
});
