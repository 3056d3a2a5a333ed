//! End-to-end tests of the localiser presets on the command line (`--localiser`) and of
//! `mapkeeper converge`, as the real binary in a temporary folder.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn an_unknown_localiser_is_refused_naming_the_flag_and_the_known_presets() {
    let dir = scratch("localiser-cli", "nope");
    let out = s(&dir);
    let cases: [&[&str]; 5] = [
        &["validate", "--localiser", "nope", "--worlds", "2", "--out", out],
        &["recover", "--localiser", "nope", "--out", out],
        &["run", "--localiser", "nope", "--world", "w.toml", "--map", "m.yaml", "--out", out],
        &["localise", "--localiser", "nope", "--log", "l", "--map", "m.yaml", "--out", out],
        &["converge", "--localisers", "amcl,nope", "--seeds", "1", "--out", out],
    ];
    for args in cases {
        let o = mapkeeper(args);
        assert!(!o.status.success(), "{args:?}");
        let e = stderr(&o);
        assert!(e.contains("--localiser") && e.contains("'nope'") && e.contains("mapkeeper, amcl"), "{args:?}: {e}");
    }
}

/// The default `validate` is the paper's setting: presets paper and mapkeeper side by side, the
/// amcl localiser (recorded with its parameters), the first hold-out seed 11, and intervals over
/// batches of its worlds, also for mapkeeper − paper (21 worlds: the fewest that have them).
#[test]
fn validate_by_default_sweeps_paper_and_mapkeeper_with_amcl_on_a_hold_out_seed() {
    let dir = scratch("localiser-cli", "validate");
    let out = dir.join("v");
    let args = ["validate", "--worlds", "21", "--route-length", "4", "--no-timing", "--out", s(&out)];
    let o = mapkeeper(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |rel: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(out.join(rel)).unwrap()).unwrap()
    };
    for preset in ["paper", "mapkeeper"] {
        let summary = read(&format!("{preset}/summary.json"));
        assert_eq!(summary["preset"], preset);
        assert_eq!(summary["seeds"], serde_json::json!([11]), "{preset}");
        assert_eq!(summary["interval_units"], "world-batches", "{preset}");
        assert_eq!(summary["localiser"], "amcl");
        assert_eq!(summary["params"]["runner"]["localiser"], "amcl");
        assert_eq!(summary["params"]["runner"]["filter"]["beam_combination"], "amcl_cube_sum");
        assert_eq!(summary["params"]["runner"]["filter"]["beam_selection"], "amcl_stride");
        for m in ["cc", "ms", "opdf"] {
            let q = &summary["map_quality"][m];
            let (lo, hi, mean) = (
                q["diff_ci95"][0].as_f64().unwrap(),
                q["diff_ci95"][1].as_f64().unwrap(),
                q["diff_mean"].as_f64().unwrap(),
            );
            assert!(lo <= mean && mean <= hi, "{preset} {m}: an interval round its mean: {q}");
        }
        let report = std::fs::read_to_string(out.join(preset).join("report.md")).unwrap();
        assert!(
            report.contains("localiser `amcl`") && report.contains("95 % CI over 10 batches of seed 11's worlds"),
            "{report}"
        );
    }
    let top = read("summary.json");
    assert_eq!(top["presets"], serde_json::json!(["paper", "mapkeeper"]));
    let diff = &top["preset_diffs"][0];
    assert_eq!((diff["a"].as_str(), diff["b"].as_str()), (Some("mapkeeper"), Some("paper")));
    assert_eq!(diff["seeds"], serde_json::json!([11]));
    assert_eq!(diff["interval_units"], "world-batches");
    assert!(diff["cc"]["ci95"][0].is_f64(), "{diff}");
    assert!(String::from_utf8_lossy(&o.stdout).contains("localiser amcl"));
}

#[test]
fn converge_writes_a_table_and_one_csv_per_run_and_refuses_an_existing_folder() {
    let dir = scratch("localiser-cli", "converge");
    let out = dir.join("c");
    let args = [
        "converge",
        "--localisers",
        "amcl,mapkeeper",
        "--seeds",
        "1",
        "--errors",
        "0.5",
        "--max-time",
        "8",
        "--out",
        s(&out),
    ];
    let o = mapkeeper(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(md.contains("| amcl | 0.5 | 1 |") && md.contains("| mapkeeper | 0.5 | 1 |"), "{md}");
    let runs = std::fs::read_to_string(out.join("runs.csv")).unwrap();
    assert_eq!(runs.lines().count(), 3, "{runs}");
    for l in ["amcl", "mapkeeper"] {
        let csv = std::fs::read_to_string(out.join(format!("runs/{l}-e0.5-s1.csv"))).unwrap();
        assert!(csv.starts_with("t_s,distance_m,error_m,yaw_error_rad\n") && csv.lines().count() > 50);
    }
    let again = mapkeeper(&args);
    assert!(!again.status.success());
    let mut forced = args.to_vec();
    forced.push("--force");
    assert!(mapkeeper(&forced).status.success());
    let bad = mapkeeper(&["converge", "--errors", "0.5,x", "--out", s(&dir.join("bad"))]);
    assert!(!bad.status.success() && stderr(&bad).contains("--errors"), "{}", stderr(&bad));
}

#[test]
fn localise_records_the_preset_and_a_parameter_file_overrides_it() {
    let dir = scratch("localiser-cli", "localise");
    let sim = dir.join("sim");
    let o = mapkeeper(&["simulate", "--seconds", "4", "--seed", "2", "--out", s(&sim)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let file = dir.join("f.toml");
    std::fs::write(&file, "max_particles = 800\n").unwrap();
    let (map, loc) = (sim.join("ground_truth.yaml"), dir.join("loc"));
    let args = ["localise", "--localiser", "amcl", "--params", s(&file), "--log", s(&sim), "--map", s(&map)];
    let o = mapkeeper(&[&args[..], &["--out", s(&loc)]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let rec: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(loc.join("params.json")).unwrap()).unwrap();
    assert_eq!(rec["localiser"], "amcl");
    assert_eq!(rec["filter"]["beam_combination"], "amcl_cube_sum");
    assert_eq!(rec["filter"]["max_particles"], 800);
    let tum = std::fs::read_to_string(loc.join("estimate.tum")).unwrap();
    assert!(tum.lines().next().unwrap().contains("localiser amcl"), "{tum}");
}
