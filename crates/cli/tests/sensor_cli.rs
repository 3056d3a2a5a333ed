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
