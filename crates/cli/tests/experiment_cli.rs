//! End-to-end tests of `mapkeeper experiment`, run as the real binary on its `--quick` settings.
#![allow(clippy::unwrap_used)]

mod common;

use common::{files, mapkeeper, s, scratch};

#[test]
fn check_detection_writes_its_folder_is_deterministic_and_counts_what_it_reports() {
    let dir = scratch("experiment", "check-detection");
    let (a, b) = (dir.join("a"), dir.join("b"));
    let run = |out: &std::path::Path, jobs: &str| {
        let o =
            mapkeeper(&["experiment", "check-detection", "--quick", "--trials", "8", "--jobs", jobs, "--out", s(out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    };
    let stdout = run(&a, "1");
    assert!(stdout.contains("paper") && stdout.contains("mapkeeper") && stdout.contains("detection"), "{stdout}");
    run(&b, "2");
    // What it runs (8 trials × 3 presets) and where it writes, then the time left as runs finish
    // (stderr, off a terminal).
    let c = dir.join("c");
    let o = mapkeeper(&["experiment", "check-detection", "--quick", "--trials", "8", "--jobs", "1", "--out", s(&c)]);
    let err = String::from_utf8_lossy(&o.stderr);
    let first = err.lines().next().unwrap_or_default();
    assert!(first.starts_with("experiment check-detection: 24 runs to run, on 1 thread(s); writing "), "{err}");
    assert!(first.contains(s(&c)), "{err}");
    let progress: Vec<&str> = err.lines().filter(|l| l.contains(" runs after ")).collect();
    assert!(progress.len() >= 3, "{err}");
    assert!(progress[0].starts_with("experiment check-detection: 1/24 runs after "), "{err}");
    assert!(progress.iter().all(|l| l.ends_with("left (at this run's rate so far)")), "{err}");
    for f in ["summary.json", "trials.csv", "report.md", "detection_by_error.svg", "detection_by_error.png"] {
        assert!(a.join(f).is_file(), "{f} missing");
    }
    common::assert_claims(&std::fs::read_to_string(a.join("report.md")).unwrap(), 4);
    // Same seed, other thread count: every file identical but the wall time in the summary and report.
    let (fa, fb) = (files(&a), files(&b));
    for (name, bytes) in &fa {
        if name == "summary.json" || name == "report.md" {
            continue;
        }
        assert_eq!(Some(bytes), fb.get(name), "{name} differs between --jobs 1 and 2");
    }
    let v: serde_json::Value = serde_json::from_slice(&fa["summary.json"]).unwrap();
    let mut w: serde_json::Value = serde_json::from_slice(&fb["summary.json"]).unwrap();
    w["wall_time_s"] = v["wall_time_s"].clone();
    assert_eq!(v, w);
    assert_eq!(v["trials"], 8);
    // The headline rates are the counts of trials.csv.
    let csv = String::from_utf8_lossy(&fa["trials.csv"]).into_owned();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 24);
    for preset in ["paper", "mapkeeper", "mapkeeper-shift"] {
        let d = &v["check_detection"][preset];
        let bad: Vec<&Vec<&str>> =
            rows.iter().filter(|r| r[0] == preset && r[4].parse::<f64>().unwrap() >= 0.3).collect();
        let detected = bad.iter().filter(|r| r[10] == "true").count();
        assert_eq!(d["detection"]["of"].as_u64().unwrap() as usize, bad.len(), "{preset}");
        assert_eq!(d["detection"]["hits"].as_u64().unwrap() as usize, detected, "{preset}");
        let clean: u64 = rows.iter().filter(|r| r[0] == preset).map(|r| r[11].parse::<u64>().unwrap()).sum();
        assert_eq!(d["false_alarms"]["of"].as_u64().unwrap(), clean, "{preset}");
        assert!(clean > 100, "{preset}: {clean} clean steps");
        let rate = d["detection_rate"].as_f64().unwrap();
        assert!((0.0..=1.0).contains(&rate) && d["false_alarm_rate"].as_f64().unwrap() <= 1.0);
    }
    // A pose held 1 m off in a world one step from the map is seen; a right pose is not flagged.
    let held = &v["check_detection"]["paper"]["by_error"][5];
    assert_eq!(held["bin"], "≥ 1.00 m", "{held}");
    let of = held["detected"]["of"].as_u64().expect("paper by_error[5].detected.of");
    let one_m: Vec<&Vec<&str>> =
        rows.iter().filter(|r| r[0] == "paper" && r[4].parse::<f64>().unwrap() >= 1.0).collect();
    assert_eq!(of as usize, one_m.len(), "{held}");
    assert!(of > 0, "no paper trial with an error of 1 m or more: {held}");
    assert_eq!(
        held["detected"]["hits"].as_u64().expect("hits") as usize,
        one_m.iter().filter(|r| r[10] == "true").count()
    );
    let rate = held["detected"]["rate"].as_f64().expect("paper by_error[5].detected.rate");
    assert!(rate > 0.0, "no 1 m error detected: {held}");
    assert!(v["check_detection"]["paper"]["false_alarm_rate"].as_f64().unwrap() < 0.2);

    // Bad input names the flag or the file.
    let o = mapkeeper(&["experiment", "check-detection", "--quick", "--presets", "nope", "--out", s(&dir.join("c"))]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--presets"), "{}", String::from_utf8_lossy(&o.stderr));
    let o = mapkeeper(&["experiment", "check-detection", "--max-world", "1", "--out", s(&dir.join("c"))]);
    assert_eq!(o.status.code(), Some(2));
    let params = dir.join("p.toml");
    std::fs::write(&params, "[check_detection]\nwindow_s = -1.0\n").unwrap();
    let o =
        mapkeeper(&["experiment", "check-detection", "--quick", "--params", s(&params), "--out", s(&dir.join("c"))]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("p.toml"), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn table1_writes_every_cell_of_the_table_and_the_held_error_costs_always_update() {
    let dir = scratch("experiment", "table1");
    let out = dir.join("t");
    // `table1` is the old spelling of `table1-held-pose`.
    let o = mapkeeper(&["experiment", "table1", "--help"]);
    assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("table1-held-pose"));
    let o = mapkeeper(&["experiment", "table1-held-pose", "--quick", "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["summary.json", "runs.csv", "report.md", "cc_by_hold.svg", "cc_by_hold.png"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    common::assert_claims(&std::fs::read_to_string(out.join("report.md")).unwrap(), 2);
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let t = &v["table1"]["paper"];
    for cond in ["hold_0s", "hold_2s", "amcl_start"] {
        for variant in ["always_update", "check", "check_no_pose_updating"] {
            let c = &t[cond][variant];
            for m in ["cc", "ms", "opdf"] {
                let x = c[m].as_f64().unwrap_or(f64::NAN);
                assert!((0.0..=100.0).contains(&x), "{cond} {variant} {m}: {c}");
            }
            assert_eq!(c["runs"], 2, "{cond} {variant}");
        }
        // always_update's difference from itself is zero.
        assert_eq!(t[cond]["always_update"]["vs_always_update"]["cc"]["mean"].as_f64(), Some(0.0));
    }
    // With no hold the check never acts on a right pose here: the three variants give one map.
    let h0 = &t["hold_0s"];
    assert_eq!(h0["check"]["cc"], h0["always_update"]["cc"]);
    // A pose held wrong for 2 s: updating without the check flips cells wrongly, the check does not.
    let h2 = &t["hold_2s"];
    assert!(
        h2["always_update"]["wrong_flips"].as_f64().unwrap() > h2["check"]["wrong_flips"].as_f64().unwrap(),
        "{h2}"
    );
    assert!(h2["check"]["vs_always_update"]["cc"]["mean"].as_f64().unwrap() > 0.0, "{h2}");
    let csv = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 2 * 3 * 3);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn kidnap_robot_moves_the_robot_and_accounts_for_every_trial() {
    let dir = scratch("experiment", "kidnap-robot");
    let out = dir.join("k");
    let o = mapkeeper(&["experiment", "kidnap-robot", "--quick", "--out", s(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["summary.json", "trials.csv", "report.md"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    common::assert_claims(&std::fs::read_to_string(out.join("report.md")).unwrap(), 2);
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let k = &v["kidnap_robot"];
    assert_eq!(k["trials"], 3);
    let applied = k["applied"].as_u64().unwrap();
    assert!(applied >= 1, "{k}");
    let sum: f64 = ["recovered_rate_pose_updating", "recovered_rate_filter", "failed_rate"]
        .iter()
        .map(|f| k[f].as_f64().unwrap())
        .sum();
    assert!((sum - 1.0).abs() < 1e-9, "{k}");
    assert!(k["trials_reference_held"].as_u64().unwrap() <= applied, "{k}");
    assert!((0.0..=1.0).contains(&k["recovered_rate_reference_held"].as_f64().unwrap()), "{k}");
    for m in ["cc", "ms", "opdf"] {
        assert!(k["map_damage"][m].is_number(), "{k}");
    }
    let csv = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv.lines().skip(1).map(|l| l.split(',').collect()).collect();
    // Three trials on each of the three maps (W_1's, the chain's M_{k-1}, G_{k-1}).
    assert_eq!(rows.len(), 9);
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let maps: Vec<&str> = v["by_map"].as_array().unwrap().iter().map(|m| m["map"].as_str().unwrap()).collect();
    assert_eq!(maps, ["w1", "chain", "truth"]);
    assert_eq!(&v["by_map"][0], k, "kidnap_robot is the first map's summary");
    for m in &maps {
        assert_eq!(rows.iter().filter(|r| r[1] == *m).count(), 3, "{m}");
    }
    for r in &rows {
        assert_eq!(r.len(), header.len(), "{r:?}");
        let at = |c: &str| r[header.iter().position(|h| *h == c).unwrap()].parse::<u64>().unwrap();
        // Lost while well localised ⊆ while right ⊆ at all; well-localised steps ⊆ steps.
        assert!(at("reference_lost_well_localised") <= at("reference_lost_right_pose"), "{r:?}");
        assert!(at("reference_lost_right_pose") <= at("reference_lost"), "{r:?}");
        assert!(at("reference_steps_well_localised") <= at("reference_steps") && at("reference_steps") > 0, "{r:?}");
        assert!(at("handovers_held") <= at("handovers_right"), "{r:?}");
    }
    let col = |r: &Vec<&str>, c: &str| r[header.iter().position(|h| *h == c).unwrap()].to_string();
    for r in rows.iter().filter(|r| col(r, "applied") == "true") {
        // The robot really moved, by 0.5-3 m, and the localiser (told nothing) was wrong after it.
        let d: f64 = col(r, "applied_displacement_m").parse().unwrap();
        assert!((0.49..=3.01).contains(&d), "{r:?}");
        assert_eq!(col(r, "detected"), "true", "a moved robot is said Lost: {r:?}");
    }
    let o = mapkeeper(&["experiment", "kidnap-robot", "--quick", "--maps", "chain,w2", "--out", s(&dir.join("y"))]);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--maps") && e.contains("unknown map \"w2\""), "{e}");
    let o = mapkeeper(&["experiment", "kidnap-robot", "--quick", "--preset", "nope", "--out", s(&dir.join("x"))]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--preset"), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Without `--out`, a run writes `results/<command>-s<SEED>-<N>t-001` under the working folder,
/// the next one `-002`: an earlier run is never overwritten.
#[test]
fn without_out_each_run_gets_the_next_numbered_folder() {
    let dir = scratch("experiment", "default-out");
    for k in 1..=2 {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_mapkeeper"))
            .args(["experiment", "kidnap-robot", "--quick", "--trials", "1", "--jobs", "1"])
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = dir.join(format!("results/kidnap-robot-s41-1t-{k:03}"));
        assert!(out.join("summary.json").is_file(), "run {k}: {} missing", out.display());
        assert!(String::from_utf8_lossy(&o.stdout).contains(&format!("kidnap-robot-s41-1t-{k:03}")));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
