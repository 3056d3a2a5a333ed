//! `mapkeeper`'s check in a stale world (issue 27's false-alarm target): the shift check on alarm
//! steps lifts the change count's alarm at a right pose whose scan fits `M_{i-1}` and has no
//! better pose nearby, and leaves the alarm of a wrong pose standing.
#![allow(clippy::unwrap_used)]

mod common;

use common::{fill_rect, room, s300_pair};
use mapkeeper_grid::{CellState, OccupancyGrid, Pose2};
use mapkeeper_updater::{MapUpdater, UpdaterParams, Verdict};

/// The map: a bare 6 m × 6 m room. The world it went stale in: a lining of shelves 0.22 m in
/// front of every wall, with 0.3 m gaps every 1.2 m through which the walls are still seen. At
/// the room's centre most beams end on the lining, 0.22 m from the map's walls: further than the
/// change distance D_th(z) at these ranges, so the paper's check counts them changed; but no
/// shift of the pose explains a lining on all four sides.
fn stale_room() -> (OccupancyGrid, OccupancyGrid) {
    let map = room(6.0, 6.0, 0.05);
    let mut world = map.clone();
    let (near, far) = (0.22, 6.0 - 0.22 - 0.05);
    let mut a: f64 = 0.3;
    while a < 5.7 {
        let b = (a + 0.9).min(5.7);
        fill_rect(&mut world, a, near, b, near + 0.05, CellState::Occupied);
        fill_rect(&mut world, a, far, b, far + 0.05, CellState::Occupied);
        fill_rect(&mut world, near, a, near + 0.05, b, CellState::Occupied);
        fill_rect(&mut world, far, a, far + 0.05, b, CellState::Occupied);
        a += 1.2;
    }
    (map, world)
}

/// The verdicts of `steps` steps driven across the room's centre, the estimate `offset` from the
/// truth.
fn verdicts(params: UpdaterParams, offset: (f64, f64), steps: usize) -> Vec<Verdict> {
    let (map, world) = stale_room();
    let mut up = MapUpdater::new(map, params).unwrap();
    (0..steps)
        .filter_map(|k| {
            let truth = Pose2::new(2.7 + 0.06 * k as f64, 3.0, 0.3);
            let est = Pose2::new(truth.x + offset.0, truth.y + offset.1, truth.yaw);
            let r = up.process(est, truth, &s300_pair(&world, truth, k as u64 * 100_000_000));
            r.verdict
        })
        .collect()
}

fn alarms(v: &[Verdict]) -> usize {
    v.iter().filter(|v| **v != Verdict::Update).count()
}

#[test]
fn a_right_pose_in_a_stale_world_is_not_an_alarm_for_mapkeeper() {
    // The paper's check (and the second release's `mapkeeper`, which shares it) cries wolf on
    // every step: three quarters of the beams end on the lining.
    for params in [UpdaterParams::paper(), UpdaterParams::mapkeeper_no_registration()] {
        let v = verdicts(params, (0.0, 0.0), 10);
        assert_eq!(alarms(&v), 10, "{v:?}");
    }
    // `mapkeeper`'s shift check finds the pose fits the map's walls through the gaps and no
    // nearby pose fits better: the alarm is lifted on every step.
    let v = verdicts(UpdaterParams::mapkeeper(), (0.0, 0.0), 10);
    assert_eq!(alarms(&v), 0, "{v:?}");
}

#[test]
fn a_wrong_pose_in_a_stale_world_stays_an_alarm_for_mapkeeper() {
    // 0.58 m off: the true pose lies inside the shift check's search and fits better.
    for params in [UpdaterParams::mapkeeper(), UpdaterParams::mapkeeper_shift()] {
        let v = verdicts(params, (0.5, 0.3), 10);
        assert_eq!(alarms(&v), 10, "{v:?}");
    }
}

#[test]
fn the_step_report_carries_the_shift_check_where_it_ran() {
    let (map, world) = stale_room();
    let truth = Pose2::new(3.0, 3.0, 0.3);
    let scans = s300_pair(&world, truth, 0);
    // `paper` has no shift check; `mapkeeper` runs it on this alarm step: the given pose is
    // the best in the search (the lining fits nowhere better) and fits.
    let r = MapUpdater::new(map.clone(), UpdaterParams::paper()).unwrap().process(truth, truth, &scans);
    assert_ne!(r.check_verdict, Some(Verdict::Update));
    assert_eq!(r.shift_check, None);
    let r = MapUpdater::new(map.clone(), UpdaterParams::mapkeeper()).unwrap().process(truth, truth, &scans);
    assert_ne!(r.check_verdict, Some(Verdict::Update));
    assert_eq!(r.verdict, Some(Verdict::Update));
    let s = r.shift_check.unwrap();
    assert!(s.given_m <= UpdaterParams::mapkeeper().shift_check.fit_ok_m, "{s:?}");
    assert!(s.given_m - s.best_m < UpdaterParams::mapkeeper().shift_check.better_margin_m, "{s:?}");
    // 0.58 m off, the search finds a better pose near the truth.
    let est = Pose2::new(truth.x + 0.5, truth.y + 0.3, truth.yaw);
    let r = MapUpdater::new(map, UpdaterParams::mapkeeper()).unwrap().process(est, truth, &scans);
    let s = r.shift_check.unwrap();
    assert!(s.best_pose.distance(&truth) < 0.25 && s.best_m < s.given_m, "{s:?}");
}
