//! `mapkeeper node` (issue 55) without the wire: a simulated drive's bag is replayed message by
//! message into the node's core (each message at its record time, as it would arrive), and the
//! map the node keeps, the map a subscriber composes from its first `/map` and every
//! `/map_updates`, and the map it saves, all equal, cell for cell, the map `mapkeeper update`
//! makes offline from the same bag with the same poses: the robot's localiser's poses (here the
//! bag's truth, played as `/amcl_pose`), and the node's own localiser against `update
//! --localise`. The same through DDS, against Cyclone DDS, is `node_cyclone.rs`.
#![allow(clippy::unwrap_used)]

mod common;

use common::{node_drive as drive, node_offline_update, s, scratch};
use mapkeeper_grid::map_io::load_map;
use mapkeeper_grid::{CellState, OccupancyGrid};
use mapkeeper_node::{Input, NodeConfig, NodeCore, Output, msgs};
use std::path::Path;

/// The bag's messages as the inputs of a node of `config`.
fn inputs(bag: &Path, config: &NodeConfig) -> Vec<(u64, Input)> {
    mapkeeper_node::replay::bag_inputs(&config.params, &std::fs::read(bag).unwrap()).unwrap()
}

fn config(dir: &Path, stale: &Path, extra: &str) -> NodeConfig {
    let text = format!(
        "mapkeeper:\n  ros__parameters:\n    map: {}\n    scan_topics: [/lidar_0/scan, /lidar_1/scan]\n    save_dir: {}\n    map_publish_period_s: 1.0\n{extra}",
        s(stale),
        s(&dir.join("saved"))
    );
    NodeConfig::parse(&text, dir.to_path_buf()).unwrap()
}

/// What a replay's updates were like.
#[derive(Debug, Default)]
struct Updates {
    count: usize,
    cells: usize,
    behind_a_barrier: usize,
}

/// Replays `inputs` into a node of `config`; returns the node, the map composed from its
/// first `/map` and every `/map_updates`, and the updates.
fn replay(config: &NodeConfig, inputs: Vec<(u64, Input)>) -> (NodeCore, OccupancyGrid, Updates) {
    let mut node = NodeCore::start(config, 0).unwrap();
    let (mut composed, mut updates): (Option<Vec<i8>>, Updates) = (None, Updates::default());
    let mut barrier = None;
    let mut apply = |outs: Vec<Output>, composed: &mut Option<Vec<i8>>| {
        for o in outs {
            match o {
                Output::Map(m) if composed.is_none() => *composed = Some(m.data),
                Output::Barrier(h) => barrier = Some(h.stamp),
                Output::MapUpdate(u) => {
                    updates.behind_a_barrier += usize::from(barrier.take() == Some(u.header.stamp));
                    updates.cells += u.data.len();
                    let c = composed.as_mut().unwrap();
                    let w = node_width(config);
                    for row in 0..u.height as usize {
                        for col in 0..u.width as usize {
                            c[(u.y as usize + row) * w + u.x as usize + col] = u.data[row * u.width as usize + col];
                        }
                    }
                    updates.count += 1;
                }
                _ => {}
            }
        }
    };
    let mut last = 0;
    for (t, input) in inputs {
        node.handle(input, t);
        last = t;
        let (outs, _, _) = node.drain();
        apply(outs, &mut composed);
    }
    node.tick(last + 10_000_000_000);
    let (outs, logs, _) = node.drain();
    apply(outs, &mut composed);
    assert!(logs.iter().any(|(_, l)| l.starts_with("saved (idle)")), "{logs:?}");
    let map = node.map().unwrap().clone();
    let values: Vec<CellState> = composed
        .unwrap()
        .iter()
        .map(|&v| match v {
            0 => CellState::Free,
            100 => CellState::Occupied,
            _ => CellState::Unknown,
        })
        .collect();
    (node, OccupancyGrid::from_cells(*map.geometry(), values).unwrap(), updates)
}

fn node_width(config: &NodeConfig) -> usize {
    load_map(&config.resolve(&config.params.map).unwrap()).unwrap().geometry().width()
}

fn differing(a: &OccupancyGrid, b: &OccupancyGrid) -> usize {
    a.cells().iter().zip(b.cells()).filter(|(x, y)| x != y).count()
}

