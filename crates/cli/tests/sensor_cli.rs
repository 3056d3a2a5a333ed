//! `--robot`, `--sensor-profile` and `--sensor-effects` (issue 13, items 4 and 5): a robot
//! file with upside-down lidars gives mirrored scans in the log; bad files and names are refused
//! before any work, naming the flag, the file, the entry and the problem.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn simulate_with_the_upside_down_robot_file_logs_mirrored_scans() {
    let dir = scratch("sensor-cli", "upside-down");
    let robot = concat!(env!("CARGO_MANIFEST_DIR"), "/../../robots/summit-xl-steel-s300.toml");
    let out = dir.join("sim");
    let r = mapkeeper(&[
        "simulate",
        "--robot",
        robot,
        "--sensor-effects",
        "legs,unsync",
        "--seconds",
        "1",
        "--out",
        s(&out),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let log = std::fs::read_to_string(out.join("log.jsonl")).unwrap();
    let scans: Vec<serde_json::Value> = log
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["type"] == "scan")
        .collect();
    assert!(scans.len() >= 20, "{} scans", scans.len());
    for v in &scans {
        assert!(v["angle_increment_rad"].as_f64().unwrap() < 0.0, "not mirrored: {}", v["angle_increment_rad"]);
        assert!(v["angle_min_rad"].as_f64().unwrap() > 0.0);
    }
    // Unsynchronised: the two lidars never fire on the same tick with these seeds' phases
    // (or at least not always).
    let stamps = |id: u64| -> Vec<u64> {
        scans.iter().filter(|v| v["lidar_id"] == id).map(|v| v["stamp_ns"].as_u64().unwrap()).collect()
    };
    assert_ne!(stamps(0), stamps(1), "the lidars fire together");
}

#[test]
fn bad_robot_files_and_effect_names_are_refused_before_any_work() {
    let dir = scratch("sensor-cli", "bad");
    let bad = dir.join("bot.toml");
    std::fs::write(
        &bad,
        "format = \"mapkeeper-robot\"\nversion = 1\n[[lidars]]\nmodel = \"velodyne\"\nx = 0\ny = 0\nyaw_deg = 0\n",
    )
    .unwrap();
    let out = dir.join("out");
    for (args, want) in [
        (
            vec!["simulate", "--robot", s(&bad)],
            format!("--robot: {}: lidars[0].model: unknown lidar model 'velodyne'", s(&bad)),
        ),
        (vec!["simulate", "--robot", "/nonexistent/r.toml"], "--robot: /nonexistent/r.toml".to_string()),
        (
            vec!["validate", "--sensor-effects", "mixed-pixels,blur"],
            "--sensor-effects: unknown sensor effect 'blur'".into(),
        ),
        (vec!["validate", "--sensor-profile", "foggy"], "--sensor-profile: unknown sensor profile 'foggy'".into()),
        (vec!["validate", "--sensor-profile", "realistic", "--sensor-effects", "legs"], "cannot be used with".into()),
    ] {
        let mut a = args.clone();
        a.extend(["--out", s(&out)]);
        let r = mapkeeper(&a);
        assert!(!r.status.success(), "{args:?} accepted");
        let e = stderr(&r);
        assert!(e.contains(&want), "{args:?}: expected {want:?} in: {e}");
        assert!(r.stdout.is_empty(), "{args:?}: wrote to stdout");
        assert!(!out.exists(), "{args:?}: made the output folder");
    }
}

#[test]
fn the_sensor_realism_experiment_compares_each_switch_with_ideal_whatever_the_threads() {
    let dir = scratch("sensor-cli", "realism");
    let run = |jobs: &str| {
        let out = dir.join(format!("j{jobs}"));
        let r = mapkeeper(&[
            "experiment",
            "sensor-realism",
            "--quick",
            "--worlds",
            "2",
            "--route-length",
            "10",
            "--configs",
            "latency,motion-distortion",
            "--jobs",
            jobs,
            "--out",
            s(&out),
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        out
    };
    let (a, b) = (run("1"), run("2"));
    for f in ["summary.json", "worlds.csv", "report.md"] {
        assert_eq!(std::fs::read(a.join(f)).unwrap(), std::fs::read(b.join(f)).unwrap(), "{f} differs across --jobs");
    }
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(a.join("summary.json")).unwrap()).unwrap();
    let configs = v["configs"].as_array().unwrap();
    let names: Vec<&str> = configs.iter().map(|c| c["config"].as_str().unwrap()).collect();
    assert_eq!(names, ["ideal", "latency", "motion-distortion"]);
    assert_eq!(configs[0]["cc_updated_vs_ideal"]["mean"], 0.0);
    for c in &configs[1..] {
        assert_eq!(c["effects"].as_array().unwrap().len(), 1, "{c}");
        // The switch reaches the scans: the run is not the ideal one.
        assert_ne!(c["err_mean_m"], configs[0]["err_mean_m"], "{} changed nothing", c["config"]);
        assert!(c["runs"] == 1 && c["routes_done"] == 1, "{c}");
    }
    let csv = std::fs::read_to_string(a.join("worlds.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3, "{csv}");
    let report = std::fs::read_to_string(a.join("report.md")).unwrap();
    assert!(report.contains("| motion-distortion |"), "{report}");
    // A bad configuration is refused before any work, naming the flag.
    let bad = dir.join("bad");
    let r = mapkeeper(&["experiment", "sensor-realism", "--configs", "legs,fog", "--out", s(&bad)]);
    assert!(!r.status.success() && stderr(&r).contains("--configs") && stderr(&r).contains("'fog'"), "{}", stderr(&r));
    assert!(!bad.exists());
}

#[test]
fn validate_runs_with_the_realistic_profile_and_records_it() {
    let dir = scratch("sensor-cli", "validate-realistic");
    let out = dir.join("v");
    let r = mapkeeper(&[
        "validate",
        "--sensor-profile",
        "realistic",
        "--worlds",
        "2",
        "--seeds",
        "1",
        "--preset",
        "mapkeeper",
        "--route-length",
        "8",
        "--no-timing",
        "--out",
        s(&out),
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let realism = &v["params"]["runner"]["sim"]["realism"];
    assert!(realism.is_object(), "realism not recorded: {}", v["params"]["runner"]["sim"]);
    assert_eq!(v["routes_completed"], 1);
}
