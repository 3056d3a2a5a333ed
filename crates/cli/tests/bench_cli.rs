//! `mapkeeper bench` end to end on a short scene: the table has a row for the simulator, every
//! localiser preset, every updater preset and grid traversal (and the closed loop unless
//! `--no-loop`), each with consistent, positive figures. No figure is compared with a time:
//! speed is measured by the command, never asserted in tests.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};

fn rows(path: &std::path::Path) -> Vec<serde_json::Value> {
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    v.as_array().unwrap().clone()
}

#[test]
fn bench_table_has_every_component_with_consistent_figures() {
    let dir = scratch("bench-cli", "table");
    let json = dir.join("bench.json");
    let out = mapkeeper(&["bench", "--repeats", "2", "--steps", "30", "--no-loop", "--json", s(&json)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8(out.stdout).unwrap();
    let rows = rows(&json);
    let names: Vec<&str> = rows.iter().map(|r| r["what"].as_str().unwrap()).collect();
    // Simulator, localisers, updaters, the fresh map, traversal, one pose-recovery attempt
    // (global search) and a second Lost driving on.
    let expected = 1 + mapkeeper_localiser::LOCALISER_PRESETS.len() + mapkeeper_updater::PRESET_NAMES.len() + 4;
    assert_eq!(rows.len(), expected, "{names:?}");
    assert!(names.iter().any(|n| n.starts_with("pose recovery when Lost")), "{names:?}");
    assert!(names.iter().any(|n| n.starts_with("pose recovery while Lost")), "{names:?}");
    // The fresh map's row names the validation's rate, from its parameters.
    let stride = mapkeeper_scenario::ValidationParams::new(2, "paper").unwrap().runner.fresh_map.unwrap().scan_stride;
    let fresh = format!(
        "fresh map: one dual-S300 step integrated (log-odds mapper; the validation integrates one step in {stride})"
    );
    assert!(names.contains(&fresh.as_str()), "{names:?}");
    for preset in mapkeeper_updater::PRESET_NAMES.iter().chain(&mapkeeper_localiser::LOCALISER_PRESETS) {
        assert!(names.iter().any(|n| n.contains(&format!("`{preset}`"))), "no row for {preset}: {names:?}");
    }
    for r in &rows {
        let f = |k: &str| r[k].as_f64().unwrap();
        let what = r["what"].as_str().unwrap();
        assert!(f("min") > 0.0 && f("min") <= f("median") && f("median") <= f("max"), "{what}: {r}");
        assert!(f("ratio_to_reference") > 0.0 && f("throughput") > 0.0, "{what}: {r}");
        assert!(stdout.contains(what), "the printed table lacks {what}:\n{stdout}");
    }
    assert!(!names.iter().any(|n| n.contains("closed loop")), "--no-loop ran the loop: {names:?}");
    filter_work_is_consistent(&stdout);
}

/// The table of what each localiser did: one row per preset, updates at most the frames, the
/// particle counts within the preset's bounds, beams weighted on every update, both CPU figures
/// per update and the cost per weighted particle and beam positive.
fn filter_work_is_consistent(stdout: &str) {
    let (_, work) = stdout.split_once("What each localiser did on the scene").expect("no filter-work table");
    for preset in mapkeeper_localiser::LOCALISER_PRESETS {
        let row = work
            .lines()
            .find(|l| l.starts_with(&format!("| `{preset}` |")))
            .unwrap_or_else(|| panic!("no row for {preset}:\n{work}"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let num = |i: usize| cells[i].parse::<usize>().unwrap_or_else(|_| panic!("{preset}: cell {i} of {row}"));
        let (frames, updates) = (num(2), num(3));
        let (median, max) = cells[4].split_once(" / ").unwrap();
        let (median, max): (usize, usize) = (median.parse().unwrap(), max.parse().unwrap());
        let p = mapkeeper_localiser::FilterParams::preset(preset).unwrap();
        assert!(frames == 30 && updates >= 1 && updates <= frames, "{row}");
        assert!(p.min_particles <= median && median <= max && max <= p.max_particles, "{row}");
        assert!(num(5) > 0, "{row}");
        let ms = |s: &str| s.strip_suffix(" ms").and_then(|v| v.parse::<f64>().ok()).unwrap_or_else(|| panic!("{row}"));
        let (all, median_update) = cells[6].split_once(" / ").unwrap_or_else(|| panic!("{row}"));
        let (all, median_update) = (ms(all), ms(median_update));
        assert!(all > 0.0 && median_update > 0.0, "{row}");
        let ns = cells[7].strip_suffix(" ns").and_then(|v| v.parse::<f64>().ok()).unwrap_or_else(|| panic!("{row}"));
        assert!(ns > 0.0 && ns.is_finite(), "{row}");
    }
}

#[test]
fn bench_json_is_not_overwritten_without_force() {
    let dir = scratch("bench-cli", "json-exists");
    let json = dir.join("bench.json");
    std::fs::write(&json, "kept").unwrap();
    let out = mapkeeper(&["bench", "--repeats", "1", "--steps", "10", "--no-loop", "--json", s(&json)]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--json") && err.contains("--force") && !err.contains("recording the scene"), "{err}");
    assert_eq!(std::fs::read_to_string(&json).unwrap(), "kept");
    let out = mapkeeper(&["bench", "--repeats", "1", "--steps", "10", "--no-loop", "--json", s(&json), "--force"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(rows(&json).len() > 5);
}

#[test]
fn bench_refuses_a_scene_longer_than_the_route() {
    let out = mapkeeper(&["bench", "--repeats", "1", "--steps", "100000", "--no-loop"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--steps"), "{err}");
}
