//! Replays the kept fuzz corpus (`fuzz/corpus/`, see `docs/reliability.md`) through the sensor
//! crate's readers: the JSON Lines sensor log and TUM trajectories. No input may panic, and
//! every rejection must be a one-line error that names the file and, for a parse error, the line.

use mapkeeper_sensor::tum::parse_tum;
use mapkeeper_sensor::{LogError, SensorLog};
use mapkeeper_sensor::{TumError, read_tum};
use mapkeeper_testkit::corpus::replay;
use std::path::Path;

fn assert_one_line_naming(m: &str, file: &Path) {
    let name = file.display().to_string();
    assert!(m.starts_with(&name), "error does not name {name}: {m}");
    assert!(!m.contains('\n'), "multi-line error: {m}");
}

#[test]
fn sensor_log_corpus_never_panics_and_errors_name_file_and_line() {
    let (mut ok, mut refused) = (0, 0);
    replay("sensor_log", 10, |file, bytes| {
        match SensorLog::from_reader(bytes, file) {
            Ok(_) => ok += 1,
            Err(e) => {
                refused += 1;
                assert_one_line_naming(&e.to_string(), file);
                assert!(matches!(e, LogError::Parse { line: 1.., .. } | LogError::Empty { .. }), "{e}");
            }
        }
        // The file reader agrees with the in-memory one.
        assert_eq!(SensorLog::read(file).is_ok(), SensorLog::from_reader(bytes, file).is_ok());
    });
    eprintln!("sensor_log corpus: {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}

#[test]
fn tum_corpus_never_panics_and_errors_name_file_and_line() {
    let (mut ok, mut refused) = (0, 0);
    replay("tum", 10, |file, bytes| {
        let result = match std::str::from_utf8(bytes) {
            Ok(text) => parse_tum(text, file),
            Err(_) => read_tum(file),
        };
        match result {
            Ok(_) => ok += 1,
            Err(e) => {
                refused += 1;
                assert_one_line_naming(&e.to_string(), file);
                assert!(matches!(e, TumError::Parse { line: 1.., .. }), "{e}");
            }
        }
    });
    eprintln!("tum corpus: {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0);
}

/// Regression (found by the `sensor_log` fuzz target): a JSON key holding an escaped newline
/// gave a two-line error, because serde_json quotes the unknown key unescaped.
#[test]
fn header_key_with_a_newline_gives_a_one_line_error() {
    let text = "{\"format\":\"mapkeeper-sensor-log\",\"version\\nx\":1}\n";
    let e = SensorLog::from_reader(text.as_bytes(), Path::new("k.jsonl")).expect_err("unknown key");
    let m = e.to_string();
    assert!(m.starts_with("k.jsonl:1: bad header: unknown field `version\\nx`"), "{m}");
    assert!(!m.contains('\n'), "{m}");
}
