//! `mapkeeper check`, the CI gate (issue 32 item 1), through the real binary: a baseline written
//! from a short validation passes that validation, byte-stably; a doctored baseline (the run
//! regressed against it) fails naming the metric, exit 1; another setting or a bad file is an
//! error, exit 2.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};
use std::path::Path;

fn validate(out: &Path, seeds: &str) {
    let o = mapkeeper(&[
        "validate",
        "--preset",
        "mapkeeper",
        "--worlds",
        "3",
        "--seeds",
        seeds,
        "--route-length",
        "8",
        "--no-timing",
        "--out",
        s(out),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // Before the first world, `validate` says what it runs and where it writes (issue 32 item 4).
    let said = String::from_utf8_lossy(&o.stdout);
    let first = said.lines().next().unwrap_or_default();
    let want = format!(
        "validate: preset(s) mapkeeper × seeds 11-{} × 3 worlds (W_2-W_3), localiser amcl",
        10 + seeds.parse::<u64>().unwrap()
    );
    assert!(first.starts_with(&want) && first.contains(&format!("writing {}", s(out))), "{first}");
}

fn text(o: &std::process::Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

#[test]
fn a_baseline_passes_its_run_and_a_doctored_one_fails_naming_the_metric() {
    let dir = scratch("check", "gate");
    let run = dir.join("run");
    validate(&run, "3");
    let base = dir.join("base.json");
    let o = mapkeeper(&["check", s(&run), "--write-baseline", s(&base)]);
    assert!(o.status.success(), "{}", text(&o));
    let bytes = std::fs::read(&base).unwrap();
    // Byte-stable: written again from the same results, the same bytes; refused without --force.
    let o = mapkeeper(&["check", s(&run), "--write-baseline", s(&base)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("--force"));
    let o = mapkeeper(&["check", s(&run), "--write-baseline", s(&base), "--force"]);
    assert!(o.status.success());
    assert_eq!(std::fs::read(&base).unwrap(), bytes);
    // The unchanged run passes.
    let o = mapkeeper(&["check", s(&run), "--baseline", s(&base)]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("0 of 9 metrics regressed") && text(&o).contains("pass"), "{}", text(&o));
    // A baseline that says the MS gain was 10 tolerances higher, and the localiser's error half
    // a metre lower: the run regressed on both.
    let mut b: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    let ms = &mut b["presets"]["mapkeeper"]["ms_gain"];
    let up = 10.0 * ms["tolerance"].as_f64().unwrap();
    ms["value"] = (ms["value"].as_f64().unwrap() + up).into();
    let err = &mut b["presets"]["mapkeeper"]["error_updated_m"];
    err["value"] = (err["value"].as_f64().unwrap() - 0.5).into();
    let doctored = dir.join("doctored.json");
    std::fs::write(&doctored, serde_json::to_vec(&b).unwrap()).unwrap();
    let o = mapkeeper(&["check", s(&run), "--baseline", s(&doctored)]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let said = text(&o);
    assert!(
        said.contains("REGRESSED mapkeeper ms_gain") && said.contains("REGRESSED mapkeeper error_updated_m"),
        "{said}"
    );
    assert!(said.contains("2 of 9 metrics regressed") && said.contains("FAIL"), "{said}");
    // Another setting (two seeds against three) is an error, not a pass or a fail.
    let other = dir.join("other");
    validate(&other, "2");
    let o = mapkeeper(&["check", s(&other), "--baseline", s(&base)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(text(&o).contains("another setting"), "{}", text(&o));
    // A file that is not a baseline: named.
    std::fs::write(dir.join("junk.json"), "{\"format\": 1}").unwrap();
    let o = mapkeeper(&["check", s(&run), "--baseline", s(&dir.join("junk.json"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o).contains("junk.json: not a baseline file"), "{}", text(&o));
}
