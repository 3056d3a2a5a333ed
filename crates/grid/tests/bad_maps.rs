//! The bad-map corpus (`tests/data/bad_maps/`): every YAML there is refused with an error that
//! names the offending file (the YAML or the image it points at), and nothing panics.

use mapkeeper_grid::map_io;
use std::path::PathBuf;

#[test]
fn every_bad_map_is_refused_with_its_file_named() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/bad_maps");
    let mut yamls: Vec<_> = std::fs::read_dir(&dir)
        .expect("corpus folder")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "yaml"))
        .collect();
    yamls.sort();
    assert!(yamls.len() >= 15, "corpus has only {} files", yamls.len());
    for yaml in yamls {
        let err = match map_io::load_map(&yaml) {
            Ok(_) => panic!("{} was accepted", yaml.display()),
            Err(e) => e.to_string(),
        };
        assert!(!err.contains('\n'), "multi-line error for {}: {err}", yaml.display());
        let image_named = ["ok.pgm", "missing.pgm", ".pgm", ".png", ".gif"].iter().any(|s| err.contains(s));
        let yaml_named = err.contains(yaml.file_name().and_then(|n| n.to_str()).expect("utf-8 name"));
        assert!(yaml_named || image_named, "{}: error names no file: {err}", yaml.display());
        eprintln!("{}: {err}", yaml.file_name().and_then(|n| n.to_str()).unwrap_or("?"));
    }
}