#[test]
fn the_node_keeps_the_map_update_makes_offline_with_the_robots_poses_and_with_its_own_localiser() {
    let dir = scratch("node", "replay");
    let (bag, stale) = drive(&dir);
    let before = load_map(&stale).unwrap();

    // The robot's localiser's poses.
    let (offline, printed) = node_offline_update(&bag, &stale, &dir.join("off"), &["--true-poses"]);
    let changed = differing(&before, &offline);
    assert!(changed > 50, "the drive must change the stale map: {changed} cells; {printed}");
    let cfg = config(
        &dir,
        &stale,
        "    pose_source: pose_topic\n    pose_topic: /truth\n    barrier_topic: /map_source_ready\n",
    );
    let (node, composed, updates) = replay(&cfg, inputs(&bag, &cfg));
    assert_eq!(differing(node.map().unwrap(), &offline), 0, "the node's map differs from the offline update's");
    assert_eq!(differing(&composed, &offline), 0, "/map + /map_updates differ from the offline update's map");
    // Partial updates: each the changed cells' bounding box, far smaller than the grid; each
    // behind a readiness barrier with its stamp.
    assert!(updates.count > 5, "{updates:?}");
    let grid_cells = offline.geometry().len();
    assert!(updates.cells < grid_cells * updates.count / 20, "{updates:?} on a {grid_cells}-cell grid");
    assert_eq!(updates.behind_a_barrier, updates.count, "{updates:?}");
    let saved = load_map(&dir.join("saved/map.yaml")).unwrap();
    assert_eq!(differing(&saved, &offline), 0);
    let counts = node.counts();
    assert_eq!(counts.steps, 375, "{counts:?}");
    assert_eq!(counts.input.scans, 750);
    assert_eq!(
        (counts.input.steps_dropped_behind, counts.input.steps_timed_out, counts.messages_refused),
        (0, 0, 0),
        "{counts:?}"
    );

    // The node's own localiser, started where `update --localise` starts (the first pose).
    let (offline, printed) =
        node_offline_update(&bag, &stale, &dir.join("off-loc"), &["--localise", "--localiser", "mapkeeper-real"]);
    let first =
        first_truth_at_first_scan(&bag, &config(&dir, &stale, "    pose_source: pose_topic\n    pose_topic: /truth\n"));
    let extra = format!(
        "    pose_source: localiser\n    localiser_preset: mapkeeper-real\n    seed: 0\n    initial_pose: [{:?}, {:?}, {:?}]\n    resume: false\n",
        first.0, first.1, first.2
    );
    let cfg = config(&dir, &stale, &extra);
    let (node, composed, _) = replay(&cfg, inputs(&bag, &cfg));
    assert_eq!(
        differing(node.map().unwrap(), &offline),
        0,
        "own localiser: the node's map differs from `update --localise`; {printed}"
    );
    assert_eq!(differing(&composed, &offline), 0);
}

/// The `/truth` pose stamped with the first scan's stamp.
fn first_truth_at_first_scan(bag: &Path, config: &NodeConfig) -> (f64, f64, f64) {
    let all = inputs(bag, config);
    let t0 = all.iter().find_map(|(_, i)| match i {
        Input::Scan { msg, .. } => msg.header.stamp.to_ns(),
        _ => None,
    });
    all.iter()
        .find_map(|(_, i)| match i {
            Input::Pose(p) if p.header.stamp.to_ns() == t0 => {
                let q = mapkeeper_node::core::planar(&p.pose.pose).unwrap();
                Some((q.x, q.y, q.yaw))
            }
            _ => None,
        })
        .unwrap()
}

