//! `--no-timing` on `run`, `update`, `recover` and the experiments `check-detection`, `table1` and
//! `kidnap-robot`: two runs of the same seed write the same bytes, every file, and no time is
//! left in them. `experiment real-data` (which needs the logs of `../shared`) takes the flag from
//! the same `TimingArg`; `validate` has its own tests.
#![allow(clippy::unwrap_used)]

mod common;

use common::{SHORT_RECOVER, files, mapkeeper, s, scratch};
use std::path::Path;

fn ok(args: &[&str]) {
    let o = mapkeeper(args);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
}

/// Runs `args` + `--out A` and `--out B` and checks that A and B hold the same files.
fn twice_the_same(dir: &Path, name: &str, args: &[&str]) -> std::collections::BTreeMap<String, Vec<u8>> {
    let (a, b) = (dir.join(format!("{name}-a")), dir.join(format!("{name}-b")));
    ok(&[args, &["--out", s(&a)]].concat());
    ok(&[args, &["--out", s(&b)]].concat());
    let (fa, fb) = (files(&a), files(&b));
    assert!(!fa.is_empty(), "{name}: no files");
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>(), "{name}");
    for (file, bytes) in &fa {
        assert!(fb[file] == *bytes, "{name}: {file} differs between two --no-timing runs");
    }
    fa
}

#[test]
fn run_and_update_without_timing_write_the_same_bytes_twice() {
    let dir = scratch("no-timing", "run-update");
    let set = dir.join("set");
    ok(&["generate", "--worlds", "2", "--seed", "3", "--out", s(&set)]);
    let route = dir.join("short.toml");
    std::fs::write(&route, "format = \"mapkeeper-route\"\nversion = 1\nwaypoints = [[-3.65, -2.3], [-3.65, 0.7]]\n")
        .unwrap();
    let (world, map) = (set.join("worlds/W_002.toml"), set.join("ground_truth/G_001.yaml"));
    let run = ["run", "--world", s(&world), "--map", s(&map), "--route", s(&route), "--no-timing"];
    let f = twice_the_same(&dir, "run", &run);
    let json: serde_json::Value = serde_json::from_slice(&f["run.json"]).unwrap();
    assert_eq!((json["wall_time_s"].as_f64(), json["median_scan_us"].as_f64()), (Some(0.0), Some(0.0)), "{json}");
    // A timed run does record times (the flag is what removes them).
    let timed = dir.join("timed");
    ok(&[&run[..run.len() - 1], &["--out", s(&timed)]].concat());
    let json: serde_json::Value = serde_json::from_slice(&files(&timed)["run.json"]).unwrap();
    assert!(json["wall_time_s"].as_f64().unwrap() > 0.0, "{json}");

    let sim = dir.join("sim");
    ok(&["simulate", "--world", s(&world), "--route", s(&route), "--seconds", "4", "--out", s(&sim)]);
    let log = sim.join("log.jsonl");
    let update = ["update", "--map", s(&map), "--log", s(&log), "--true-poses", "--no-timing"];
    let f = twice_the_same(&dir, "update", &update);
    let csv = String::from_utf8_lossy(&f["scans.csv"]).into_owned();
    let header = csv.lines().next().unwrap();
    assert!(header.ends_with(",microseconds"), "the last column is the updater's time: {header}");
    assert!(csv.lines().skip(1).count() > 10, "{csv}");
    assert!(csv.lines().skip(1).all(|l| l.ends_with(",0.0")), "times left in scans.csv: {csv}");
    let timed = dir.join("update-timed");
    ok(&[&update[..update.len() - 1], &["--out", s(&timed)]].concat());
    let csv = String::from_utf8_lossy(&files(&timed)["scans.csv"]).into_owned();
    assert!(csv.lines().skip(1).any(|l| !l.ends_with(",0.0")), "a timed update records times: {csv}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn experiments_without_timing_write_the_same_bytes_whatever_the_thread_count() {
    let dir = scratch("no-timing", "experiment");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let args = ["experiment", "check-detection", "--quick", "--trials", "4", "--no-timing"];
    ok(&[&args[..], &["--jobs", "1", "--out", s(&a)]].concat());
    ok(&[&args[..], &["--jobs", "2", "--out", s(&b)]].concat());
    let (fa, fb) = (files(&a), files(&b));
    assert!(fa.contains_key("summary.json") && fa.contains_key("report.md"));
    assert!(fa == fb, "the folders differ between --jobs 1 and 2 under --no-timing");
    let v: serde_json::Value = serde_json::from_slice(&fa["summary.json"]).unwrap();
    assert_eq!(v["wall_time_s"].as_f64(), Some(0.0), "{v}");
    // The other experiments and the recovery suite, on their shortest settings.
    for which in ["table1", "kidnap-robot"] {
        let f = twice_the_same(&dir, which, &["experiment", which, "--quick", "--trials", "2", "--no-timing"]);
        let v: serde_json::Value = serde_json::from_slice(&f["summary.json"]).unwrap();
        assert_eq!(v["wall_time_s"].as_f64(), Some(0.0), "{which}: {v}");
    }
    let params = dir.join("short.toml");
    std::fs::write(&params, SHORT_RECOVER).unwrap();
    let recover = ["recover", "--trials", "1", "--seed", "2", "--no-best-case", "--params", s(&params), "--no-timing"];
    let f = twice_the_same(&dir, "recover", &recover);
    let v: serde_json::Value = serde_json::from_slice(&f["summary.json"]).unwrap();
    assert_eq!(v["wall_time_s"].as_f64(), Some(0.0), "recover: {v}");
    let _ = std::fs::remove_dir_all(&dir);
}
