//! `mapkeeper node` (issue 55) on the wire, against an independent implementation: Eclipse
//! Cyclone DDS (the `cyclonedds` Python package, its own C library; no ROS installation) plays
//! a simulated drive's bag at real rate as a robot would (`crates/node/tests/cyclone/drive.py`)
//! and records what the node publishes. Every DDS participant is held to 127.0.0.1.
//!
//! The peer's Python is `MAPKEEPER_CYCLONE_PYTHON`, else `target/cyclone-venv/bin/python`
//! (`.ci/run` installs it from `crates/node/tests/cyclone/requirements.txt`). Without it the
//! tests print a note and pass, except under `CI=true`, where they fail.
#![allow(clippy::unwrap_used)]

mod common;

use common::{node_drive, node_offline_update, s, scratch};
use mapkeeper_grid::CellState;
use mapkeeper_grid::map_io::load_map;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;

/// One node and one peer at a time: they run at real rate on a two-core machine.
static SERIAL: Mutex<()> = Mutex::new(());

fn peer_python() -> Option<PathBuf> {
    let p = std::env::var_os("MAPKEEPER_CYCLONE_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/cyclone-venv/bin/python"));
    if p.is_file() {
        return Some(p);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI=true but the Cyclone DDS peer is not installed at {} (.ci/run installs it)",
        p.display()
    );
    println!("note: the Cyclone DDS peer is not installed ({}): skipped; `bash .ci/run` installs it", p.display());
    None
}

fn driver() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../node/tests/cyclone/drive.py")
}

/// A DDS domain of this test process and scenario, so that parallel runs on one machine do not
/// meet.
fn domain(k: u32) -> u32 {
    10 + (std::process::id() % 40) * 5 + k
}

fn params(dir: &Path, stale: &Path, domain: u32, extra: &str) -> PathBuf {
    let text = format!(
        "mapkeeper:\n  ros__parameters:\n    map: {}\n    scan_topics: [/lidar_0/scan, /lidar_1/scan]\n    save_dir: {}\n    \
         map_publish_period_s: 1.0\n    domain_id: {domain}\n    interfaces: [127.0.0.1]\n    resume: false\n{extra}",
        s(stale),
        s(&dir.join("saved"))
    );
    let p = dir.join("node.yaml");
    std::fs::write(&p, text).unwrap();
    p
}

fn start_node(dir: &Path, params: &Path) -> Child {
    let log = std::fs::File::create(dir.join("node.log")).unwrap();
    Command::new(env!("CARGO_BIN_EXE_mapkeeper"))
        .args(["node", "--params", s(params), "--seconds", "300", "--figures", s(&dir.join("figures.json"))])
        .stdout(Stdio::null())
        .stderr(log)
        .spawn()
        .unwrap()
}

/// SIGINT, as Ctrl-C or `ros2 launch` stopping it; returns its log.
fn stop_node(dir: &Path, mut node: Child) -> String {
    assert!(
        node.try_wait().unwrap().is_none(),
        "the node stopped by itself: {}",
        std::fs::read_to_string(dir.join("node.log")).unwrap()
    );
    let st = Command::new("kill").args(["-INT", &node.id().to_string()]).status().unwrap();
    assert!(st.success());
    let status = node.wait().unwrap();
    let log = std::fs::read_to_string(dir.join("node.log")).unwrap();
    assert!(status.success(), "the node failed: {log}");
    log
}

/// Plays the bag; returns the peer's exit status, its report and what it printed.
fn play(python: &Path, dir: &Path, bag: &Path, domain: u32, args: &[&str]) -> (bool, Value, String) {
    let out = dir.join("peer.json");
    let o = Command::new(python)
        .arg(driver())
        .args(["--bag", s(bag), "--out", s(&out), "--domain", &domain.to_string()])
        .args(args)
        .output()
        .unwrap();
    let printed = String::from_utf8_lossy(&o.stderr).into_owned();
    let v = std::fs::read(&out).ok().and_then(|b| serde_json::from_slice(&b).ok()).unwrap_or(Value::Null);
    (o.status.success(), v, printed)
}

fn cells(map: &mapkeeper_grid::OccupancyGrid) -> Vec<i64> {
    map.cells()
        .iter()
        .map(|c| match c {
            CellState::Free => 0,
            CellState::Occupied => 100,
            CellState::Unknown => -1,
        })
        .collect()
}

fn grid(v: &Value) -> Vec<i64> {
    v["data"].as_array().unwrap().iter().map(|x| x.as_i64().unwrap()).collect()
}

