//! Replays the kept corpus of the `updater_params` fuzz target (`fuzz/corpus/updater_params/`,
//! see `docs/reliability.md`) through the target's own property (`fuzz/check/updater_params.rs`):
//! each file laid over every preset as the CLI does it, refusals naming the line or the key,
//! accepted parameters running the updater (with every preset) without a panic and within
//! bounded memory. A second test sweeps every numeric parameter through edge values the same
//! way (the updater run with one preset per value, as the fuzz target does), so the property is
//! exercised on stable Rust without the fuzzer.

#![allow(clippy::unwrap_used)]

#[path = "../../../fuzz/check/updater_params.rs"]
mod property;

use mapkeeper_testkit::corpus::{corpus_dir, corpus_files};
use mapkeeper_updater::UpdaterParams;
use property::{Checked, Run};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// Runs the property on `text`, naming `what` if it fails.
fn check(what: &str, text: &str, run: Run) -> Checked {
    match catch_unwind(AssertUnwindSafe(|| property::check(text, run))) {
        Ok(c) => c,
        Err(e) => {
            let m = e.downcast_ref::<String>().cloned().or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()));
            panic!("{what}: {}\n--- input:\n{text}", m.unwrap_or_default());
        }
    }
}

fn add(total: &mut Checked, c: &Checked) {
    total.accepted += c.accepted;
    total.syntax += c.syntax;
    total.typed += c.typed;
    total.invalid += c.invalid;
    total.lost += c.lost;
    total.recoveries += c.recoveries;
}

#[test]
fn the_seed_with_every_field_of_paper_gives_paper_over_any_preset() {
    let file = corpus_dir("updater_params").join("paper.toml");
    let text = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    for name in mapkeeper_updater::PRESET_NAMES {
        let base = UpdaterParams::preset(name).unwrap();
        let p = mapkeeper_common::params_from_toml_str(base, &text, UpdaterParams::validate).unwrap();
        assert_eq!(p, UpdaterParams::paper(), "paper.toml over {name}");
    }
}

#[test]
fn updater_params_corpus_holds_the_fuzz_property() {
    let mut total = Checked::default();
    for file in corpus_files("updater_params", 15) {
        let Ok(text) = std::fs::read_to_string(&file) else { continue };
        add(&mut total, &check(&file.display().to_string(), &text, Run::All));
    }
    eprintln!("updater_params corpus: {total:?}");
    // The corpus reaches every kind of refusal and, past validation, pose updating.
    assert!(total.accepted > 0 && total.syntax > 0 && total.typed > 0 && total.invalid > 0, "{total:?}");
    assert!(total.lost > 0 && total.recoveries > 0, "{total:?}");
}

/// Edge values for a parameter whose preset value is `v` (as JSON); none for booleans and
/// enums.
fn edge_values(v: &serde_json::Value) -> Vec<String> {
    use serde_json::Value;
    let floats = ["0.0", "-0.0", "5e-324", "1e-9", "-1.0", "0.5", "1.0", "3.2", "1e9", "1e300", "nan", "inf", "-inf"];
    match v {
        Value::Number(n) if n.is_u64() => {
            ["-1", "0", "1", "2", "7", "33", "65", "1000", "1001", "100000", "4294967295", "4294967296"]
                .map(String::from)
                .to_vec()
        }
        // Floats, and the limits serialised as "inf".
        Value::Number(_) | Value::String(_) if v.as_str().is_none_or(|s| s == "inf") => {
            floats.map(String::from).to_vec()
        }
        Value::Array(_) => {
            let many = vec!["0.1"; 4097].join(", ");
            ["[]", "[nan]", "[1e300]", "[-1e300, 0.0, 1e300]", "[0.0, 0.0, 0.0]"]
                .map(String::from)
                .into_iter()
                .chain([format!("[{many}]")])
                .collect()
        }
        _ => Vec::new(),
    }
}

/// Every numeric parameter at each of its edge values: the fuzz property, and a refusal by
/// `validate()` names the parameter set, as the field or in the reason (a refusal of a
/// combination names the others).
#[test]
fn every_numeric_parameter_at_edge_values_holds_the_fuzz_property() {
    let paper = serde_json::to_value(UpdaterParams::paper()).unwrap();
    // (the key, the text setting it)
    let mut texts = Vec::new();
    for (key, v) in paper.as_object().unwrap() {
        if let Some(table) = v.as_object() {
            for (sub, w) in table {
                texts.extend(edge_values(w).into_iter().map(|e| (sub.clone(), format!("[{key}]\n{sub} = {e}\n"))));
            }
        } else {
            texts.extend(edge_values(v).into_iter().map(|e| (key.clone(), format!("{key} = {e}\n"))));
        }
    }
    assert!(texts.len() > 500, "{} texts", texts.len());
    let mut total = Checked::default();
    for (key, text) in &texts {
        add(&mut total, &check("edge value", text, Run::One));
        for name in mapkeeper_updater::PRESET_NAMES {
            let base = UpdaterParams::preset(name).unwrap();
            if let Err(m) = mapkeeper_common::params_from_toml_str(base, text, UpdaterParams::validate)
                && m.starts_with("invalid updater parameter")
            {
                assert!(m.contains(key.as_str()), "{name}: {text:?} refused without naming {key}: {m}");
            }
        }
    }
    eprintln!("edge values ({} texts): {total:?}", texts.len());
    assert!(total.accepted > 0 && total.typed > 0 && total.invalid > 0, "{total:?}");
}
