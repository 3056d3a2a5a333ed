//! Regression tests of the defects found by the line-by-line reading of issue 11, and the scenes
//! that tell the presets apart (`paper` vs `authors`, `paper` vs `mapkeeper`).
#![allow(clippy::unwrap_used)]

mod common;

use common::digest::moved as placed;
use common::{fill_rect, room, scan360};
use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Point2, Pose2};
use mapkeeper_updater::support::beam_walk::BeamGeometry;
use mapkeeper_updater::support::cell_buffers::CellBuffers;
use mapkeeper_updater::{MapUpdater, PoseRecovery, StepOutcome, UpdaterParams, Verdict};

fn changed(a: &OccupancyGrid, b: &OccupancyGrid) -> usize {
    a.cells().iter().zip(b.cells()).filter(|(x, y)| x != y).count()
}

/// Drives along the wall of a room whose map origin is turned by `yaw`, the estimate 2 cm off
/// towards the wall and 0.3° turned; returns the number of cells changed.
fn wall_drive(params: UpdaterParams, yaw: f64) -> usize {
    let origin = Pose2::new(1.0, -2.0, yaw);
    let world = placed(&room(10.0, 4.0, 0.05), origin);
    let error = Pose2::new(0.0, -0.02, 0.3f64.to_radians());
    let mut up = MapUpdater::new(world.clone(), params).unwrap();
    for k in 0..120 {
        let truth = origin.compose(&Pose2::new(1.0 + 0.06 * k as f64, 0.55, 0.0));
        let r = up.process(truth.compose(&error), truth, &[scan360(&world, truth, k * 100_000_000)]);
        assert_eq!(r.verdict, Some(Verdict::Update), "step {k}");
    }
    changed(&world, up.map())
}

/// The grazing gate compared a world-frame ray with grid-frame cell faces: in a map whose origin
/// has a yaw (real maps do) it gated the wrong rays and the wall eroded.
#[test]
fn grazing_gate_works_in_a_map_with_a_turned_origin() {
    // The grazing gate alone (the hit clearance would hide the defect).
    let mut gate_only = UpdaterParams::mapkeeper_no_registration();
    gate_only.removal.hit_clearance_m = 0.0;
    let mut without = gate_only.clone();
    without.removal.min_incidence_rad = 0.0;
    for yaw in [0.0, 0.9, -1.1, 2.5] {
        assert!(wall_drive(without.clone(), yaw) >= 5, "yaw {yaw}: the scene needs the gate");
        assert_eq!(wall_drive(gate_only.clone(), yaw), 0, "yaw {yaw}");
    }
}

/// The free-pass rule voted a short beam's own hit cell "unchanged" (its centre lay beyond the
/// tiny final chunk) while the changed evaluator voted it "changed".
#[test]
fn free_pass_never_votes_the_hit_cell() {
    use mapkeeper_updater::additions::free_pass::evaluate_free_pass;
    let g = GridGeometry::new(40, 40, 0.05, Pose2::IDENTITY).unwrap();
    let base = OccupancyGrid::filled(g, CellState::Free);
    let mut buffers = CellBuffers::new();
    for y in 0..40 {
        for x in 0..40 {
            let c = CellCoord::new(x, y);
            buffers.ensure(g.index(c).unwrap() as u32, c);
        }
    }
    let params = UpdaterParams::mapkeeper();
    // A 0.5 m beam ending 1 mm into a cell: the chunk is 1 cm, the cell's centre 2.4 cm away.
    let origin = Point2::new(0.525, 1.025);
    let hit = Point2::new(1.001, 1.025);
    let hit_cell = g.index(g.world_to_cell(hit).unwrap()).unwrap() as u32;
    let mut votes = Vec::new();
    let beam = BeamGeometry::new(origin, hit, hit.x - origin.x);
    evaluate_free_pass(&base, &beam, &params, 0.0, &mut buffers.probe(), &mut votes);
    assert!(!votes.is_empty());
    assert!(votes.iter().all(|v| v >> 1 != hit_cell), "the hit cell got a free-pass vote");
}

/// A square room's 360° scan with the first `changed` beams of every 20 shortened by 1 m (an
/// unmapped object close to the robot in those directions).
fn scan_with_changes(
    world: &OccupancyGrid,
    robot: Pose2,
    changed: usize,
    stamp_ns: u64,
) -> mapkeeper_sensor::LaserScan {
    let mut s = scan360(world, robot, stamp_ns);
    for (i, r) in s.ranges_m.iter_mut().enumerate() {
        if i % 20 < changed {
            *r -= 1.0;
        }
    }
    s
}

/// The localisation check tells `paper` from `authors`: with 65 % of the beams a change, the
/// paper updates (≤ 0.75 n), the authors' single threshold (0.58) says Lost.
#[test]
fn paper_and_authors_differ_on_the_check() {
    let world = room(6.0, 6.0, 0.05);
    let robot = Pose2::new(3.0, 3.0, 0.1);
    let scan = scan_with_changes(&world, robot, 13, 0);
    let verdict = |p: UpdaterParams| {
        MapUpdater::new(world.clone(), p).unwrap().process(robot, robot, std::slice::from_ref(&scan)).verdict
    };
    assert_eq!(verdict(UpdaterParams::paper()), Some(Verdict::Update));
    assert_eq!(verdict(UpdaterParams::mapkeeper()), Some(Verdict::Update));
    assert_eq!(verdict(UpdaterParams::authors()), Some(Verdict::Lost));
}

