//! Logs with scans only (issue 52, item 6), through the real binary: a bag with laser scans and
//! no odometry is refused naming `--odometry-from-scans`, converts with it, and localises,
//! updates and runs on the converted log; a log with odometry has it replaced, and says so; the
//! Intel CARMEN log without its odometry converts and localises on its own map.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};
use mapkeeper_sensor::{LogRecord, SensorLog};
use std::path::Path;

fn ok(args: &[&str]) -> String {
    let o = mapkeeper(args);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn err(args: &[&str]) -> String {
    let o = mapkeeper(args);
    assert!(!o.status.success(), "{args:?} should fail");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `log` without its odometry records.
fn without_odometry(mut log: SensorLog) -> SensorLog {
    log.records.retain(|r| !matches!(r, LogRecord::Odom(_)));
    log
}

fn import_json(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("import.json")).unwrap()).unwrap()
}

/// The position RMSE printed by `localise`, metres.
fn rmse(out: &str) -> f64 {
    let at = out.find("position RMSE ").unwrap_or_else(|| panic!("no RMSE in {out}"));
    out[at + 14..].split_whitespace().next().unwrap().parse().unwrap()
}

#[test]
fn a_bag_with_scans_only_converts_with_the_flag_and_localises_updates_and_runs() {
    let dir = scratch("scan-odometry", "bag");
    let sim = dir.join("sim");
    ok(&["simulate", "--seconds", "8", "--seed", "4", "--out", s(&sim)]);
    let map = sim.join("ground_truth.yaml");
    // The drive as a ROS 2 bag of scans and reference poses, nothing else.
    let scans_only = without_odometry(SensorLog::read(&sim.join("log.jsonl")).unwrap());
    let bag = mapkeeper_logs::write_log_mcap(&scans_only, &dir.join("scans.mcap")).unwrap();
    let conv = dir.join("conv");
    let e = err(&["convert", "--log", s(&bag), "--truth-topic", "/truth", "--out", s(&conv)]);
    assert!(e.contains("scans.mcap") && e.contains("no odometry") && e.contains("--odometry-from-scans"), "{e}");
    assert!(!conv.exists());
    let e = err(&["convert", "--log", s(&bag), "--odometry-from-scans", "--odom-topic", "/odom", "--out", s(&conv)]);
    assert!(e.contains("--odometry-from-scans") && e.contains("--odom-topic"), "{e}");
    let out = ok(&["convert", "--log", s(&bag), "--truth-topic", "/truth", "--odometry-from-scans", "--out", s(&conv)]);
    assert!(out.contains("odometry made by scan matching: 100 steps"), "{out}");
    let import = import_json(&conv);
    assert_eq!(import["odometry_source"], "scan matching (--odometry-from-scans)", "{import}");
    let made = &import["scan_odometry"];
    assert_eq!(made["steps"], 100, "{made}");
    assert!(made["refused"].as_u64().unwrap() <= 2 && made["restarts"] == 0, "{made}");
    assert!(made["method"].as_str().unwrap().contains("scan-to-local-map"), "{made}");
    let header = SensorLog::read(&conv.join("log.jsonl")).unwrap().header;
    assert_eq!(header.meta["scan_odometry"], *made, "the log's header carries the report");
    // Localised on the drive's map: as close to the truth as with the simulator's odometry
    // (measured 0.024 m and 0.023 m, seed 2).
    let loc = |log: &Path, out: &str| {
        rmse(&ok(&[
            "localise",
            "--log",
            s(log),
            "--map",
            s(&map),
            "--localiser",
            "mapkeeper",
            "--seed",
            "2",
            "--out",
            s(&dir.join(out)),
        ]))
    };
    let (scan_made, wheels) = (loc(&conv, "loc-conv"), loc(&sim, "loc-sim"));
    assert!(scan_made < 0.05 && scan_made < wheels + 0.02, "{scan_made} m against {wheels} m");
    // The map updater with the localiser, and `run --log`, go through too.
    let out = ok(&["update", "--log", s(&conv), "--map", s(&map), "--localise", "--out", s(&dir.join("upd"))]);
    assert!(out.contains("steps"), "{out}");
    ok(&["run", "--log", s(&conv), "--map", s(&map), "--out", s(&dir.join("run"))]);
    assert!(dir.join("run/poses.tum").is_file());
    // The project's own log without odometry: the commands that localise name the way out.
    let stripped = dir.join("stripped.jsonl");
    scans_only.write(&stripped).unwrap();
    for args in [
        vec!["localise", "--log", s(&stripped), "--map", s(&map), "--out", s(&dir.join("x"))],
        vec!["update", "--log", s(&stripped), "--map", s(&map), "--localise", "--out", s(&dir.join("x"))],
        vec!["run", "--log", s(&stripped), "--map", s(&map), "--out", s(&dir.join("x"))],
    ] {
        let e = err(&args);
        assert!(
            e.contains("stripped.jsonl") && e.contains("no odometry") && e.contains("--odometry-from-scans"),
            "{e}"
        );
        assert!(!dir.join("x").exists());
    }
}

