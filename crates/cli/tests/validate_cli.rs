//! End-to-end tests of `mapkeeper validate` and `mapkeeper merge`, run as the real binary on
//! tiny validations (3 worlds, 2 seeds, a 10 m route).
//!
//! Determinism contract checked here: the same seeds give the same folder, file for file and
//! byte for byte, under `--no-timing`, whatever the thread count and whether the seeds ran in
//! one process or in shards merged afterwards; with timing on, only `wall_time_s` and the
//! `median_scan_us` figures differ.
// Helpers outside `#[test]` functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used)]

mod common;

use common::{files, validate_args};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The figure files every validation folder holds (stems under `plots/`).
const FIGURES: [&str; 9] = [
    "fig24a_cc",
    "fig24b_ms",
    "fig24c_opdf",
    "fig25a_position_error",
    "fig25b_max_position_error",
    "fig26a_trace",
    "fig26b_lambda_max",
    "fig27a_updater_time",
    "fig27b_updater_memory",
];

/// This test binary's scratch folder (one per process).
fn scratch() -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("mapkeeper-validate-cli-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    })
    .clone()
}

/// The number of `#[test]` functions in this file: the last one to pass removes the scratch
/// folder (it is kept when a test fails, or when tests are filtered).
const TESTS: usize = 8;

/// Called at the end of each test.
fn done() {
    static PASSED: AtomicUsize = AtomicUsize::new(0);
    if PASSED.fetch_add(1, Ordering::SeqCst) + 1 == TESTS {
        let _ = std::fs::remove_dir_all(scratch());
    }
}

fn mapkeeper(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mapkeeper")).args(args).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `validate` of 3 worlds (unless `extra` says otherwise) on a 10 m route into
/// `scratch()/name`, with `extra` arguments.
fn validate(name: &str, extra: &[&str]) -> PathBuf {
    let out = scratch().join(name);
    let o = out.to_str().unwrap();
    let mut args = vec!["validate", "--route-length", "10", "--out", o];
    if !extra.contains(&"--worlds") {
        args.extend(["--worlds", "3"]);
    }
    args.extend_from_slice(extra);
    let args = validate_args(&args);
    let r = mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(r.status.success(), "validate {extra:?} failed: {}", stderr(&r));
    out
}

/// Seeds 1 and 2 in one untimed run (shared by the tests).
fn whole() -> &'static Path {
    static D: OnceLock<PathBuf> = OnceLock::new();
    D.get_or_init(|| validate("whole", &["--seeds", "2", "--no-timing"]))
}

/// The same as shards 1/2 and 2/2, on one thread each.
fn shards() -> &'static (PathBuf, PathBuf) {
    static D: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    D.get_or_init(|| {
        let a = validate("shard1", &["--seeds", "2", "--no-timing", "--shard", "1/2", "--jobs", "1"]);
        let b = validate("shard2", &["--seeds", "2", "--no-timing", "--shard", "2/2", "--jobs", "1"]);
        (a, b)
    })
}

fn copy_dir(from: &Path, to: &Path) {
    for (rel, bytes) in files(from) {
        let p = to.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, bytes).unwrap();
    }
}

/// Width and height of a PNG file, after checking its signature, header chunk and end chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert!(bytes.len() > 57, "too short for a PNG");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    assert_eq!(&bytes[8..16], b"\0\0\0\x0dIHDR", "first chunk is a 13-byte IHDR");
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    assert_eq!((bytes[24], bytes[25]), (8, 2), "8-bit RGB");
    assert_eq!(&bytes[bytes.len() - 12..], b"\0\0\0\0IEND\xae\x42\x60\x82", "ends with IEND");
    (be(&bytes[16..20]), be(&bytes[20..24]))
}