/// The update gate stood in front of the whole pipeline, so nothing was checked while the robot
/// stood still: a pose jump of a standing robot went unnoticed. The check now runs on every
/// scan; the gate only paces the cells update.
#[test]
fn the_check_runs_while_the_robot_stands_still() {
    let world = room(6.0, 6.0, 0.05);
    let robot = Pose2::new(3.0, 3.0, 0.1);
    let mut up = MapUpdater::new(world.clone(), UpdaterParams::paper()).unwrap();
    let first = up.process(robot, robot, &[scan360(&world, robot, 0)]);
    assert_eq!((first.outcome, first.verdict), (StepOutcome::Processed, Some(Verdict::Update)));
    let still = up.process(robot, robot, &[scan360(&world, robot, 100_000_000)]);
    assert!(matches!(still.outcome, StepOutcome::Gated(_)), "{:?}", still.outcome);
    assert_eq!(still.verdict, Some(Verdict::Update));
    // The estimate jumps 1.2 m and turns while the odometry says the robot has not moved.
    let wrong = Pose2::new(1.8, 4.0, 0.9);
    let lost = up.process(wrong, robot, &[scan360(&world, robot, 200_000_000)]);
    assert_eq!(lost.verdict, Some(Verdict::Lost), "n={} n_dc={}", lost.n_valid, lost.n_dc);
    assert!(lost.pose_recovery.is_some());
    assert!(lost.changed_cells.is_empty());
    assert_eq!(up.stats().processed, 3);
    assert_eq!(up.stats().cells_updates, 1);
}

/// The check had no minimum beam count: one valid beam that is a change made the robot Lost.
#[test]
fn one_valid_beam_is_no_verdict() {
    let world = room(6.0, 6.0, 0.05);
    let robot = Pose2::new(3.0, 3.0, 0.0);
    let mut scan = scan360(&world, robot, 0);
    for r in scan.ranges_m.iter_mut() {
        *r = f32::NAN;
    }
    scan.ranges_m[0] = 1.0; // a change: the wall is 2.95 m away
    let mut up = MapUpdater::new(world.clone(), UpdaterParams::paper()).unwrap();
    let r = up.process(robot, robot, &[scan.clone()]);
    assert_eq!((r.outcome, r.verdict, r.n_valid, r.n_dc), (StepOutcome::TooFewBeams, None, 1, 1));
    assert_eq!(up.stats().losts, 0);
    // With the guard lowered to one beam the old behaviour comes back.
    let mut one = MapUpdater::new(world, UpdaterParams { min_valid_beams: 1, ..UpdaterParams::paper() }).unwrap();
    assert_eq!(one.process(robot, robot, &[scan]).verdict, Some(Verdict::Lost));
}

/// A lidar inside a non-free cell of `M_{i-1}` (the robot drives through where a removed item
/// was mapped) turned every beam into a change, forever: the robot was Lost while inside and
/// could not be updated. Now such a scan is not used; the item is removed by the rays from
/// outside, and the robot is never Lost.
#[test]
fn driving_through_a_removed_item() {
    let base = {
        let mut m = room(8.0, 4.0, 0.05);
        fill_rect(&mut m, 3.5, 1.5, 4.5, 2.5, CellState::Occupied);
        m
    };
    let world = room(8.0, 4.0, 0.05);
    for params in [UpdaterParams::paper(), UpdaterParams::mapkeeper(), UpdaterParams::authors()] {
        let mut up = MapUpdater::new(base.clone(), params).unwrap();
        let mut occluded = 0;
        for k in 0..100u64 {
            let robot = Pose2::new(1.0 + 0.06 * k as f64, 2.0, 0.0);
            let r = up.process(robot, robot, &[scan360(&world, robot, k * 300_000_000)]);
            assert_ne!(r.verdict, Some(Verdict::Lost), "step {k}: n={} n_dc={}", r.n_valid, r.n_dc);
            occluded += r.occluded_scans;
        }
        assert!(occluded >= 10, "the robot stood inside the mapped item: {occluded}");
        assert_eq!(up.stats().occluded_scans, occluded as u64);
        let freed = (75..85).filter(|&x| up.map().get(CellCoord::new(x, 40)) == Some(CellState::Free)).count();
        assert!(freed >= 8, "the item's cells along the route are free: {freed} of 10");
    }
}

/// While Lost persists, pose updating is retried at most every `retry_interval_s`.
#[test]
fn pose_updating_is_retried_at_a_bounded_rate() {
    let world = room(6.0, 6.0, 0.05);
    let robot = Pose2::new(3.0, 3.0, 0.1);
    let wrong = Pose2::new(1.8, 4.0, 0.9);
    let params = UpdaterParams {
        pose_updating: mapkeeper_updater::PoseUpdatingParams {
            search_radius_m: 0.0,
            ..UpdaterParams::paper().pose_updating
        },
        ..UpdaterParams::paper()
    };
    let mut up = MapUpdater::new(world.clone(), params).unwrap();
    let mut attempts = Vec::new();
    for k in 0..20u64 {
        let r = up.process(wrong, robot, &[scan360(&world, robot, k * 100_000_000)]);
        assert_eq!(r.verdict, Some(Verdict::Lost));
        if let Some(rec) = r.pose_recovery {
            assert!(!matches!(rec, PoseRecovery::Recovered { .. }), "the search is off: {rec:?}");
            attempts.push(k);
        }
    }
    // 0.1 s apart, one attempt per 0.5 s: steps 0, 5, 10, 15.
    assert_eq!(attempts, vec![0, 5, 10, 15]);
    assert_eq!(up.stats().failed_recoveries, 4);
}
