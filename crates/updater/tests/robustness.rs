//! Behaviour of the whole updater: bad input, gating, presets, multi-lidar, determinism,
//! memory, and pose updating.

mod common;

use common::{Lidar, fill_rect, room, s300_pair, scan360, synth_scan};
use mapkeeper_grid::{CellState, OccupancyGrid, Pose2};
use mapkeeper_sensor::LaserScan;
use mapkeeper_testkit::rooms::walled_in;
use mapkeeper_updater::paper::pose_updating::PoseUpdater;
use mapkeeper_updater::{
    GateReason, MapUpdater, PoseRecovery, PoseUpdatingParams, StepOutcome, UpdaterParams, Verdict,
};

fn added_box_world(base: &OccupancyGrid) -> OccupancyGrid {
    let mut w = base.clone();
    fill_rect(&mut w, 4.0, 1.8, 4.4, 2.2, CellState::Occupied);
    w
}

fn pose_at(k: usize) -> Pose2 {
    Pose2::new(1.5 + 0.06 * k as f64, 2.0, 0.0)
}

#[test]
fn bad_scans_are_counted_never_a_panic() {
    let base = room(6.0, 4.0, 0.05);
    let mut up = MapUpdater::new(base.clone(), UpdaterParams::paper()).unwrap();
    let robot = Pose2::new(2.0, 2.0, 0.0);
    let mut good = scan360(&base, robot, 0);
    // NaN, +inf, -inf, negative, zero, beyond max range, below min range.
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0, 0.0, 31.0, 0.01];
    for (k, r) in bad.iter().enumerate() {
        good.ranges_m[k * 10] = *r;
    }
    let mut bad_header = good.clone();
    bad_header.angle_increment_rad = f64::NAN;
    let mut too_wide = good.clone();
    too_wide.angle_increment_rad = 0.1; // 720 beams over 72 rad: fails validate()
    let empty = LaserScan { ranges_m: vec![], ..good.clone() };
    let r = up.process(robot, robot, &[good.clone(), bad_header, too_wide, empty]);
    assert_eq!(r.outcome, StepOutcome::Processed);
    assert_eq!(r.invalid_scans, 2);
    assert_eq!(r.n_valid, 720 - bad.len());
    assert_eq!(r.n_invalid, bad.len() + 2 * 720);
    assert_eq!(r.verdict, Some(Verdict::Update));
    // A step with no valid beam is skipped and counted.
    let all_bad = LaserScan { ranges_m: vec![f32::NAN; 720], ..good.clone() };
    let r = up.process(Pose2::new(2.5, 2.0, 0.0), Pose2::new(2.5, 2.0, 0.0), &[all_bad]);
    assert_eq!(r.outcome, StepOutcome::NoValidBeams);
    let r = up.process(Pose2::new(2.5, 2.0, 0.0), Pose2::new(2.5, 2.0, 0.0), &[]);
    assert_eq!(r.outcome, StepOutcome::NoValidBeams);
    // A non-finite pose makes every scan invalid rather than panicking.
    let r = up.process(Pose2::new(f64::NAN, 2.0, 0.0), Pose2::new(3.0, 2.0, 0.0), &[good]);
    assert_eq!(r.outcome, StepOutcome::NoValidBeams);
    let s = up.stats();
    assert_eq!((s.processed, s.skipped_no_valid_beam), (1, 3));
    assert_eq!(up.map(), &base);
}

#[test]
fn gating_needs_5cm_or_20deg_between_processed_scans() {
    let base = room(6.0, 4.0, 0.05);
    let mut up = MapUpdater::new(base.clone(), UpdaterParams::paper()).unwrap();
    let p0 = Pose2::new(2.0, 2.0, 0.0);
    assert_eq!(up.process(p0, p0, &[scan360(&base, p0, 0)]).outcome, StepOutcome::Processed);
    let p1 = Pose2::new(2.04, 2.0, 0.0);
    let r = up.process(p1, p1, &[scan360(&base, p1, 1)]);
    assert_eq!(r.outcome, StepOutcome::Gated(GateReason::TooLittleMotion));
    let p2 = Pose2::new(2.0, 2.0, 0.36);
    assert_eq!(up.process(p2, p2, &[scan360(&base, p2, 2)]).outcome, StepOutcome::Processed);
}

