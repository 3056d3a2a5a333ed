//! Replays the parameter-file part of the kept fuzz corpus (`fuzz/corpus/params_toml/`, see
//! `docs/reliability.md`) as FilterParams: no input may panic; a TOML error names the line, a
//! validation error the parameter.

use mapkeeper_localiser::FilterParams;
use std::path::Path;

#[test]
fn params_toml_corpus_never_panics_for_filter_params() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/params_toml");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("entry").path())
        .collect();
    files.sort();
    assert!(files.len() >= 10);
    let (mut ok, mut refused) = (0, 0);
    for file in files {
        let Ok(text) = std::fs::read_to_string(&file) else { continue };
        match toml::from_str::<FilterParams>(&text) {
            Ok(p) => match p.validate() {
                Ok(()) => ok += 1,
                Err(e) => {
                    refused += 1;
                    let m = e.to_string();
                    let names = m.contains("parameter ") || m.contains("particles") || m.contains("alphas");
                    assert!(names, "{}: validation error names no parameter: {m}", file.display());
                }
            },
            Err(e) => {
                refused += 1;
                let m = e.to_string();
                assert!(e.span().is_none() || m.contains("line "), "{}: TOML error names no line: {m}", file.display());
            }
        }
    }
    eprintln!("params_toml corpus (FilterParams): {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}
