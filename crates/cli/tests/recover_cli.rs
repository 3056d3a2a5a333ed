//! End-to-end test of `mapkeeper recover`, run as the real binary with every experiment
//! shortened by a parameter file.
// Helpers outside `#[test]` functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used)]

mod common;

use common::SHORT_RECOVER;
use std::path::PathBuf;
use std::process::Command;

fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-recover-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn recover_writes_the_summary_csv_and_report_and_refuses_bad_input() {
    let dir = scratch();
    let params = dir.join("short.toml");
    std::fs::write(&params, SHORT_RECOVER).unwrap();
    let out = dir.join("out");
    let run_as = |command: &[&str], extra: &[&str]| {
        let mut args = command.to_vec();
        args.extend_from_slice(&["--trials", "1", "--seed", "2", "--jobs", "2", "--params"]);
        args.push(params.to_str().unwrap());
        args.extend_from_slice(extra);
        Command::new(env!("CARGO_BIN_EXE_mapkeeper")).args(&args).output().unwrap()
    };
    let run = |extra: &[&str]| run_as(&["recover"], extra);
    let o = run(&["--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("Table 1 direction reproduced"), "{stdout}");
    for f in ["summary.json", "kidnap_trials.csv", "table1.csv", "lost_robot.csv", "demo_timeline.csv", "report.md"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(v["seed"], 2);
    assert_eq!(v["kidnap"]["trials"], 1);
    assert!(v["table1"]["check"]["opdf"].is_number());
    assert!(v["wall_time_s"].as_f64().unwrap() > 0.0);

    // The same suite under the experiment family's name writes the same files (but for the wall
    // time in summary.json and report.md).
    let out2 = dir.join("out2");
    let o = run_as(&["experiment", "recovery-suite"], &["--out", out2.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["kidnap_trials.csv", "table1.csv", "lost_robot.csv", "demo_timeline.csv"] {
        assert_eq!(std::fs::read(out.join(f)).unwrap(), std::fs::read(out2.join(f)).unwrap(), "{f}");
    }

    // An existing folder is refused without --force.
    let o = run(&["--out", out.to_str().unwrap()]);
    assert!(!o.status.success());
    // A bad parameter file names the file.
    std::fs::write(&params, "[kidnap]\nmin_displacement_m = \"far\"\n").unwrap();
    let o = run(&["--out", dir.join("other").to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("short.toml"), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_dir_all(&dir).unwrap();
}