#[test]
fn no_update_keeps_m1_and_always_update_ignores_the_check() {
    let base = room(6.0, 4.0, 0.05);
    let world = added_box_world(&base);
    // no-update: verdicts as usual, map unchanged.
    let mut up = MapUpdater::new(base.clone(), UpdaterParams::no_update()).unwrap();
    for k in 0..10 {
        let r = up.process(pose_at(k), pose_at(k), &[scan360(&world, pose_at(k), k as u64)]);
        assert_eq!(r.verdict, Some(Verdict::Update));
        assert!(r.changed_cells.is_empty());
    }
    assert_eq!(up.map(), &base);
    // A badly wrong estimate (0.6 m, 25°): paper suspends or is lost and never updates;
    // always-update updates anyway and corrupts the map.
    let err = Pose2::new(0.6, 0.4, 25f64.to_radians());
    let mut paper = MapUpdater::new(base.clone(), UpdaterParams::paper()).unwrap();
    let mut always = MapUpdater::new(base.clone(), UpdaterParams::always_update()).unwrap();
    for k in 0..10 {
        let scans = [scan360(&base, pose_at(k), k as u64)];
        let est = pose_at(k).compose(&err);
        let r = paper.process(est, pose_at(k), &scans);
        assert_ne!(r.verdict, Some(Verdict::Update), "n={} n_dc={}", r.n_valid, r.n_dc);
        assert!(r.changed_cells.is_empty());
        assert_eq!(always.process(est, pose_at(k), &scans).verdict, Some(Verdict::Update));
    }
    assert_eq!(paper.map(), &base);
    assert!(always.stats().cell_changes > 0);
}

#[test]
fn log_odds_baseline_writes_scans_into_the_map() {
    let base = room(6.0, 4.0, 0.05);
    let world = added_box_world(&base);
    let mut up = MapUpdater::new(base.clone(), UpdaterParams::log_odds()).unwrap();
    for k in 0..10 {
        up.process(pose_at(k), pose_at(k), &[scan360(&world, pose_at(k), k as u64)]);
    }
    assert_eq!(up.map().get(mapkeeper_grid::CellCoord::new(80, 40)), Some(CellState::Occupied));
    assert_eq!(up.initial_map(), &base);
}

/// Two 180° lidars at the robot centre facing opposite ways see exactly the beams of one merged
/// 360° scan: same n, n_dc, changes and map.
#[test]
fn multi_lidar_equals_merged_scan_on_a_symmetric_case() {
    let base = room(6.0, 4.0, 0.05);
    let world = added_box_world(&base);
    let inc = std::f64::consts::PI / 360.0;
    let half = std::f64::consts::FRAC_PI_2;
    let mut merged = MapUpdater::new(base.clone(), UpdaterParams::paper()).unwrap();
    let mut split = MapUpdater::new(base.clone(), UpdaterParams::paper()).unwrap();
    for k in 0..10 {
        let robot = pose_at(k);
        // Merged: beams from -90° to 270°, 720 of them.
        let one = synth_scan(&world, robot, &Lidar::centred(-half, inc, 720), k as u64);
        let front = LaserScan { ranges_m: one.ranges_m[..360].to_vec(), ..one.clone() };
        let back = LaserScan {
            lidar_id: 1,
            lidar_in_robot: Pose2::new(0.0, 0.0, std::f64::consts::PI),
            ranges_m: one.ranges_m[360..].to_vec(),
            ..one.clone()
        };
        let a = merged.process(robot, robot, &[one]);
        let b = split.process(robot, robot, &[front, back]);
        assert_eq!((a.n_valid, a.n_dc, a.verdict), (b.n_valid, b.n_dc, b.verdict), "step {k}");
        assert_eq!(a.changed_cells, b.changed_cells, "step {k}");
    }
    assert_eq!(merged.map(), split.map());
    assert!(merged.stats().cell_changes > 0);
}

#[test]
fn deterministic_bit_for_bit() {
    let run = || {
        let base = room(6.0, 4.0, 0.05);
        let world = added_box_world(&base);
        let mut up = MapUpdater::new(base, UpdaterParams::paper()).unwrap();
        let reports: Vec<_> = (0..12)
            .map(|k| {
                let truth = pose_at(k);
                let est = truth.compose(&Pose2::new(0.01, -0.02, 0.004));
                up.process(est, truth, &s300_pair(&world, truth, k as u64 * 80_000_000))
            })
            .collect();
        (reports, up.map().clone(), up.state_bytes())
    };
    assert_eq!(run(), run());
}

/// The updater's own state for the same changes is identical in a map 16 times larger.
#[test]
fn state_bytes_independent_of_map_size() {
    let state_after = |cells_w: usize, cells_h: usize| {
        let base = walled_in(6.0, 4.0, 0.05, cells_w, cells_h);
        let mut world = added_box_world(&base);
        fill_rect(&mut world, 2.8, 0.05, 3.2, 0.4, CellState::Free); // a removed piece of wall
        let mut up = MapUpdater::new(base, UpdaterParams::paper()).unwrap();
        for k in 0..10 {
            up.process(pose_at(k), pose_at(k), &[scan360(&world, pose_at(k), k as u64)]);
        }
        (up.state_bytes(), up.buffered_cells(), up.stats().cell_changes)
    };
    let small = state_after(120, 80);
    let large = state_after(480, 320);
    assert!(small.1 > 0, "some cells hold buffers");
    assert_eq!(small, large);
}

