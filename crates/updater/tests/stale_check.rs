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