#[test]
fn validate_writes_every_figure_as_svg_and_png_and_the_report_shows_them() {
    let dir = whole();
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    common::assert_claims(&report, 5);
    for stem in FIGURES {
        let svg = std::fs::read_to_string(dir.join(format!("plots/{stem}.svg"))).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{stem}.svg is not an SVG document");
        let names: &[&str] = match stem {
            s if s.starts_with("fig24") => &["M_1 / G_i (static)", "M_i / G_i (updated)"],
            s if s.starts_with("fig25") || s.starts_with("fig26") => {
                &["localiser on M_1 (static)", "localiser on M_i-1 (updated)", "mean over 2 seeds"]
            }
            "fig27a_updater_time" => &["not measured"],
            _ => &["updater"],
        };
        for name in names {
            assert!(svg.contains(name), "{stem}.svg lacks {name:?}");
        }
        // Lines are drawn (a polyline per series and world range), not only the legend.
        if !stem.starts_with("fig27a") {
            assert!(svg.matches("<polyline").count() >= 2, "{stem}.svg draws no line");
        }
        let png = std::fs::read(dir.join(format!("plots/{stem}.png"))).unwrap();
        assert_eq!(png_size(&png), (1200, 750), "{stem}.png");
        assert!(report.contains(&format!("](plots/{stem}.svg)")), "report.md does not show {stem}.svg");
        assert!(report.contains(&format!("](plots/{stem}.png)")), "report.md does not link {stem}.png");
    }
    // Structure retention and change classes: in the report, the summary and every csv row.
    assert!(report.contains("## Structure retention and change classes") && report.contains("initial-error"));
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["retention"]["rows"], 4, "2 seeds × W_2, W_3");
    assert_eq!(summary["retention"]["best_mean"], 100.0, "M*_i keeps all structure");
    assert!(summary["change_classes"]["initial_errors"]["rows"].as_u64().unwrap() > 0);
    let csv = std::fs::read_to_string(dir.join("worlds.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header.iter().position(|c| *c == "retention_best").unwrap();
    for line in csv.lines().skip(1) {
        assert_eq!(line.split(',').nth(col), Some("100.000000"), "{line}");
    }
    let names: Vec<String> = files(dir).into_keys().collect();
    for f in ["runs.json", "summary.json", "worlds.csv", "edits.json", "report.md", "seed-2/maps/M_003.pgm"] {
        assert!(names.iter().any(|n| n == f), "{f} missing in {names:?}");
    }
    assert!(!names.iter().any(|n| n.contains(".tmp")), "a temporary file was left: {names:?}");
    done();
}

#[test]
fn merged_shards_equal_the_unsharded_run_file_for_file() {
    let (a, b) = shards();
    let merged = scratch().join("merged");
    let r = mapkeeper(&["merge", a.to_str().unwrap(), b.to_str().unwrap(), "--out", merged.to_str().unwrap()]);
    assert!(r.status.success(), "merge failed: {}", stderr(&r));
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(stdout.contains("seeds [1, 2]"), "{stdout}");

    // Each shard holds its own seed only, and says which shard it is.
    let runs: serde_json::Value = serde_json::from_slice(&std::fs::read(a.join("runs.json")).unwrap()).unwrap();
    assert_eq!(runs["shard"], serde_json::json!({"index": 1, "count": 2}));
    assert_eq!(runs["seeds"].as_array().unwrap().len(), 1);
    assert!(!b.join("seed-1").exists() && b.join("seed-2").exists());

    let (want, got) = (files(whole()), files(&merged));
    assert_eq!(want.keys().collect::<Vec<_>>(), got.keys().collect::<Vec<_>>(), "not the same files");
    for (name, bytes) in &want {
        assert!(got[name] == *bytes, "{name} differs between the unsharded run and the merged shards");
    }
    // Merging in the other order gives the same folder.
    let merged2 = scratch().join("merged-reversed");
    let r = mapkeeper(&["merge", b.to_str().unwrap(), a.to_str().unwrap(), "--out", merged2.to_str().unwrap()]);
    assert!(r.status.success(), "merge failed: {}", stderr(&r));
    assert!(files(&merged2) == got);
    done();
}

/// Without `--no-timing`, on one thread: the same results as the untimed run on all cores,
/// but for the wall time and the updater times.
#[test]
fn validate_twice_gives_the_same_summary_maps_and_trajectories() {
    let timed = validate("timed", &["--seeds", "2", "--jobs", "1"]);
    let untimed = whole();
    let summary = |d: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(d.join("summary.json")).unwrap()).unwrap()
    };
    let (mut t, mut u) = (summary(&timed), summary(untimed));
    assert!(t["wall_time_s"].as_f64().unwrap() > 0.0, "timed run without wall time");
    assert!(t["updater"]["median_scan_us"].as_f64().unwrap() > 0.0, "timed run without updater time");
    assert_eq!(u["wall_time_s"].as_f64(), Some(0.0));
    for v in [&mut t, &mut u] {
        let o = v.as_object_mut().unwrap();
        o.remove("wall_time_s");
        o["updater"].as_object_mut().unwrap().remove("median_scan_us");
    }
    assert_eq!(t, u, "summary.json differs beyond the timing fields");

    // worlds.csv without its median_scan_us column.
    let csv = |d: &Path| -> Vec<String> {
        let text = std::fs::read_to_string(d.join("worlds.csv")).unwrap();
        let col = text.lines().next().unwrap().split(',').position(|c| c == "median_scan_us").unwrap();
        text.lines()
            .map(|l| l.split(',').enumerate().filter(|(i, _)| *i != col).map(|(_, c)| c).collect::<Vec<_>>().join(","))
            .collect()
    };
    assert_eq!(csv(&timed), csv(untimed));

    let (ft, fu) = (files(&timed), files(untimed));
    let seed_files: Vec<&String> = fu.keys().filter(|k| k.starts_with("seed-")).collect();
    assert!(seed_files.iter().any(|k| k.ends_with("M_003.pgm")) && seed_files.iter().any(|k| k.ends_with(".tum")));
    for k in seed_files {
        assert!(ft.get(k) == fu.get(k), "{k} differs between the two runs");
    }
    assert!(ft["edits.json"] == fu["edits.json"]);
    done();
}

