//! Replays the kept corpus of the `merge_json` fuzz target (`fuzz/corpus/merge_json/`, see
//! `docs/reliability.md`) through the target's own property (`fuzz/check/merge_json.rs`): the
//! `runs.json` and `summary.json` of a validation folder, as `mapkeeper merge` reads them back.
//! No input may panic; a refusal is one line naming the folder, and for bad JSON the file, the
//! line and the column.

#![allow(clippy::unwrap_used)]

#[path = "../../../fuzz/check/merge_json.rs"]
mod property;

use mapkeeper_testkit::corpus::corpus_files;
use property::Checked;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

#[test]
fn merge_json_corpus_holds_the_fuzz_property() {
    let mut total = Checked::default();
    for file in corpus_files("merge_json", 15) {
        let data = std::fs::read(&file).unwrap();
        let c = match catch_unwind(AssertUnwindSafe(|| property::check(&data))) {
            Ok(c) => c,
            Err(e) => {
                let m = e.downcast_ref::<String>().cloned().or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()));
                panic!("{}: {}", file.display(), m.unwrap_or_default());
            }
        };
        total.bad_runs_json += c.bad_runs_json;
        total.bad_runs += c.bad_runs;
        total.runs_ok += c.runs_ok;
        total.bad_summary += c.bad_summary;
        total.accepted += c.accepted;
    }
    eprintln!("merge_json corpus: {total:?}");
    // The corpus reaches every kind of refusal and the whole way through.
    assert!(total.bad_runs_json > 0 && total.bad_runs > 0 && total.bad_summary > 0, "{total:?}");
    assert!(total.accepted > 0, "{total:?}");
}

/// The folder the seeds come from (`tests/data/validation_run/`, written by `mapkeeper
/// validate`) is read back whole: if this fails, the format changed and the folder and the
/// seeds (`python3 fuzz/make_seed_corpus.py`) must be written again.
#[test]
fn the_seed_folder_is_accepted_as_written() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/validation_run");
    let runs = std::fs::read_to_string(dir.join("runs.json")).unwrap();
    let summary = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    let record = mapkeeper_scenario::experiments::validation::merge::parse_runs_json(&dir, &runs).unwrap();
    mapkeeper_scenario::experiments::validation::merge::check_summary_json(&dir, &record, &summary).unwrap();
    let mut data = runs.into_bytes();
    data.push(0);
    data.extend(summary.into_bytes());
    assert_eq!(property::check(&data).accepted, 1);
}

/// The seed folder's `runs.json` with `edit` applied, as text.
fn edited_runs(edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/validation_run");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("runs.json")).unwrap()).unwrap();
    edit(&mut v);
    v.to_string()
}

/// The recomputed summary added up a scan-time histogram of two counts of 2^64 − 1: an
/// overflow (a panic with overflow checks, a wrong median without). Found by the seed
/// `fuzz/corpus/merge_json/huge_histogram.json` on the `merge_json` target's first run.
#[test]
fn a_histogram_whose_counts_overflow_u64_is_refused_not_summed() {
    use mapkeeper_scenario::experiments::validation::merge::parse_runs_json;
    use mapkeeper_scenario::results::MergeProblem;
    let text =
        edited_runs(|v| v["seeds"][0]["scan_time_histogram_us"] = serde_json::json!([[1, u64::MAX], [2, u64::MAX]]));
    let e = parse_runs_json(Path::new("run"), &text).unwrap_err();
    let m = e.to_string();
    assert!(
        matches!(
            e,
            mapkeeper_scenario::ResultsError::Merge {
                problem: MergeProblem::CountsOverflow { counter: "scan_time_histogram_us", seed: 1 },
                ..
            }
        ),
        "{m}"
    );
    assert_eq!(m, "run: cannot merge: the scan_time_histogram_us counts add up beyond 2^64 - 1 with seed 1");
}

