//! Replays the parameter-file part of the kept fuzz corpus (`fuzz/corpus/params_toml/`, see
//! `docs/reliability.md`) as FilterParams: no input may panic; a TOML error names the line, a
//! validation error the parameter.

use mapkeeper_localiser::FilterParams;
use mapkeeper_testkit::corpus::replay;

#[test]
fn params_toml_corpus_never_panics_for_filter_params() {
    let (mut ok, mut refused) = (0, 0);
    replay("params_toml", 10, |file, bytes| {
        let Ok(text) = std::str::from_utf8(bytes) else { return };
        match toml::from_str::<FilterParams>(text) {
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
    });
    eprintln!("params_toml corpus (FilterParams): {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}