/// Runs `merge dirs… --out scratch()/out` and returns its error message (the run must fail).
fn merge_error(dirs: &[&Path], out: &str) -> String {
    let out = scratch().join(out);
    let mut args: Vec<&str> = vec!["merge"];
    args.extend(dirs.iter().map(|d| d.to_str().unwrap()));
    args.extend(["--out", out.to_str().unwrap()]);
    let r = mapkeeper(&args);
    assert!(!r.status.success(), "merge of {dirs:?} succeeded");
    assert!(!out.exists(), "a refused merge left an output folder");
    let staging = out.with_file_name(format!(".{}.partial", out.file_name().unwrap().to_string_lossy()));
    assert!(!staging.exists(), "a refused merge left a staging folder");
    stderr(&r)
}

/// An edit replacing every `from` by `to`.
fn edit_all(from: &'static str, to: &'static str) -> impl Fn(&str) -> String {
    move |t: &str| t.replace(from, to)
}

/// A copy of `from` named `name`, with `edit` applied to the text of each of `files`.
fn edited_copy(from: &Path, name: &str, files: &[&str], edit: &dyn Fn(&str) -> String) -> PathBuf {
    let to = scratch().join(name);
    copy_dir(from, &to);
    for f in files {
        let p = to.join(f);
        let text = std::fs::read_to_string(&p).unwrap();
        let new = edit(&text);
        assert_ne!(new, text, "the edit of {f} changed nothing");
        std::fs::write(&p, new).unwrap();
    }
    to
}

#[test]
fn merge_refuses_folders_that_do_not_belong_together() {
    let (a, b) = shards();
    let b_str = b.to_str().unwrap();
    let mention = |e: &str, dir: &Path, what: &str| {
        assert!(e.contains(dir.to_str().unwrap()) && e.contains(what), "expected {what:?} about {dir:?}, got: {e}");
    };

    // The same seed twice.
    let e = merge_error(&[a, whole()], "m-dup");
    mention(&e, whole(), "seed 1 is also in");

    // Another number of worlds (a real run: seed 3, 2 worlds).
    let two = validate("two-worlds", &["--seed", "3", "--worlds", "2", "--no-timing"]);
    let e = merge_error(&[a, &two], "m-worlds");
    mention(&e, &two, "has 2 worlds, the first folder 3");

    // Another preset (both files edited alike, so that the folder itself is consistent).
    let preset = edited_copy(
        b,
        "preset",
        &["runs.json", "summary.json"],
        &edit_all("\"preset\": \"paper\"", "\"preset\": \"authors\""),
    );
    mention(&merge_error(&[a, &preset], "m-preset"), &preset, "updater preset 'authors', the first folder 'paper'");

    // Another value of a parameter deep inside.
    let text = std::fs::read_to_string(b.join("runs.json")).unwrap();
    assert_eq!(text.matches("\"max_speed_mps\": 1.5").count(), 1);
    let param = edited_copy(
        b,
        "param",
        &["runs.json", "summary.json"],
        &edit_all("\"max_speed_mps\": 1.5", "\"max_speed_mps\": 1.25"),
    );
    mention(&merge_error(&[a, &param], "m-param"), &param, "params.runner.sim.robot.max_speed_mps differs");

    // Timed and untimed.
    let timed = edited_copy(b, "timing", &["runs.json"], &edit_all("\"timing\": false", "\"timing\": true"));
    mention(&merge_error(&[a, &timed], "m-timing"), &timed, "timed and untimed");

    // Missing files and folders.
    let no_runs = scratch().join("no-runs");
    copy_dir(b, &no_runs);
    std::fs::remove_file(no_runs.join("runs.json")).unwrap();
    mention(&merge_error(&[a, &no_runs], "m-no-runs"), &no_runs, "runs.json is missing");
    let no_seed = scratch().join("no-seed");
    copy_dir(b, &no_seed);
    std::fs::remove_dir_all(no_seed.join("seed-2")).unwrap();
    mention(&merge_error(&[a, &no_seed], "m-no-seed"), &no_seed, "seed-2/ is missing");
    let nowhere = scratch().join("does-not-exist");
    mention(&merge_error(&[a, &nowhere], "m-nowhere"), &nowhere, "no such folder");

    // Bad JSON, and a summary that does not match the record.
    let bad = edited_copy(b, "bad-json", &["runs.json"], &|t: &str| t[..t.len() / 2].to_owned());
    mention(&merge_error(&[a, &bad], "m-bad"), &bad, "runs.json: EOF while parsing");
    let wrong = edited_copy(b, "wrong-summary", &["summary.json"], &edit_all("\"rows\": 2", "\"rows\": 3"));
    mention(&merge_error(&[a, &wrong], "m-wrong"), &wrong, "summary.json does not match");

    // And the good pair still merges (the refusals left nothing behind).
    let ok = scratch().join("m-ok");
    let r = mapkeeper(&["merge", a.to_str().unwrap(), b_str, "--out", ok.to_str().unwrap()]);
    assert!(r.status.success(), "{}", stderr(&r));
    // An existing output folder is refused without --force.
    let r = mapkeeper(&["merge", a.to_str().unwrap(), b_str, "--out", ok.to_str().unwrap()]);
    assert!(!r.status.success() && stderr(&r).contains("--force"), "{}", stderr(&r));
    done();
}