#[test]
fn a_log_with_odometry_has_it_replaced_and_the_report_says_so() {
    let dir = scratch("scan-odometry", "replace");
    let sim = dir.join("sim");
    ok(&["simulate", "--seconds", "3", "--seed", "5", "--out", s(&sim)]);
    let conv = dir.join("conv");
    let out = ok(&["convert", "--log", s(&sim), "--odometry-from-scans", "--out", s(&conv)]);
    assert!(out.contains("odometry made by scan matching") && out.contains("odometry readings replaced"), "{out}");
    let import = import_json(&conv);
    assert!(import["note"].as_str().unwrap().contains("odometry readings replaced"), "{import}");
    let (before, after) =
        (SensorLog::read(&sim.join("log.jsonl")).unwrap(), SensorLog::read(&conv.join("log.jsonl")).unwrap());
    assert_eq!(after.scans().count(), before.scans().count());
    assert_eq!(after.truth().count(), before.truth().count());
    // One reading per scan time (the two lidars share their stamps), the first at the identity.
    let stamps: std::collections::BTreeSet<u64> = before.scans().map(|s| s.stamp_ns).collect();
    let odom: Vec<_> = after.odometry().collect();
    assert_eq!(odom.len(), stamps.len());
    assert_eq!(odom[0].pose_in_odom, mapkeeper_grid::Pose2::IDENTITY);
}

#[test]
fn intel_without_its_odometry_converts_with_the_flag_and_localises_on_its_own_map() {
    // The Intel log's scans are 0.7 m apart (a corrected log keeps one scan per metre or half
    // turn): the scan odometry holds over its first 90 scans (66 m of path) and then, in the
    // corridors, takes a look-alike a metre off (docs/real-data.md, "Logs with scans only").
    let Some(intel) = mapkeeper_common::shared_data::path(
        "data/carmen/intel-corrected.log.gz",
        "intel_without_its_odometry_converts_with_the_flag_and_localises_on_its_own_map",
    ) else {
        return;
    };
    const SCANS: usize = 90;
    let dir = scratch("scan-odometry", "intel");
    ok(&["convert", "--log", s(&intel), "--out", s(&dir.join("full"))]);
    let full = SensorLog::read(&dir.join("full/log.jsonl")).unwrap();
    let end = full.scans().nth(SCANS).unwrap().stamp_ns;
    let mut head = full.clone();
    head.records.retain(|r| r.stamp_ns() < end);
    std::fs::create_dir_all(dir.join("wheels")).unwrap();
    head.write(&dir.join("wheels/log.jsonl")).unwrap();
    std::fs::create_dir_all(dir.join("stripped")).unwrap();
    without_odometry(head).write(&dir.join("stripped/log.jsonl")).unwrap();
    let e = err(&["localise", "--log", s(&dir.join("stripped")), "--map", "m.yaml", "--out", s(&dir.join("x"))]);
    assert!(e.contains("--odometry-from-scans"), "{e}");
    let conv = dir.join("conv");
    ok(&["convert", "--log", s(&dir.join("stripped")), "--odometry-from-scans", "--out", s(&conv)]);
    let made = &import_json(&conv)["scan_odometry"];
    assert_eq!(made["steps"], SCANS, "{made}");
    let map = dir.join("map.yaml");
    ok(&["map", "--log", s(&dir.join("wheels")), "--out", s(&map)]);
    let loc = |log: &str| {
        rmse(&ok(&[
            "localise",
            "--log",
            s(&dir.join(log)),
            "--map",
            s(&map),
            "--localiser",
            "mapkeeper-real",
            "--out",
            s(&dir.join(format!("loc-{log}"))),
        ]))
    };
    let (scan_made, wheels) = (loc("conv"), loc("wheels"));
    println!(
        "Intel, first {SCANS} scans: position RMSE {scan_made:.4} m with scan odometry, {wheels:.4} m with its own"
    );
    assert!(scan_made < 0.05, "{scan_made} m (with its own odometry {wheels} m)");
}