/// The robot's localiser goes wrong (its pose 1.5 m off in x and in y from 15 s on, as a kidnapped
/// AMCL's would be), on the true map: the node's check says Lost, pose updating finds the robot,
/// and the pose goes out on `/initialpose` to re-seed the localiser, near where the robot truly
/// is. (At 1 m off in x alone, along an aisle, the check says Suspend and nothing goes out.)
#[test]
fn a_pose_that_pose_updating_recovers_goes_out_on_initialpose() {
    let dir = scratch("node", "initialpose");
    let (bag, _) = drive(&dir);
    let cfg = config(
        &dir,
        &dir.join("sim/ground_truth.yaml"),
        "    pose_source: pose_topic\n    pose_topic: /truth\n    resume: false\n",
    );
    let all = inputs(&bag, &cfg);
    let truth: Vec<(u64, mapkeeper_grid::Pose2)> = all
        .iter()
        .filter_map(|(_, i)| match i {
            Input::Pose(p) => Some((p.header.stamp.to_ns()?, mapkeeper_node::core::planar(&p.pose.pose)?)),
            _ => None,
        })
        .collect();
    let t0 = truth[0].0;
    let wrong: Vec<(u64, Input)> = all
        .into_iter()
        .map(|(t, i)| match i {
            Input::Pose(mut p) if p.header.stamp.to_ns().unwrap() > t0 + 15_000_000_000 => {
                p.pose.pose.position.x += 1.5;
                p.pose.pose.position.y += 1.5;
                (t, Input::Pose(p))
            }
            other => (t, other),
        })
        .collect();
    let mut node = NodeCore::start(&cfg, 0).unwrap();
    let mut sent = Vec::new();
    for (t, input) in wrong {
        node.handle(input, t);
        sent.extend(node.drain().0.into_iter().filter_map(|o| match o {
            Output::InitialPose(p) => Some(p),
            _ => None,
        }));
    }
    assert!(!sent.is_empty(), "no /initialpose from {:?}", node.counts());
    for p in &sent {
        let at = p.header.stamp.to_ns().unwrap();
        let k = truth.partition_point(|(s, _)| *s < at).min(truth.len() - 1);
        let got = mapkeeper_node::core::planar(&p.pose.pose).unwrap();
        let d = got.distance(&truth[k].1);
        assert!(d < 0.3, "a recovered pose {d:.2} m from the truth: {got:?} vs {:?}", truth[k].1);
        assert!(p.pose.covariance.0[0] > 0.0 && p.pose.covariance.0[35] > 0.0, "a covariance with it");
    }
}

/// `pose_source: tf`: the robot's localiser gives `map → odom` on `/tf` (here the truth composed
/// with the inverse odometry at the same stamps), the node composes it with the odometry at each
/// step, and its map matches the offline update's at the true poses.
#[test]
fn with_map_to_odom_on_tf_the_node_keeps_the_map_of_the_true_poses() {
    let dir = scratch("node", "tf");
    let (bag, stale) = drive(&dir);
    let (offline, _) = node_offline_update(&bag, &stale, &dir.join("off"), &["--true-poses"]);
    let topic = config(&dir, &stale, "    pose_source: pose_topic\n    pose_topic: /truth\n    resume: false\n");
    let all = inputs(&bag, &topic);
    let odom: std::collections::BTreeMap<u64, mapkeeper_grid::Pose2> = all
        .iter()
        .filter_map(|(_, i)| match i {
            Input::Odometry(o) => Some((o.header.stamp.to_ns()?, mapkeeper_node::core::planar(&o.pose.pose)?)),
            _ => None,
        })
        .collect();
    let as_tf: Vec<(u64, Input)> = all
        .into_iter()
        .filter_map(|(t, i)| match i {
            Input::Pose(p) => {
                let stamp = p.header.stamp.to_ns()?;
                let map_odom = mapkeeper_node::core::planar(&p.pose.pose)?.compose(&odom.get(&stamp)?.inverse());
                let tf = msgs::TransformStamped {
                    header: msgs::Header { stamp: p.header.stamp, frame_id: "map".into() },
                    child_frame_id: "odom".into(),
                    transform: mapkeeper_node::outputs::pose_message(map_odom),
                };
                Some((t, Input::Tf(msgs::TfMessage { transforms: vec![tf] })))
            }
            other => Some((t, other)),
        })
        .collect();
    let cfg = config(&dir, &stale, "    pose_source: tf\n    resume: false\n");
    let (node, composed, _) = replay(&cfg, as_tf);
    assert_eq!(node.counts().steps, 375, "{:?}", node.counts());
    let d = differing(node.map().unwrap(), &offline);
    let changed = differing(&load_map(&stale).unwrap(), &offline);
    // The composed pose differs from the true pose by rounding only (~1e-16 m).
    assert!(d * 200 <= changed, "{d} cells differ of the {changed} the offline update changed");
    assert_eq!(differing(&composed, node.map().unwrap()), 0);
    println!("tf: {d} cells differ from the offline map at the true poses, of {changed} changed");
}
