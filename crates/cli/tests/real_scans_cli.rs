//! `experiment real-scans` through the real binary (issue 52), on a simulated drive written as a
//! bag with a truth topic (no `../shared` needed): the chain's scores move the right way, every
//! field of `summary.json` the issue names is there, and a log without reference poses runs on a
//! given map, unscored, or is refused naming `--map`.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};
use serde_json::Value;

fn ok(args: &[&str]) -> String {
    let o = mapkeeper(args);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn f(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} missing in {v}"))
}

#[test]
fn real_scans_scores_a_simulated_bag_and_runs_one_without_reference_on_a_given_map() {
    let dir = scratch("real-scans", "bag");
    let sim = dir.join("sim");
    let bag = dir.join("drive.mcap");
    ok(&["simulate", "--seconds", "45", "--seed", "6", "--out", s(&sim), "--mcap", s(&bag)]);
    let out = dir.join("rs");
    let printed = ok(&[
        "experiment",
        "real-scans",
        "--log",
        s(&bag),
        "--truth-topic",
        "/truth",
        "--quick",
        "--first-scans",
        "100000",
        "--presets",
        "mapkeeper",
        "--kidnap-cuts",
        "1",
        "--out",
        s(&out),
        "--no-timing",
    ]);
    assert!(printed.contains("drive") && printed.contains("poses reference"), "{printed}");
    let v: Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    check_scored(&v["logs"][0]);
    for f in ["report.md", "report.html", "drive/G.yaml", "drive/M_1.yaml", "drive/ms_reference.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(out.join("drive/errors/mapkeeper_reference_W03.png").is_file());
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("The passes, step by step") && html.contains("data:image/png;base64"));
    check_unscored(&dir, &bag, &sim);
}

/// The scored log's fields: every chain's scores, the kidnaps, the stale map.
fn check_scored(log: &Value) {
    let chains = log["chains"].as_array().unwrap();
    assert_eq!(chains.len(), 2, "mapkeeper × (reference, mapkeeper-real)");
    for c in chains {
        for key in ["m1", "final", "fresh", "oracle"] {
            for m in ["cc", "ms", "opdf"] {
                assert!(c[key][m].is_f64(), "{key}.{m} in {c}");
            }
        }
        // The oracle is G on the scored cells; the chain moves M_1 towards it and keeps the structure.
        assert_eq!(f(&c["oracle"], "ms"), 100.0);
        assert!(f(&c["final"], "ms") > f(&c["m1"], "ms") && f(&c["final"], "cc") > f(&c["m1"], "cc"), "{c}");
        assert!(f(c, "retention") >= 95.0, "{c}");
        for class in ["added", "removed", "moved"] {
            assert!(c["restored"].get(class).is_some(), "restored.{class} in {c}");
        }
        let passes = c["per_pass"].as_array().unwrap();
        assert_eq!(passes.iter().map(|p| p["pass"].as_u64().unwrap()).collect::<Vec<_>>(), vec![2, 3]);
        assert_eq!(passes[1]["ms"], c["final"]["ms"]);
    }
    // At the reference poses the fresh map is G itself; with the localiser, the pose error is scored.
    assert_eq!(f(&chains[0]["fresh"], "ms"), 100.0);
    assert!(chains[1]["per_pass"][0]["pose_error"]["rmse_m"].as_f64().unwrap() < 0.2);
    let k = &log["kidnaps"];
    assert_eq!(k["maps"], serde_json::json!(["stale", "truth"]));
    assert_eq!(k["summaries"].as_array().unwrap().len(), 2, "{k}");
    for x in k["summaries"].as_array().unwrap() {
        assert_eq!(x["trials"], 1);
    }
    let stale = &log["stale"][0];
    assert!(stale["edits"].as_u64().unwrap() > 0, "{stale}");
}

/// The bag without its truth topic: refused without --map, unscored with it.
fn check_unscored(dir: &std::path::Path, bag: &std::path::Path, sim: &std::path::Path) {
    // Without reference poses and without --map: refused, naming the flag.
    let o = mapkeeper(&["experiment", "real-scans", "--log", s(bag), "--quick", "--out", s(&dir.join("x"))]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && e.contains("--map") && e.contains("no reference poses"), "{e}");
    // With a map: the passes run, unscored, and the report says why.
    let out2 = dir.join("unscored");
    ok(&[
        "experiment",
        "real-scans",
        "--log",
        s(bag),
        "--map",
        s(&sim.join("ground_truth.yaml")),
        "--quick",
        "--first-scans",
        "300",
        "--presets",
        "mapkeeper",
        "--out",
        s(&out2),
        "--no-timing",
    ]);
    let v: Value = serde_json::from_slice(&std::fs::read(out2.join("summary.json")).unwrap()).unwrap();
    let log = &v["logs"][0];
    assert!(log["note"].as_str().unwrap().contains("no reference poses"));
    assert!(log["chains"].as_array().unwrap().is_empty());
    let unscored = log["unscored"].as_array().unwrap();
    assert_eq!(unscored.len(), 1, "mapkeeper with mapkeeper-real (the reference cannot be a source)");
    assert_eq!(unscored[0]["per_pass"].as_array().unwrap().len(), 2);
    let report = std::fs::read_to_string(out2.join("report.md")).unwrap();
    assert!(report.contains("no reference poses"), "{report}");
}
