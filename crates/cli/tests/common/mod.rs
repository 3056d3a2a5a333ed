//! Helpers shared by the CLI's end-to-end tests: a scratch folder, the binary, paths as text.
#![allow(dead_code, clippy::unwrap_used)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Asserts that a report ends with the paper's claims, each with a computed verdict, and that
/// at least `n` claims are there.
pub fn assert_claims(report: &str, n: usize) {
    let section = report
        .split("## The paper's claims beside this run")
        .nth(1)
        .unwrap_or_else(|| panic!("no claims section in {report}"));
    let verdicts = ["**reproduced**", "**not reproduced**", "**differs**", "**inconclusive**"];
    let rows = section.lines().filter(|l| l.starts_with("| §") || l.starts_with("| Table")).collect::<Vec<_>>();
    assert!(rows.len() >= n, "{} claims, expected at least {n}: {section}", rows.len());
    for r in rows {
        assert!(verdicts.iter().any(|v| r.contains(v)), "a claim without a verdict: {r}");
    }
}

/// A fresh folder `mapkeeper-<group>-<name>-<pid>` in the temporary folder.
pub fn scratch(group: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-{group}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the `mapkeeper` binary built for these tests.
pub fn mapkeeper(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_mapkeeper")).args(args).output().unwrap()
}

/// A path as `&str` (test paths are UTF-8).
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir`, by path relative to it.
pub fn files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(base: &Path, dir: &Path, out: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(base, &p, out);
            } else {
                let rel = p.strip_prefix(base).unwrap().to_string_lossy().into_owned();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// A `recover --params` file that shortens every experiment to seconds (for end-to-end tests).
pub const SHORT_RECOVER: &str = r#"
exploration_route = { format = "mapkeeper-route", version = 1, waypoints = [[-3.65, -2.3], [-3.65, 7.3]] }
[demo]
duration_s = 4.0
[table1]
runs = 1
route_length_m = 4.0
[lost]
runs = 1
route_length_m = 4.0
[kidnap]
stale_max_world = 2
kidnap_min_s = 2.0
kidnap_max_s = 2.5
recovery_window_s = 4.0
"#;

/// `validate` arguments with the settings most tests run under filled in where `args` does not
/// give them: one preset (`paper`), the `mapkeeper` localiser, seed 1, one seed. (The default
/// run, a sweep of paper and mapkeeper with amcl over seeds 11-13, is tested on its own in
/// localiser_cli.rs.)
pub fn validate_args(args: &[&str]) -> Vec<String> {
    let has = |flag: &str| args.contains(&flag);
    let mut v: Vec<String> = args.iter().map(ToString::to_string).collect();
    if !has("--preset") && !has("--presets") {
        v.extend(["--preset".into(), "paper".into()]);
    }
    for (flag, value) in [("--localiser", "mapkeeper"), ("--seed", "1"), ("--seeds", "1")] {
        if !has(flag) {
            v.extend([flag.into(), value.into()]);
        }
    }
    v
}

/// The subcommands a `--help` lists under "Commands:" (without `help`); none without that section.
pub fn help_commands(help: &str) -> Vec<String> {
    let Some(section) = help.split("Commands:\n").nth(1) else { return Vec::new() };
    section
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .filter(|l| l.starts_with("  ") && !l.starts_with("    "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(str::to_string)
        .collect()
}

/// Runs `mapkeeper` with `args`; asserts it succeeds; returns what it printed on stdout.
pub fn ok(args: &[&str]) -> String {
    let o = mapkeeper(args);
    assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A 30 s drive of two lidars as a bag, and a stale map of its world: the true map with a
/// phantom box and a missing stretch of structure near the start of the route.
pub fn node_drive(dir: &Path) -> (PathBuf, PathBuf) {
    let sim = dir.join("sim");
    let bag = dir.join("drive.mcap");
    ok(&["simulate", "--seconds", "30", "--seed", "6", "--out", s(&sim), "--mcap", s(&bag)]);
    let mut map = mapkeeper_grid::map_io::load_map(&sim.join("ground_truth.yaml")).unwrap();
    let tum = std::fs::read_to_string(sim.join("truth.tum")).unwrap();
    let first: Vec<f64> =
        tum.lines().find(|l| !l.starts_with('#')).unwrap().split_whitespace().map(|v| v.parse().unwrap()).collect();
    let g = *map.geometry();
    let at = |dx: f64, dy: f64| g.world_to_cell(mapkeeper_grid::Point2::new(first[1] + dx, first[2] + dy)).unwrap();
    let c0 = at(0.0, 0.0);
    let (mut phantom, mut removed) = (0, 0);
    for iy in c0.iy - 60..c0.iy + 60 {
        for ix in c0.ix - 60..c0.ix + 60 {
            let c = mapkeeper_grid::CellCoord { ix, iy };
            let d = (((ix - c0.ix).pow(2) + (iy - c0.iy).pow(2)) as f64).sqrt();
            match map.get(c) {
                Some(mapkeeper_grid::CellState::Occupied) if (ix + iy) % 3 == 0 => {
                    map.set(c, mapkeeper_grid::CellState::Free);
                    removed += 1;
                }
                Some(mapkeeper_grid::CellState::Free) if (25.0..33.0).contains(&d) && (ix - c0.ix).abs() < 6 => {
                    map.set(c, mapkeeper_grid::CellState::Occupied);
                    phantom += 1;
                }
                _ => {}
            }
        }
    }
    assert!(phantom > 10 && removed > 10, "phantom {phantom}, removed {removed}");
    let stale = dir.join("stale.yaml");
    mapkeeper_grid::map_io::save_map(&map, &stale).unwrap();
    (bag, stale)
}

/// `mapkeeper update` of a node drive's bag (`node_drive`) on `map`, into `out`, the poses given by
/// `poses` (`--true-poses`, or `--localise --localiser NAME`); the updated map and what it printed.
pub fn node_offline_update(
    bag: &Path,
    map: &Path,
    out: &Path,
    poses: &[&str],
) -> (mapkeeper_grid::OccupancyGrid, String) {
    let mut args = vec!["update", "--log", s(bag), "--truth-topic", "/truth", "--map", s(map), "--out", s(out)];
    args.extend_from_slice(poses);
    let printed = ok(&args);
    (mapkeeper_grid::map_io::load_map(&out.join("map.yaml")).unwrap(), printed)
}
