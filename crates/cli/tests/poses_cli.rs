//! End-to-end tests of the updater's pose source (`--poses localiser|true|true+noise` and the
//! noise flags) on `validate` and `run`, as the real binary on tiny settings (2 worlds, a 10 m
//! route): the source reaches the outputs, the same seed gives the same folder, and bad values
//! are refused naming the flag.
#![allow(clippy::unwrap_used)]

mod common;

use common::{files, mapkeeper, s, scratch, validate_args};
use std::path::{Path, PathBuf};

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `validate` of 2 worlds on a 10 m route into `dir/name`, untimed, with `extra` arguments.
fn validate(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut args = vec!["validate", "--worlds", "2", "--route-length", "10", "--no-timing", "--jobs", "1"];
    args.extend(["--out", s(&out)]);
    args.extend_from_slice(extra);
    let args = validate_args(&args);
    let r = mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(r.status.success(), "validate {extra:?} failed: {}", stderr(&r));
    out
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn validate_with_true_poses_feeds_the_updater_the_truth_and_says_so() {
    let dir = scratch("poses-cli", "true");
    let out = validate(&dir, "true", &["--poses", "true"]);
    let summary = json(&out.join("summary.json"));
    assert_eq!(summary["params"]["runner"]["updater_poses"], serde_json::json!({ "source": "true" }));
    let e = &summary["updater_pose_error"];
    assert!(e["steps"].as_u64().unwrap() > 50, "{e}");
    assert_eq!((e["rmse_m"].as_f64(), e["yaw_rmse_rad"].as_f64()), (Some(0.0), Some(0.0)), "{e}");
    // The chain localiser still ran and is scored.
    assert!(summary["localisation"]["updated_map"]["mean_error_m"].as_f64().unwrap() > 0.0);
    let runs = json(&out.join("runs.json"));
    assert_eq!(runs["params"]["runner"]["updater_poses"]["source"], "true");
    assert!(runs["seeds"][0]["rows"][0]["updater_pose_error"].is_object());
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("Pose source of the updater: the simulator's true pose at every step"), "{report}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn validate_with_noisy_true_poses_records_the_noise_and_repeats_with_the_seed() {
    let dir = scratch("poses-cli", "noise");
    let noise = [
        "--poses",
        "true+noise",
        "--pose-noise-xy-m",
        "0.05",
        "--pose-noise-yaw-deg",
        "1",
        "--pose-bias-yaw-deg",
        "0.5",
        "--pose-bias-tau-s",
        "10",
    ];
    let a = validate(&dir, "a", &noise);
    let summary = json(&a.join("summary.json"));
    let p = &summary["params"]["runner"]["updater_poses"];
    assert_eq!(p["source"], "true+noise");
    assert_eq!(p["sigma_xy_m"], 0.05);
    assert_eq!(p["yaw_bias_tau_s"], 10.0);
    assert!((p["sigma_yaw_rad"].as_f64().unwrap() - 1f64.to_radians()).abs() < 1e-15);
    assert!((p["yaw_bias_sigma_rad"].as_f64().unwrap() - 0.5f64.to_radians()).abs() < 1e-15);
    // RMSE of a 2-D Gaussian position error: √2 σ (a hundred-odd steps: within 25 %).
    let rmse = summary["updater_pose_error"]["rmse_m"].as_f64().unwrap();
    assert!((rmse / (0.05 * 2f64.sqrt()) - 1.0).abs() < 0.25, "RMSE {rmse} m");
    let report = std::fs::read_to_string(a.join("report.md")).unwrap();
    assert!(report.contains("`--poses true+noise`") && report.contains("σ 0.05 m"), "{report}");
    let b = validate(&dir, "b", &noise);
    assert!(files(&a) == files(&b), "the same seed gave different folders");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn bad_pose_sources_and_noise_values_are_refused_naming_the_flag() {
    let dir = scratch("poses-cli", "bad");
    let out = dir.join("out");
    for (extra, flag) in [
        (vec!["--poses", "foo"], "--poses"),
        (vec!["--poses", "true+noise", "--pose-noise-xy-m", "-0.1"], "--pose-noise-xy-m"),
        (vec!["--poses", "true+noise", "--pose-noise-yaw-deg", "NaN"], "--pose-noise-yaw-deg"),
        (vec!["--poses", "true+noise", "--pose-bias-yaw-deg", "-1"], "--pose-bias-yaw-deg"),
        (vec!["--poses", "true+noise", "--pose-bias-tau-s", "0"], "--pose-bias-tau-s"),
        (vec!["--pose-noise-xy-m", "0.1"], "--pose-noise-xy-m needs --poses true+noise"),
        (vec!["--poses", "true", "--pose-bias-tau-s", "5"], "--pose-bias-tau-s needs --poses true+noise"),
    ] {
        let mut args = vec!["validate", "--worlds", "2", "--out", s(&out)];
        args.extend_from_slice(&extra);
        let r = mapkeeper(&args);
        assert!(!r.status.success(), "{extra:?} was accepted");
        assert!(stderr(&r).contains(flag), "{extra:?}: the error does not name {flag}: {}", stderr(&r));
        assert!(!out.exists(), "{extra:?}: {} was created", out.display());
    }
    let r = mapkeeper(&["run", "--log", "x.jsonl", "--map", "m.yaml", "--out", s(&out), "--poses", "true"]);
    assert!(!r.status.success() && stderr(&r).contains("--poses"), "{}", stderr(&r));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn run_with_true_poses_records_the_source_in_run_json() {
    let dir = scratch("poses-cli", "run");
    let gen_dir = dir.join("gen");
    let out = mapkeeper(&["generate", "--worlds", "2", "--seed", "3", "--out", s(&gen_dir)]);
    assert!(out.status.success(), "{}", stderr(&out));
    std::fs::write(
        dir.join("route.toml"),
        "format = \"mapkeeper-route\"\nversion = 1\nwaypoints = [[-3.65, -2.3], [-3.65, 5.0]]\n",
    )
    .unwrap();
    let (world, map, route) =
        (gen_dir.join("worlds/W_002.toml"), gen_dir.join("ground_truth/G_001.yaml"), dir.join("route.toml"));
    let run = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["run", "--world", s(&world), "--map", s(&map), "--route", s(&route), "--out", s(&out)];
        args.extend_from_slice(extra);
        let r = mapkeeper(&args);
        assert!(r.status.success(), "{}", stderr(&r));
        json(&out.join("run.json"))
    };
    let default = run("default", &[]);
    assert!(default.get("updater_poses").is_none() && default.get("updater_pose_error").is_none(), "{default}");
    let oracle = run("true", &["--poses", "true"]);
    assert_eq!(oracle["updater_poses"]["source"], "true");
    assert_eq!(oracle["updater_pose_error"]["rmse_m"], 0.0);
    // Without a recovered pose re-initialising it, the chain localiser ran exactly as with
    // --poses localiser. The setup is seeded, and neither run recovers a pose on this short
    // route: asserted, so that the comparison below always runs.
    for (name, r) in [("default", &default), ("--poses true", &oracle)] {
        let recovered = r["updater"]["recovered"].as_u64().unwrap_or_else(|| panic!("{name}: updater.recovered: {r}"));
        assert_eq!(recovered, 0, "{name}: a recovered pose re-initialised the chain localiser");
    }
    assert!(oracle["chain"].is_object(), "{oracle}");
    assert_eq!(oracle["chain"], default["chain"]);
    let _ = std::fs::remove_dir_all(dir);
}