/// Two folders whose counters fit alone but not together: the merge is refused, naming the
/// second folder and the counter, before any summary is computed.
#[test]
fn two_folders_whose_counts_add_up_beyond_u64_are_not_merged() {
    use mapkeeper_scenario::experiments::validation::merge::{merge_records, parse_runs_json};
    use mapkeeper_scenario::results::MergeProblem;
    let half = 1u64 << 63;
    let a =
        parse_runs_json(Path::new("a"), &edited_runs(|v| v["seeds"][0]["rows"][0]["updater"]["beams"] = half.into()));
    let b = edited_runs(|v| {
        v["seeds"][0]["seed"] = 2.into();
        v["seeds"][0]["rows"][0]["seed"] = 2.into();
        v["seeds"][0]["rows"][0]["updater"]["beams"] = half.into();
    });
    let b = parse_runs_json(Path::new("b"), &b);
    let inputs = [("a".into(), a.unwrap()), ("b".into(), b.unwrap())];
    let e = merge_records(&inputs).unwrap_err();
    assert!(
        matches!(
            &e,
            mapkeeper_scenario::ResultsError::Merge {
                dir,
                problem: MergeProblem::CountsOverflow { counter: "updater.beams", seed: 2 },
            } if dir == Path::new("b")
        ),
        "{e}"
    );
    // One less beam in the first folder, and they merge.
    let a = parse_runs_json(
        Path::new("a"),
        &edited_runs(|v| v["seeds"][0]["rows"][0]["updater"]["beams"] = (half - 1).into()),
    );
    let inputs = [("a".into(), a.unwrap()), inputs[1].clone()];
    assert_eq!(merge_records(&inputs).unwrap().summary().updater.beams, u64::MAX);
}

/// serde_json quotes an unknown key unescaped, so a key holding a newline (`"\n"` in the JSON)
/// made the error two lines. Found by `merge_json` after 67,705 executions; the input
/// `fuzz/corpus/merge_json/regression_newline_in_key.json`. A format name is quoted the same way.
#[test]
fn a_key_or_format_with_a_newline_gives_a_one_line_merge_error() {
    use mapkeeper_scenario::experiments::validation::merge::parse_runs_json;
    let text = edited_runs(|v| {
        let u = v["params"]["runner"]["updater"].as_object_mut().unwrap();
        let x = u.remove("removal_min_incidence_rad").unwrap();
        u.insert("removal_min_i\ncidence_rad".into(), x);
    });
    let m = parse_runs_json(Path::new("run"), &text).unwrap_err().to_string();
    assert!(!m.contains('\n') && m.contains(r"unknown field `removal_min_i\ncidence_rad`"), "{m}");
    let text = edited_runs(|v| v["format"] = "mapkeeper-\nvalidation-runs".into());
    let m = parse_runs_json(Path::new("run"), &text).unwrap_err().to_string();
    assert_eq!(
        m,
        r"run: cannot merge: runs.json: format is 'mapkeeper-\nvalidation-runs', expected 'mapkeeper-validation-runs'"
    );
}

/// The parameter-file corpus (`fuzz/corpus/params_toml/`) as `recover --params` loads it: the
/// defaults overlaid by the file, then `RecoveryParams::validate`. No input panics; a refusal
/// names what is wrong: a TOML syntax error its line (the CLI puts the file's name before it and
/// joins the parser's lines into one).
#[test]
fn params_toml_corpus_never_panics_for_recovery_params() {
    let (mut ok, mut refused) = (0, 0);
    for file in corpus_files("params_toml", 1) {
        let Ok(text) = std::fs::read_to_string(&file) else { continue };
        let base = mapkeeper_scenario::RecoveryParams::default();
        let got = catch_unwind(AssertUnwindSafe(|| {
            let p = mapkeeper_harness::config::params_from_toml_str(
                base,
                &text,
                mapkeeper_scenario::RecoveryParams::validate,
            )?;
            // What validation accepts, the kidnap suite's draws must take (a range of
            // non-finite width panics in rand).
            for trial in 0..4 {
                let d = mapkeeper_scenario::experiments::recovery::draw_trial(&p, 7, trial);
                assert!(d.tour_position_m.is_finite() && d.yaw_rad.is_finite(), "{d:?}");
            }
            Ok::<_, String>(p)
        }))
        .unwrap_or_else(|_| panic!("{}: panicked", file.display()));
        match got {
            Ok(_) => ok += 1,
            Err(m) => {
                refused += 1;
                let syntax = m.starts_with("TOML parse error");
                assert!(!m.is_empty() && (!syntax || m.contains("line ")), "{}: {m}", file.display());
            }
        }
    }
    eprintln!("params_toml corpus (RecoveryParams): {ok} accepted, {refused} refused");
    assert!(ok > 0 && refused > 0, "the corpus holds both accepted and refused files");
}