fn differing(a: &[i64], b: &[i64]) -> usize {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).filter(|(x, y)| x != y).count()
}

#[test]
fn over_cyclone_dds_at_real_rate_the_node_publishes_the_offline_updates_map() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(python) = peer_python() else { return };
    let dir = scratch("node-cyclone", "equal");
    let (bag, stale) = node_drive(&dir);
    let (offline, _) = node_offline_update(&bag, &stale, &dir.join("off"), &["--true-poses"]);
    let want = cells(&offline);
    let d = domain(0);
    let node = start_node(
        &dir,
        &params(
            &dir,
            &stale,
            d,
            // With sim time: the peer sends /clock before the messages, as a simulator or a bag
            // player does (the node stamps everything with sensor time: the map is the same).
            "    pose_source: pose_topic\n    pose_topic: /amcl_pose\n    service_layout: cyclone\n    use_sim_time: true\n",
        ),
    );
    let (passed, v, printed) =
        play(&python, &dir, &bag, d, &["--rate", "1", "--clock", "--call-save-map", "mapkeeper"]);
    let log = stop_node(&dir, node);
    assert!(passed, "the peer failed: {printed}\nnode: {log}");
    println!("peer: {printed}\nnode: {log}");
    let g = &offline.geometry();
    for (name, m) in [("final_map", &v["final_map"]), ("composed_map", &v["composed_map"])] {
        assert_eq!(
            (m["width"].as_u64(), m["height"].as_u64()),
            (Some(g.width() as u64), Some(g.height() as u64)),
            "{name}"
        );
        assert!((m["resolution"].as_f64().unwrap() - g.resolution_m()).abs() < 1e-6, "{name}");
        assert_eq!(differing(&grid(m), &want), 0, "{name} differs from `mapkeeper update`'s map");
    }
    assert!(v["updates_received"].as_u64().unwrap() > 5, "{v}");
    // The save_map service, called the way rmw_cyclonedds lays a request out.
    assert_eq!(v["save_map"]["success"], true, "{}", v["save_map"]);
    assert!(v["save_map"]["message"].as_str().unwrap().ends_with("saved/map.yaml"), "{}", v["save_map"]);
    assert!(log.contains("save_map: "), "{log}");
    assert!(differing(&cells(&load_map(&stale).unwrap()), &want) > 50, "the drive must change the map");
    assert_eq!(differing(&cells(&load_map(&dir.join("saved/map.yaml")).unwrap()), &want), 0, "the saved map");
    let fig: Value = serde_json::from_slice(&std::fs::read(dir.join("figures.json")).unwrap()).unwrap();
    assert_eq!(fig["steps"], 375, "every step processed, none dropped: {fig}");
    assert!(fig["latency_p99_ms"].as_f64().unwrap() > 0.0, "{fig}");
    println!("figures: {fig}");
}

#[test]
fn bad_and_late_input_and_a_vanishing_peer_leave_the_node_running_and_its_map_whole() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(python) = peer_python() else { return };
    let dir = scratch("node-cyclone", "faults");
    let (bag, stale) = node_drive(&dir);
    let d = domain(1);
    let node = start_node(&dir, &params(&dir, &stale, d, "    pose_source: pose_topic\n    pose_topic: /amcl_pose\n"));
    let faults = ["drop:/odom:7", "reorder:/lidar_0/scan:20", "wrong-size:150", "stale-scan:300", "stop-at:24"];
    let mut args = vec!["--rate", "3"];
    for f in &faults {
        args.extend(["--inject", f]);
    }
    let (passed, v, printed) = play(&python, &dir, &bag, d, &args);
    assert!(passed, "{printed}");
    for f in faults {
        assert!(v["injections_applied"][f].as_u64().unwrap_or(0) > 0, "{f} not applied: {v}");
    }
    // The peer vanished without a goodbye: the node goes on.
    std::thread::sleep(std::time::Duration::from_secs(3));
    let log = stop_node(&dir, node);
    for want in ["ranges where", "is not after the lidar's last scan", "saved on exit"] {
        assert!(log.contains(want), "{want:?} not in the node's log: {log}");
    }
    let saved = load_map(&dir.join("saved/map.yaml")).unwrap();
    assert!(saved.geometry().same_as(load_map(&stale).unwrap().geometry()));
    let fig: Value = serde_json::from_slice(&std::fs::read(dir.join("figures.json")).unwrap()).unwrap();
    assert!(fig["steps"].as_u64().unwrap() > 200, "{fig}");
}

