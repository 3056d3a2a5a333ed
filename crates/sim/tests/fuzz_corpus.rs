//! Replays the kept fuzz corpus (`fuzz/corpus/`, see `docs/reliability.md`) through the
//! simulator's parsers: world TOML, route TOML, robot TOML and SimParams TOML. No input may panic, and every
//! rejection must be a one-line error that names the file and the place (line and column for
//! a syntax error, the entry for an invalid value).

use mapkeeper_sim::{RobotFile, Route, SimError, SimParams, World};
use mapkeeper_testkit::corpus;
use std::path::Path;

/// A rejection names the file, then the line (syntax) or the entry (validation), on one line.
fn assert_names_place(e: &SimError, file: &Path) {
    let m = e.to_string();
    let name = file.display().to_string();
    assert!(m.starts_with(&format!("{name}: ")), "error does not name {name}: {m}");
    assert!(!m.contains('\n'), "multi-line error: {m}");
    match e {
        SimError::Parse { message, .. } => {
            assert!(message.starts_with("line ") || message.contains("UTF-8"), "syntax error names no line: {m}")
        }
        SimError::Invalid { entry, .. } => assert!(!entry.is_empty(), "no entry named: {m}"),
        other => panic!("unexpected error kind for a text parser: {other}"),
    }
}

/// Replays `target` through `parse`; returns (accepted, refused).
fn replay<T>(target: &str, parse: impl Fn(&str, &str) -> Result<T, SimError>) -> (usize, usize) {
    let (mut ok, mut refused) = (0, 0);
    corpus::replay(target, 10, |file, bytes| {
        let Ok(text) = std::str::from_utf8(bytes) else { return };
        match parse(text, &file.display().to_string()) {
            Ok(_) => ok += 1,
            Err(e) => {
                refused += 1;
                assert_names_place(&e, file);
            }
        }
    });
    eprintln!("{target} corpus: {ok} accepted, {refused} refused");
    (ok, refused)
}

#[test]
fn world_toml_corpus_never_panics_and_errors_name_the_place() {
    let (ok, refused) = replay("world_toml", World::from_toml_str);
    assert!(ok > 0 && refused > 0);
}

#[test]
fn route_toml_corpus_never_panics_and_errors_name_the_place() {
    let (ok, refused) = replay("route_toml", Route::from_toml_str);
    assert!(ok > 0 && refused > 0);
}

#[test]
fn robot_toml_corpus_never_panics_and_errors_name_the_place() {
    let (ok, refused) = replay("robot_toml", RobotFile::from_toml_str);
    assert!(ok >= 3 && refused > 0);
}

#[test]
fn params_toml_corpus_never_panics_for_sim_params() {
    let (mut ok, mut refused) = (0, 0);
    corpus::replay("params_toml", 10, |file, bytes| {
        let Ok(text) = std::str::from_utf8(bytes) else { return };
        match toml::from_str::<SimParams>(text) {
            Ok(p) => match p.validate() {
                Ok(()) => ok += 1,
                Err(e) => {
                    refused += 1;
                    // Names the component (`RobotParams`, `lidars[1]`, ...) and the problem.
                    assert!(matches!(e, SimError::Params { .. }), "{}: {e}", file.display());
                }
            },
            Err(e) => {
                refused += 1;
                let m = e.to_string();
                assert!(e.span().is_none() || m.contains("line "), "{}: TOML error names no line: {m}", file.display());
            }
        }
    });
    eprintln!("params_toml corpus (SimParams): {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}
