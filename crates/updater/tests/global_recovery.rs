//! The global search when Lost (`mapkeeper`, issue 33): a robot carried across the map and
//! turned, its odometry blind to the move, is found; in a scene with two identical rooms the
//! answer is "not recovered", never a guess; the paper's presets keep the local pose updating.

mod common;

use common::{fill_rect, room, s300_pair};
use mapkeeper_grid::{CellState, OccupancyGrid, Pose2, angle_diff};
use mapkeeper_updater::{MapUpdater, PoseRecovery, RecoveryFailure, StepReport, UpdaterParams, Verdict};

/// A 20 m × 10 m hall with furniture placed without symmetry.
fn hall() -> OccupancyGrid {
    let mut m = room(20.0, 10.0, 0.05);
    for (x0, y0, x1, y1) in [
        (2.0, 6.5, 2.6, 9.95),
        (5.0, 0.05, 5.3, 2.6),
        (6.2, 5.0, 9.0, 5.4),
        (3.6, 2.8, 3.9, 3.1),
        (11.0, 1.5, 11.4, 4.0),
        (13.5, 7.0, 17.0, 7.3),
        (16.0, 2.0, 16.8, 2.8),
        (9.5, 8.0, 9.8, 9.95),
    ] {
        fill_rect(&mut m, x0, y0, x1, y1, CellState::Occupied);
    }
    m
}

/// Two identical closed 8 m × 5 m rooms side by side (the second one 10 m further along x).
fn twin_rooms() -> OccupancyGrid {
    let mut m = room(20.0, 5.0, 0.05);
    fill_rect(&mut m, 9.9, 0.0, 10.1, 5.0, CellState::Occupied);
    for dx in [0.0, 10.0] {
        for (x0, y0, x1, y1) in
            [(2.0, 3.5, 2.6, 4.95), (5.0, 0.05, 5.3, 1.6), (6.2, 3.0, 7.0, 3.4), (3.6, 1.8, 3.9, 2.1)]
        {
            fill_rect(&mut m, x0 + dx, y0, x1 + dx, y1, CellState::Occupied);
        }
    }
    m
}

/// Three good steps at `start`, then a step with the robot at `kidnapped` while estimate and
/// odometry still say `start`; returns the report of that step.
fn kidnap(map: &OccupancyGrid, params: UpdaterParams, start: Pose2, kidnapped: Pose2) -> StepReport {
    let mut up = MapUpdater::new(map.clone(), params).expect("valid preset");
    for k in 0..3u64 {
        let r = up.process(start, start, &s300_pair(map, start, k * 400_000_000));
        assert_eq!(r.verdict, Some(Verdict::Update));
    }
    up.process(start, start, &s300_pair(map, kidnapped, 3 * 400_000_000))
}

#[test]
fn a_kidnap_across_the_map_is_found() {
    let map = hall();
    let start = Pose2::new(3.0, 4.5, 0.2);
    for kidnapped in [Pose2::new(14.5, 4.8, 2.9), Pose2::new(8.0, 2.5, -1.7), Pose2::new(18.0, 8.5, -2.6)] {
        let r = kidnap(&map, UpdaterParams::mapkeeper(), start, kidnapped);
        assert_eq!(r.verdict, Some(Verdict::Lost), "{kidnapped:?}");
        let Some(found) = r.global_search.as_ref() else {
            panic!("no global search for {kidnapped:?}: {:?}", r.pose_recovery)
        };
        assert!(!found.peaks.is_empty() && !found.truncated, "{found:?}");
        match r.pose_recovery {
            Some(PoseRecovery::Recovered { pose_in_map, .. }) => {
                assert!(pose_in_map.distance(&kidnapped) < 0.05, "{pose_in_map:?} for {kidnapped:?}");
                assert!(angle_diff(pose_in_map.yaw, kidnapped.yaw).abs() < 0.01);
            }
            other => panic!("not found: {other:?} for {kidnapped:?} ({found:?})"),
        }
    }
}

#[test]
fn the_paper_stays_local() {
    let map = hall();
    let (start, kidnapped) = (Pose2::new(3.0, 4.5, 0.2), Pose2::new(14.5, 4.8, 2.9));
    for params in [UpdaterParams::paper(), UpdaterParams::authors()] {
        let r = kidnap(&map, params, start, kidnapped);
        assert_eq!(r.verdict, Some(Verdict::Lost));
        assert!(r.global_search.is_none());
        assert!(matches!(r.pose_recovery, Some(PoseRecovery::NotRecovered { .. })), "{:?}", r.pose_recovery);
    }
}