fn asymmetric_room() -> OccupancyGrid {
    let mut m = room(8.0, 5.0, 0.05);
    fill_rect(&mut m, 2.0, 3.5, 2.6, 4.95, CellState::Occupied);
    fill_rect(&mut m, 5.0, 0.05, 5.3, 1.6, CellState::Occupied);
    fill_rect(&mut m, 6.2, 3.0, 7.0, 3.4, CellState::Occupied);
    fill_rect(&mut m, 3.6, 1.8, 3.9, 2.1, CellState::Occupied);
    m
}

#[test]
fn icp_recovers_a_known_offset() {
    let map = asymmetric_room();
    let truth = Pose2::new(3.0, 2.6, 0.3);
    let scans = s300_pair(&map, truth, 0);
    let mut pu = PoseUpdater::new();
    for offset in [Pose2::new(0.4, -0.3, 0.12), Pose2::new(-0.5, 0.2, -0.3), Pose2::new(0.1, 0.1, 0.0)] {
        let predicted = Pose2::new(truth.x + offset.x, truth.y + offset.y, truth.yaw + offset.yaw);
        match pu.recover(&map, predicted, &scans, f64::INFINITY, &PoseUpdatingParams::default()) {
            PoseRecovery::Recovered { pose_in_map, covariance, fitness } => {
                assert!(pose_in_map.distance(&truth) < 0.03, "{pose_in_map:?} from {offset:?}");
                assert!((pose_in_map.yaw - truth.yaw).abs() < 0.01);
                assert!(fitness.inlier_ratio > 0.9);
                assert!(covariance[0][0] > 0.0 && covariance[2][2] > 0.0);
            }
            other => panic!("not recovered from {offset:?}: {other:?}"),
        }
    }
}

#[test]
fn icp_refuses_a_scan_of_another_place() {
    let map = asymmetric_room();
    // A narrower, longer hall with other furniture.
    let mut elsewhere = room(11.0, 3.2, 0.05);
    fill_rect(&mut elsewhere, 1.0, 1.0, 1.3, 2.4, CellState::Occupied);
    fill_rect(&mut elsewhere, 4.0, 2.0, 6.5, 2.3, CellState::Occupied);
    fill_rect(&mut elsewhere, 8.5, 0.05, 8.8, 1.0, CellState::Occupied);
    let truth = Pose2::new(3.0, 1.2, 0.0);
    let scans = s300_pair(&elsewhere, truth, 0);
    let mut pu = PoseUpdater::new();
    let r = pu.recover(&map, truth, &scans, f64::INFINITY, &PoseUpdatingParams::default());
    assert!(matches!(r, PoseRecovery::NotRecovered { .. }), "{r:?}");
}

/// A kidnapped estimate (0.5 m, 0.2 rad off) makes the check say Lost; pose updating starts
/// from the last good pose moved on by odometry and hands back the true pose.
#[test]
fn lost_triggers_pose_updating_from_the_last_good_pose() {
    let map = asymmetric_room();
    let mut up = MapUpdater::new(map.clone(), UpdaterParams::paper()).unwrap();
    let truth = |k: usize| Pose2::new(1.5 + 0.1 * k as f64, 2.6, 0.0);
    // Odometry with an offset frame: only its increments matter.
    let odom_frame = Pose2::new(-3.0, 7.0, 1.0);
    for k in 0..3 {
        let r = up.process(truth(k), odom_frame.compose(&truth(k)), &s300_pair(&map, truth(k), k as u64 * 400_000_000));
        assert_eq!(r.verdict, Some(Verdict::Update));
    }
    let k = 3;
    let wrong = truth(k).compose(&Pose2::new(1.2, 0.9, 2.6));
    let r = up.process(wrong, odom_frame.compose(&truth(k)), &s300_pair(&map, truth(k), k as u64 * 400_000_000));
    assert_eq!(r.verdict, Some(Verdict::Lost), "n={} n_dc={}", r.n_valid, r.n_dc);
    match r.pose_recovery {
        Some(PoseRecovery::Recovered { pose_in_map, .. }) => {
            assert!(pose_in_map.distance(&truth(k)) < 0.03 && (pose_in_map.yaw - truth(k).yaw).abs() < 0.01)
        }
        other => panic!("{other:?}"),
    }
    assert!(r.changed_cells.is_empty());
    assert_eq!(up.map(), &map);
}
