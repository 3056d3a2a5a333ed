//! Replays the kept fuzz corpus (`fuzz/corpus/`, see `docs/reliability.md`) through the grid's
//! parsers: map YAML, PGM, PNG, and the MapperParams / MetricParams TOML files. No input may
//! panic, and every rejection must be a one-line error that names the place: the file, and the
//! line or key where the text says which.

use mapkeeper_grid::map_io::{self, MapYaml};
use mapkeeper_grid::mapper::MapperParams;
use mapkeeper_grid::metrics::MetricParams;
use mapkeeper_testkit::corpus::replay;
use std::path::Path;

/// A one-line error that starts with the file's name.
fn assert_names_file(message: &str, file: &Path) {
    let name = file.display().to_string();
    assert!(message.starts_with(&name), "error does not name {name}: {message}");
    assert!(!message.contains('\n'), "multi-line error: {message}");
    assert!(message.len() > name.len() + 2, "error names no problem: {message}");
}

#[test]
fn map_yaml_corpus_never_panics_and_errors_name_file_and_line_or_key() {
    let (mut ok, mut refused) = (0, 0);
    replay("map_yaml", 10, |file, bytes| {
        let result = match std::str::from_utf8(bytes) {
            Ok(text) => map_io::parse_map_yaml(text, file).map(|_| ()),
            // Not UTF-8: only the file reader sees it; it names the file and the line.
            Err(_) => map_io::load_map(file).map(|_| ()),
        };
        match result {
            Ok(()) => ok += 1,
            Err(e) => {
                refused += 1;
                let m = e.to_string();
                assert_names_file(&m, file);
                let rest = &m[file.display().to_string().len()..];
                let line_named = rest.starts_with(':') && rest[1..].starts_with(|c: char| c.is_ascii_digit());
                assert!(line_named || rest.contains("key '"), "names neither line nor key: {m}");
            }
        }
    });
    eprintln!("map_yaml corpus: {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}

fn image_meta() -> MapYaml {
    map_io::parse_map_yaml(
        "image: x\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n",
        Path::new("corpus.yaml"),
    )
    .expect("yaml")
}

fn replay_images(target: &str) {
    let meta = image_meta();
    let (mut ok, mut refused) = (0, 0);
    replay(target, 10, |file, bytes| {
        match map_io::map_from_image_bytes(&meta, bytes, file, Path::new("corpus.yaml")) {
            Ok(_) => ok += 1,
            Err(e) => {
                refused += 1;
                assert_names_file(&e.to_string(), file);
            }
        }
    });
    eprintln!("{target} corpus: {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}

#[test]
fn pgm_corpus_never_panics_and_errors_name_the_image() {
    replay_images("pgm");
}

#[test]
fn png_corpus_never_panics_and_errors_name_the_image() {
    replay_images("png");
}

/// Parses `text` as `T` and validates it: a TOML error names the line, a validation error
/// the parameter. Returns whether the text was accepted.
fn params_ok<T: serde::de::DeserializeOwned, E: std::fmt::Display>(
    text: &str,
    file: &Path,
    validate: impl Fn(&T) -> Result<(), E>,
) -> bool {
    match toml::from_str::<T>(text) {
        Ok(p) => match validate(&p) {
            Ok(()) => true,
            Err(e) => {
                let m = e.to_string();
                assert!(m.contains("parameter "), "{}: validation error names no parameter: {m}", file.display());
                false
            }
        },
        Err(e) => {
            let m = e.to_string();
            assert!(e.span().is_none() || m.contains("line "), "{}: TOML error names no line: {m}", file.display());
            false
        }
    }
}

#[test]
fn params_corpus_never_panics_for_mapper_and_metric_params() {
    let (mut ok, mut refused) = (0, 0);
    replay("params_toml", 10, |file, bytes| {
        let Ok(text) = std::str::from_utf8(bytes) else { return };
        for accepted in [params_ok(text, file, MapperParams::validate), params_ok(text, file, MetricParams::validate)] {
            if accepted { ok += 1 } else { refused += 1 }
        }
    });
    eprintln!("params_toml corpus (MapperParams, MetricParams): {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}

/// Regression (found by review while writing the `pgm` fuzz target): a 30-byte P2 header
/// promising 16384 × 16384 pixels reserved 512 MiB before reading any pixel value.
#[test]
fn p2_header_promising_more_pixels_than_the_file_holds_is_refused_before_allocating() {
    let e = map_io::map_from_image_bytes(
        &image_meta(),
        b"P2\n16384 16384\n255\n0 1 2\n",
        Path::new("h.pgm"),
        Path::new("h.yaml"),
    )
    .expect_err("truncated");
    let m = e.to_string();
    assert!(m.starts_with("h.pgm: truncated P2 data"), "{m}");
}
