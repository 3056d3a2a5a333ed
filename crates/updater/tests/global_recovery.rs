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