#[test]
fn bad_shards_are_refused_before_any_work() {
    for (shard, seeds, want) in [
        ("0/2", "2", "expected k/N"),
        ("3/2", "2", "expected k/N"),
        ("1/0", "2", "expected k/N"),
        ("a/b", "2", "expected k/N"),
        ("2", "2", "expected k/N"),
        ("3/3", "2", "cannot make 3 non-empty shards"),
    ] {
        let out = scratch().join(format!("bad-shard-{}", shard.replace('/', "-")));
        let r = mapkeeper(&[
            "validate",
            "--preset",
            "paper",
            "--worlds",
            "3",
            "--seeds",
            seeds,
            "--shard",
            shard,
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(!r.status.success(), "--shard {shard} accepted");
        assert!(stderr(&r).contains(want), "--shard {shard}: {}", stderr(&r));
        assert!(!out.exists());
    }
    done();
}

/// A sweep over two presets: the (preset × seed) jobs sliced into three shards and merged preset
/// by preset equal the unsharded sweep file for file; the second preset's folder equals a
/// single-preset run of it. Bad preset lists are refused before any work.
#[test]
fn preset_sweeps_shard_over_preset_and_seed_jobs() {
    let common = ["--worlds", "2", "--seeds", "2", "--no-timing", "--presets", "paper,no-update"];
    let all = validate("sweep-all", &common);
    assert!(all.join("paper/summary.json").is_file() && all.join("no-update/summary.json").is_file());
    // Jobs (paper,1) (paper,2) (no-update,1) (no-update,2) in three shards: [p1] [p2] [n1 n2].
    let mut parts = Vec::new();
    for k in 1..=3 {
        let shard = format!("{k}/3");
        let mut args = common.to_vec();
        args.extend(["--shard", &shard]);
        parts.push(validate(&format!("sweep-{k}"), &args));
    }
    assert!(parts[0].join("paper").is_dir() && !parts[0].join("no-update").exists());
    assert!(parts[2].join("no-update").is_dir() && !parts[2].join("paper").exists());
    let merged = scratch().join("sweep-merged");
    for (preset, dirs) in [("paper", vec![&parts[0], &parts[1]]), ("no-update", vec![&parts[2]])] {
        let out = merged.join(preset);
        let mut args = vec!["merge".to_string()];
        args.extend(dirs.iter().map(|d| d.join(preset).to_str().unwrap().to_string()));
        args.extend(["--out".to_string(), out.to_str().unwrap().to_string()]);
        let r = mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(r.status.success(), "{}", stderr(&r));
        assert_eq!(files(&out), files(&all.join(preset)), "{preset}: merged shards differ from the sweep");
    }
    check_comparison(&all);
    // The shards merged whole: preset by preset, then the comparison: the unsharded sweep.
    let whole_merge = scratch().join("sweep-merged-whole");
    let mut args = vec!["merge".to_string()];
    args.extend(parts.iter().map(|d| d.to_str().unwrap().to_string()));
    args.extend(["--out".to_string(), whole_merge.to_str().unwrap().to_string()]);
    let r = mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(r.status.success(), "{}", stderr(&r));
    assert_eq!(files(&whole_merge), files(&all), "the merged sweep differs from the unsharded one");
    // Its top-level files are refused without --force, and a sweep over other presets is refused.
    let r = mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(!r.status.success() && stderr(&r).contains("--force"), "{}", stderr(&r));
    let r = mapkeeper(&["validate", "--worlds", "2", "--presets", "paper,no-update", "--out", all.to_str().unwrap()]);
    assert!(!r.status.success() && stderr(&r).contains("exists and is not empty"), "{}", stderr(&r));
    let single = validate("sweep-single", &["--worlds", "2", "--seeds", "2", "--no-timing", "--preset", "no-update"]);
    assert_eq!(files(&single), files(&all.join("no-update")));
    for (list, want) in [("paper,paper", "twice"), ("paper,bogus", "bogus"), ("paper,", "preset names")] {
        let out = scratch().join(format!("bad-presets-{}", list.replace(',', "_")));
        let r = mapkeeper(&["validate", "--worlds", "2", "--presets", list, "--out", out.to_str().unwrap()]);
        assert!(!r.status.success(), "--presets {list} accepted");
        assert!(stderr(&r).contains(want), "--presets {list}: {}", stderr(&r));
        assert!(!out.exists());
    }
    done();
}

/// `--updater-params` overrides fields of the preset, is recorded in summary.json, and a bad
/// file is refused before any work with an error naming the file and the field.
#[test]
fn updater_params_file_overrides_the_preset() {
    let dir = scratch();
    let good = dir.join("clearance.toml");
    std::fs::write(&good, "[removal]\nhit_clearance_m = 0.125\n").unwrap();
    let out = validate(
        "updater-params",
        &["--preset", "mapkeeper", "--worlds", "2", "--updater-params", good.to_str().unwrap()],
    );
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("\"hit_clearance_m\": 0.125"), "{summary}");
    assert!(summary.contains("\"free_pass_votes\": true"), "the rest is mapkeeper's");
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "change_threshold = 5\n").unwrap();
    let out = dir.join("updater-params-bad");
    let r = mapkeeper(&[
        "validate",
        "--preset",
        "mapkeeper",
        "--updater-params",
        bad.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!r.status.success());
    let e = stderr(&r);
    assert!(e.contains("bad.toml") && e.contains("change_threshold"), "{e}");
    assert!(!out.exists());
    done();
}

/// The comparison of a sweep over paper and no-update with seeds 1 and 2: one row per preset
/// and one per preset and seed, each with the figures of the preset's own summary.
fn check_comparison(all: &Path) {
    let json = |p: &Path| -> serde_json::Value { serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap() };
    let c = json(&all.join("summary.json"));
    assert_eq!(c["format"], "mapkeeper-validation-comparison");
    assert_eq!(c["presets"], serde_json::json!(["paper", "no-update"]));
    let rows = c["rows"].as_array().unwrap();
    let keys: Vec<(String, serde_json::Value)> =
        rows.iter().map(|r| (r["preset"].as_str().unwrap().to_owned(), r["seed"].clone())).collect();
    let want: Vec<(String, serde_json::Value)> = ["paper", "no-update"]
        .iter()
        .flat_map(|p| [serde_json::Value::Null, 1.into(), 2.into()].map(|s| (p.to_string(), s)))
        .collect();
    assert_eq!(keys, want);
    for r in rows.iter().filter(|r| r["seed"].is_null()) {
        let s = json(&all.join(r["preset"].as_str().unwrap()).join("summary.json"));
        assert_eq!(r["map_quality"], s["map_quality"]);
        assert_eq!(r["localisation_error"]["on_m1_m"], s["localisation"]["static_map"]["mean_error_m"]);
        assert_eq!(r["localisation_error"]["on_prev_m"], s["localisation"]["updated_map"]["mean_error_m"]);
        for v in ["update", "suspend", "lost"] {
            assert_eq!(r["verdicts"][v], s["updater"][v], "{v}");
        }
        assert_eq!(r["lost_handling"], s["lost_handling"]);
        assert_eq!(r["retention"], s["retention"]);
        assert_eq!(r["change_classes"], s["change_classes"]);
        assert_eq!(r["worlds"], 2, "2 seeds × W_2");
    }
    // no-update never updates its map: M_i is M_1 in every world, which keeps all of S_i.
    let nu = &rows[3]["map_quality"]["cc"];
    assert_eq!(nu["static_mean"], nu["updated_mean"]);
    assert_eq!(rows[3]["retention"]["updated_mean"], 100.0);
    assert_eq!(rows[3]["retention"]["target_met"], true);
    let report = std::fs::read_to_string(all.join("report.md")).unwrap();
    // Six rows in the table of map quality and localisation, six in that of retention.
    assert_eq!(report.lines().filter(|l| l.starts_with("| paper |") || l.starts_with("| no-update |")).count(), 12);
    assert!(report.contains("## Structure retention and change classes"), "{report}");
    assert!(report.contains("Lost episodes") && report.contains("err on M_1"), "{report}");
    check_intervals(all);
}

/// `--ground-truth exact` and `observed` score the same maps against both variants: each run's
/// `map_quality` is its own variant, `by_ground_truth` is the same in both, and the worlds.csv
/// columns of the other variant swap. The observed G_i knows fewer cells than the exact one (not
/// the backs of walls and items) and gives every cell it knows the exact state.
#[test]
fn ground_truth_variants_are_both_reported_and_swap() {
    let exact = validate("gt-exact", &["--worlds", "2", "--no-timing"]);
    let observed = validate("gt-observed", &["--worlds", "2", "--no-timing", "--ground-truth", "observed"]);
    let json = |p: &Path| -> serde_json::Value { serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap() };
    let (e, o) = (json(&exact.join("summary.json")), json(&observed.join("summary.json")));
    assert_eq!((e["ground_truth"].as_str(), o["ground_truth"].as_str()), (Some("exact"), Some("observed")));
    assert_eq!(e["by_ground_truth"], o["by_ground_truth"]);
    assert_eq!(e["map_quality"], e["by_ground_truth"]["exact"]["map_quality"]);
    assert_eq!(o["map_quality"], o["by_ground_truth"]["observed"]["map_quality"]);
    assert_ne!(e["map_quality"], o["map_quality"]);
    let mut fractions = 0;
    for gt in ["exact", "observed"] {
        for m in ["cc", "ms", "opdf"] {
            let b = &e["by_ground_truth"][gt]["best_achievable"][m];
            let q = &e["by_ground_truth"][gt]["map_quality"][m];
            let (best, m1, mi) = (
                b["best_mean"].as_f64().unwrap(),
                q["static_mean"].as_f64().unwrap(),
                q["updated_mean"].as_f64().unwrap(),
            );
            assert!(best.is_finite() && (0.0..=100.0).contains(&best), "{gt} {m}: {b}");
            if let Some(a) = b["achieved_fraction"].as_f64() {
                assert!((a - (mi - m1) / (best - m1)).abs() < 1e-9, "{gt} {m}: {b} {q}");
                fractions += 1;
            } else {
                assert!(best <= m1 + 1e-9, "{gt} {m}: null although M* beats M_1: {b} {q}");
            }
            let fresh = e["by_ground_truth"][gt]["fresh_map"][m].as_f64().unwrap();
            assert!(fresh > 0.0 && fresh <= 100.0, "{gt} {m}: fresh map {fresh}");
        }
    }
    assert!(fractions > 0, "the best achievable map beat M_1 on no metric");
    let csv = |d: &Path| -> Vec<Vec<String>> {
        let text = std::fs::read_to_string(d.join("worlds.csv")).unwrap();
        text.lines().map(|l| l.split(',').map(str::to_string).collect()).collect()
    };
    let (ce, co) = (csv(&exact), csv(&observed));
    let col = |name: &str| ce[0].iter().position(|h| h == name).unwrap();
    for (mine, other) in [("cc_updated", "cc_updated_other_gt"), ("ms_best", "ms_best_other_gt")] {
        assert_eq!(ce[1][col(mine)], co[1][col(other)], "{mine}");
        assert_eq!(ce[1][col(other)], co[1][col(mine)], "{other}");
    }
    let report = std::fs::read_to_string(observed.join("report.md")).unwrap();
    assert!(report.contains("use the `observed` ground truth") && report.contains("| exact | CC |"), "{report}");
    // The saved ground truth of W_2: the observed raster keeps the exact states where known.
    let pgm = |d: &Path| std::fs::read(d.join("seed-1/maps/G_002.pgm")).unwrap();
    let (ge, go) = (pgm(&exact), pgm(&observed));
    assert_eq!(ge.len(), go.len());
    let unknown = 205u8;
    let header = ge.iter().rposition(|&b| b == b'\n').unwrap() + 1;
    let (pe, po) = (&ge[header..], &go[header..]);
    let count = |p: &[u8], v: u8| p.iter().filter(|&&x| x == v).count();
    assert!(count(po, unknown) > count(pe, unknown), "the observed raster knows fewer cells");
    assert!(count(po, 0) < count(pe, 0), "the backs of walls and items are not observed");
    assert!(pe.iter().zip(po).all(|(a, b)| *b == unknown || a == b), "observed cells keep the exact state");
    done();
}

/// The paired intervals of summary.json, recomputed here from the presets' runs.json: per seed
/// the mean over its worlds, then mean ± t(0.975, n−1)·s/√n over the seeds (n = 2: t = 12.7062).
fn check_intervals(all: &Path) {
    let json = |p: &Path| -> serde_json::Value { serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap() };
    let per_seed = |preset: &str, f: &dyn Fn(&serde_json::Value) -> f64| -> Vec<f64> {
        let runs = json(&all.join(preset).join("runs.json"));
        runs["seeds"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| {
                let rows = s["rows"].as_array().unwrap();
                rows.iter().map(f).sum::<f64>() / rows.len() as f64
            })
            .collect()
    };
    let interval = |d: &[f64]| -> (f64, [f64; 2]) {
        assert_eq!(d.len(), 2);
        let m = (d[0] + d[1]) / 2.0;
        let sd = (((d[0] - m).powi(2) + (d[1] - m).powi(2)) / 1.0).sqrt();
        let half = 12.7062 * sd / 2f64.sqrt();
        (m, [m - half, m + half])
    };
    let close = |got: &serde_json::Value, want: f64, what: &str| {
        let g = got.as_f64().unwrap_or_else(|| panic!("{what}: {got}"));
        assert!((g - want).abs() < 1e-9 * (1.0 + want.abs()), "{what}: {g} vs {want}");
    };
    let ci = |got: &serde_json::Value, want: [f64; 2], what: &str| {
        close(&got[0], want[0], what);
        close(&got[1], want[1], what);
    };
    let metric = |m: &'static str, updated: bool| {
        move |w: &serde_json::Value| w[if updated { "updated_map" } else { "static_map" }][m].as_f64().unwrap()
    };
    for preset in ["paper", "no-update"] {
        let s = json(&all.join(preset).join("summary.json"));
        for m in ["cc", "ms", "opdf"] {
            let (u, st) = (per_seed(preset, &metric(m, true)), per_seed(preset, &metric(m, false)));
            let (mean, bounds) = interval(&[u[0] - st[0], u[1] - st[1]]);
            close(&s["map_quality"][m]["diff_mean"], mean, &format!("{preset} {m} diff_mean"));
            ci(&s["map_quality"][m]["diff_ci95"], bounds, &format!("{preset} {m} diff_ci95"));
        }
        let err = |key: &'static str| move |w: &serde_json::Value| w[key]["mean_error_m"].as_f64().unwrap();
        let (u, st) = (per_seed(preset, &err("loc_updated")), per_seed(preset, &err("loc_static")));
        let (mean, bounds) = interval(&[u[0] - st[0], u[1] - st[1]]);
        close(&s["localisation"]["error_diff_mean_m"], mean, "error_diff_mean_m");
        ci(&s["localisation"]["error_diff_ci95_m"], bounds, "error_diff_ci95_m");
        let report = std::fs::read_to_string(all.join(preset).join("report.md")).unwrap();
        assert!(report.contains("(95 % CI over 2 seeds)"), "the report states the seed count");
        assert_eq!(s["interval_units"], "seeds");
    }
    // One pair: no-update − paper, on the updated maps and the chain's error.
    let c = json(&all.join("summary.json"));
    let pairs = c["preset_diffs"].as_array().unwrap();
    assert_eq!(pairs.len(), 1);
    let d = &pairs[0];
    assert_eq!((d["a"].as_str(), d["b"].as_str()), (Some("no-update"), Some("paper")));
    assert_eq!(d["seeds"], serde_json::json!([1, 2]));
    for m in ["cc", "ms", "opdf"] {
        let (a, b) = (per_seed("no-update", &metric(m, true)), per_seed("paper", &metric(m, true)));
        let (mean, bounds) = interval(&[a[0] - b[0], a[1] - b[1]]);
        close(&d[m]["mean"], mean, m);
        ci(&d[m]["ci95"], bounds, m);
    }
}