#[test]
fn two_identical_rooms_are_refused_not_guessed() {
    let map = twin_rooms();
    let start = Pose2::new(3.0, 2.6, 0.0);
    let r = kidnap(&map, UpdaterParams::mapkeeper(), start, Pose2::new(14.2, 2.4, 2.0));
    assert_eq!(r.verdict, Some(Verdict::Lost));
    let found = r.global_search.as_ref().expect("the global search ran");
    assert!(found.peaks.len() >= 2, "both rooms are candidates: {found:?}");
    match r.pose_recovery {
        Some(PoseRecovery::NotRecovered { reason: RecoveryFailure::Ambiguous { first, second } }) => {
            assert!((first.x - second.x).abs() > 9.0, "{first:?} / {second:?}");
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_scan_of_another_place_is_not_placed() {
    let map = hall();
    // The robot drives into a place that is not on the map at all.
    let mut elsewhere = room(11.0, 3.2, 0.05);
    fill_rect(&mut elsewhere, 1.0, 1.0, 1.3, 2.4, CellState::Occupied);
    fill_rect(&mut elsewhere, 4.0, 2.0, 6.5, 2.3, CellState::Occupied);
    let start = Pose2::new(3.0, 4.5, 0.2);
    let mut up = MapUpdater::new(map.clone(), UpdaterParams::mapkeeper()).expect("valid preset");
    for k in 0..3u64 {
        up.process(start, start, &s300_pair(&map, start, k * 400_000_000));
    }
    let r = up.process(start, start, &s300_pair(&elsewhere, Pose2::new(3.0, 1.2, 0.0), 1_200_000_000));
    assert_eq!(r.verdict, Some(Verdict::Lost));
    assert!(r.global_search.is_some());
    assert!(matches!(r.pose_recovery, Some(PoseRecovery::NotRecovered { .. })), "{:?}", r.pose_recovery);
    assert_eq!((up.stats().global_searches, up.stats().global_recoveries), (1, 0));
}

/// A 30 m × 4 m corridor: a block on its lower wall at x = 3 and x = 15 (alike), a pillar near
/// its upper wall at x = 10 and x = 27 (alike), plain walls between. With the lidar reaching
/// 2.5 m no view sees two features: each of them fits two places (or, between them, many).
fn twin_corridor() -> OccupancyGrid {
    let mut m = room(30.0, 4.0, 0.05);
    for x in [3.0, 15.0] {
        fill_rect(&mut m, x - 0.75, 0.0, x + 0.75, 1.0, CellState::Occupied);
    }
    for x in [10.0, 27.0] {
        fill_rect(&mut m, x - 0.5, 2.6, x + 0.5, 3.2, CellState::Occupied);
    }
    m
}

/// The robot, kidnapped to x = 3 (its estimate stuck at x = 20 by the lower wall), drives 7 m
/// along the corridor, Lost (once Suspended); returns the poses recovered on the way, with the robot's
/// true pose at each.
fn drive_lost_through_the_twins(params: UpdaterParams) -> Vec<(Pose2, Pose2)> {
    let map = twin_corridor();
    let lidar =
        common::Lidar { range_max_m: 2.5, ..common::Lidar::centred(-std::f64::consts::PI, 0.5f64.to_radians(), 720) };
    let mut up = MapUpdater::new(map.clone(), params).expect("valid preset");
    let stuck = Pose2::new(20.0, 0.6, std::f64::consts::PI);
    let mut found = Vec::new();
    for k in 0..29u64 {
        let truth = Pose2::new(3.0 + 0.25 * k as f64, 2.0, 0.0);
        let odom = Pose2::new(0.25 * k as f64, 0.0, 0.0);
        let r = up.process(stuck, odom, &[common::synth_scan(&map, truth, &lidar, k * 600_000_000)]);
        assert_ne!(r.verdict, Some(Verdict::Update), "step {k}");
        if let Some(PoseRecovery::Recovered { pose_in_map, .. }) = r.pose_recovery {
            found.push((pose_in_map, truth));
            break;
        }
    }
    found
}

/// Issue 54 item 2: on the way each view fits two places or more; the views kept since the
/// kidnap (the block seen at x = 3 and the plain walls after it) rule out every place but the
/// right one, which is handed over near the pillar. Without views (one scan per attempt) the
/// check hands over a place 3.7 m off, which the scans of that one step fit best by the margin.
#[test]
fn views_kept_while_lost_tell_twin_places_apart() {
    let mut with = UpdaterParams::mapkeeper();
    assert_eq!((with.global_search.views, with.global_search.kept_candidates), (4, 4));
    // Every attempt through the global search and its check, where the views act: a view of
    // plain corridor and a pillar's corner fits a place 11 m off, turned, with 95 % of its points,
    // which the local search's confident shortcut would take (docs/recovery.md, "Finding more").
    with.global_search.confident_inlier_ratio = 1.0;
    let found = drive_lost_through_the_twins(with.clone());
    let [(pose, truth)] = found[..] else { panic!("{found:?}") };
    assert!(pose.distance(&truth) < 0.1 && angle_diff(pose.yaw, truth.yaw).abs() < 0.02, "{pose:?} at {truth:?}");
    let mut without = with;
    (without.global_search.views, without.global_search.kept_candidates) = (1, 0);
    let guessed = drive_lost_through_the_twins(without);
    let [(pose, truth)] = guessed[..] else { panic!("{guessed:?}") };
    assert!(pose.distance(&truth) > 1.0, "without views the check takes a wrong place: {pose:?} at {truth:?}");
}