#[test]
fn with_sim_time_its_own_localiser_seeded_by_initialpose_and_a_clock_that_jumps_back() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(python) = peer_python() else { return };
    let dir = scratch("node-cyclone", "simtime");
    let (bag, stale) = node_drive(&dir);
    let tum = std::fs::read_to_string(dir.join("sim/truth.tum")).unwrap();
    let f: Vec<f64> =
        tum.lines().find(|l| !l.starts_with('#')).unwrap().split_whitespace().map(|v| v.parse().unwrap()).collect();
    let yaw = (2.0 * f[6] * f[7]).atan2(1.0 - 2.0 * f[6] * f[6]);
    let d = domain(2);
    let node = start_node(&dir, &params(&dir, &stale, d, "    pose_source: localiser\n    use_sim_time: true\n"));
    let init = format!("{},{},{}", f[1], f[2], yaw);
    let (passed, v, printed) = play(
        &python,
        &dir,
        &bag,
        d,
        &["--rate", "3", "--clock", "--initialpose", &init, "--inject", "clock-back:1200"],
    );
    let log = stop_node(&dir, node);
    assert!(passed, "{printed}\nnode: {log}");
    for want in ["/initialpose: localiser set", "/clock jumped back by 5.000 s"] {
        assert!(log.contains(want), "{want:?} not in the node's log: {log}");
    }
    assert_eq!(
        differing(&grid(&v["final_map"]), &grid(&v["composed_map"])),
        0,
        "/map and /map + /map_updates disagree"
    );
    assert!(differing(&grid(&v["final_map"]), &cells(&load_map(&stale).unwrap())) > 20, "the node updated the map");
}

#[test]
fn a_mount_that_never_comes_is_reported_and_nothing_is_written() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(python) = peer_python() else { return };
    let dir = scratch("node-cyclone", "no-mount");
    let (bag, stale) = node_drive(&dir);
    let d = domain(3);
    let node = start_node(&dir, &params(&dir, &stale, d, "    pose_source: pose_topic\n    pose_topic: /amcl_pose\n"));
    let (passed, _, printed) =
        play(&python, &dir, &bag, d, &["--rate", "6", "--inject", "no-tf-static", "--timeout-s", "4"]);
    assert!(!passed && printed.contains("no full /map arrived"), "{printed}");
    let log = stop_node(&dir, node);
    assert!(log.contains("no mount for frame 'lidar_0' yet"), "{log}");
    assert_eq!(cells(&load_map(&dir.join("saved/map.yaml")).unwrap()), cells(&load_map(&stale).unwrap()));
    let fig: Value = serde_json::from_slice(&std::fs::read(dir.join("figures.json")).unwrap()).unwrap();
    assert_eq!(fig["steps"], 0, "{fig}");
}

#[test]
fn a_node_killed_while_it_saves_leaves_a_whole_map_and_a_memory_that_fits_it() {
    let _one = SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(python) = peer_python() else { return };
    let dir = scratch("node-cyclone", "killed");
    let (bag, stale) = node_drive(&dir);
    let d = domain(4);
    // A save every 0.1 s of the drive at six times real rate: sixty a second.
    let params =
        params(&dir, &stale, d, "    pose_source: pose_topic\n    pose_topic: /amcl_pose\n    save_period_s: 0.1\n");
    for (k, after_ms) in [1700u64, 2300, 2900].into_iter().enumerate() {
        let mut node = start_node(&dir, &params);
        let mut peer = Command::new(&python)
            .arg(driver())
            .args([
                "--bag",
                s(&bag),
                "--out",
                s(&dir.join("peer.json")),
                "--domain",
                &d.to_string(),
                "--rate",
                "6",
                "--timeout-s",
                "2",
            ])
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(after_ms));
        node.kill().unwrap(); // SIGKILL: no handler runs
        node.wait().unwrap();
        peer.wait().unwrap();
        let saved = mapkeeper_node::save::load(&dir.join("saved")).unwrap_or_else(|e| panic!("kill {k}: {e}"));
        let saved = saved.unwrap_or_else(|| panic!("kill {k}: nothing saved"));
        assert!(saved.map.geometry().same_as(load_map(&stale).unwrap().geometry()), "kill {k}");
        let counts: Value = serde_json::from_slice(&std::fs::read(dir.join("saved/node.json")).unwrap()).unwrap();
        assert!(counts["saves"].is_u64(), "kill {k}: {counts}");
    }
}