#[test]
fn update_every_k_updates_only_every_kth_world_and_reports_the_check_under_heavy_change() {
    let dir = common::scratch("validate", "update-every");
    let out = dir.join("v");
    let args = common::validate_args(&[
        "validate",
        "--worlds",
        "5",
        "--route-length",
        "10",
        "--update-every",
        "2",
        "--route-clearance",
        "0.5",
        "--no-timing",
        "--out",
        common::s(&out),
    ]);
    let o = common::mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(v["params"]["update_every"], 2);
    assert_eq!(v["params"]["generator"]["route_clearance_m"], 0.5);
    let h = &v["heavy_change"];
    assert_eq!((h["update_every"].as_u64(), h["update_worlds"].as_u64()), (Some(2), Some(2)), "{h}");
    // W_2 and W_4 are updated; W_3 and W_5 are driven with the updater off (nothing processed, no change).
    let csv = std::fs::read_to_string(out.join("worlds.csv")).unwrap();
    let head: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| head.iter().position(|c| *c == name).unwrap();
    let mut worlds = Vec::new();
    for line in csv.lines().skip(1) {
        let r: Vec<&str> = line.split(',').collect();
        let world: usize = r[col("world")].parse().unwrap();
        let processed: u64 = r[col("processed_scans")].parse().unwrap();
        let changed: u64 = r[col("cells_changed")].parse().unwrap();
        if world.is_multiple_of(2) {
            assert!(processed > 0, "W_{world} should be updated");
        } else {
            assert_eq!((processed, changed), (0, 0), "W_{world} should not be updated");
        }
        worlds.push(world);
    }
    // One row per driven world, W_2..W_5: two updated, two not.
    assert_eq!(worlds, [2, 3, 4, 5], "rows of worlds.csv");
    assert!(std::fs::read_to_string(out.join("report.md")).unwrap().contains("Heavy change"));
    // A k of 0 is refused, naming the flag.
    let o = common::mapkeeper(&["validate", "--update-every", "0", "--out", common::s(&dir.join("x"))]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--update-every"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn fresh_map_every_k_changes_the_fresh_map_only_and_the_report_says_its_rate() {
    let dir = common::scratch("validate", "fresh-map-every");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut a = vec!["validate", "--preset", "mapkeeper", "--worlds", "3", "--route-length", "12", "--no-timing"];
        a.extend_from_slice(extra);
        a.extend(["--out", common::s(&out)]);
        let args = common::validate_args(&a);
        let o = common::mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
        let csv = std::fs::read_to_string(out.join("worlds.csv")).unwrap();
        let report = std::fs::read_to_string(out.join("report.md")).unwrap();
        (v, csv, report)
    };
    let (v2, csv2, report2) = run("default", &[]);
    let (v6, csv6, report6) = run("six", &["--fresh-map-every", "6"]);
    assert_eq!(v2["params"]["runner"]["fresh_map"]["scan_stride"], 2);
    assert_eq!(v6["params"]["runner"]["fresh_map"]["scan_stride"], 6);
    assert!(report2.contains("fed the scans of every 2nd processed step"), "{report2}");
    assert!(report6.contains("fed the scans of every 6th processed step"), "{report6}");
    assert!(report6.contains("M_1 took every 2nd step of its exploration run"), "{report6}");
    assert!(report6.contains("poses every 0.5 m along it, cast once per world"), "{report6}");
    assert!(report6.contains("Both localisers (`mapkeeper`) are given every frame of the drive"), "{report6}");
    // The same updated maps and localisation; only the fresh map's columns differ.
    let table =
        |csv: &str| -> Vec<Vec<String>> { csv.lines().map(|l| l.split(',').map(String::from).collect()).collect() };
    let (a, b) = (table(&csv2), table(&csv6));
    assert_eq!(a[0], b[0]);
    let mut fresh_differs = false;
    for (ra, rb) in a.iter().zip(&b).skip(1) {
        for ((name, x), y) in a[0].iter().zip(ra).zip(rb) {
            if name.contains("fresh") {
                fresh_differs |= x != y;
            } else {
                assert_eq!(x, y, "{name}");
            }
        }
    }
    assert!(fresh_differs, "a sixth of the scans should give another fresh map");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn harder_worlds_vary_route_and_start_per_world_and_people_stop() {
    let dir = common::scratch("validate", "harder");
    let out = dir.join("v");
    let args = common::validate_args(&[
        "validate",
        "--worlds",
        "4",
        "--route-variants",
        "--people-pause-s",
        "10",
        "--no-timing",
        "--out",
        common::s(&out),
    ]);
    let o = common::mapkeeper(&args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(v["params"]["generator"]["route_variants"], true);
    assert_eq!(v["params"]["generator"]["people_pause_s"], 10.0);
    assert_eq!(v["routes_completed"].as_u64(), v["rows"].as_u64(), "every variant is driven to its end: {v}");
    // The same worlds written by `generate`: each varied world's route is its own file.
    let set = dir.join("set");
    let o = common::mapkeeper(&[
        "generate",
        "--worlds",
        "6",
        "--seed",
        "3",
        "--route-variants",
        "--people-pause-s",
        "10",
        "--out",
        common::s(&set),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value = serde_json::from_slice(&std::fs::read(set.join("manifest.json")).unwrap()).unwrap();
    let routes: Vec<&str> = m["files"].as_array().unwrap().iter().filter_map(|f| f["route"].as_str()).collect();
    assert!(!routes.is_empty() && routes.iter().all(|r| set.join(r).is_file()), "{m}");
    let w = std::fs::read_to_string(set.join("worlds/W_002.toml")).unwrap();
    assert!(w.contains("max_pause_s = 10.0"), "people stop in W_2");
    let w1 = std::fs::read_to_string(set.join("worlds/W_001.toml")).unwrap();
    assert!(!w1.contains("max_pause_s = 10.0"), "W_1 keeps the paper's setting");
}
