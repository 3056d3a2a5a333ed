//! Degenerate maps through the estimators' public APIs (the localiser, and the map updater,
//! which is a dev-dependency here so that this crate's tests can run both): a one-cell map, and
//! maps that are all unknown, all occupied or all free. Each gives a clear error or the
//! documented behaviour of `docs/reliability.md` ("Degenerate worlds and maps"), never a panic,
//! a NaN or a hang.

use mapkeeper_grid::{CellState, GridGeometry, OccupancyGrid, Pose2};
use mapkeeper_localiser::{FilterParams, Localiser, LocaliserError, UpdateOutcome};
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, StepOutcome, UpdaterParams};

fn filled(w: usize, h: usize, state: CellState) -> OccupancyGrid {
    OccupancyGrid::filled(GridGeometry::new(w, h, 0.05, Pose2::IDENTITY).expect("geometry"), state)
}

fn small_filter() -> FilterParams {
    FilterParams { min_particles: 50, max_particles: 100, ..FilterParams::default() }
}

/// A 360° scan with every reading `range_m`.
fn scan(range_m: f32, stamp_ns: u64) -> LaserScan {
    let inc = std::f64::consts::TAU / 360.0;
    LaserScan {
        stamp_ns,
        lidar_id: 0,
        lidar_in_robot: Pose2::IDENTITY,
        angle_min_rad: -std::f64::consts::PI,
        angle_increment_rad: inc,
        range_min_m: 0.05,
        range_max_m: 30.0,
        ranges_m: vec![range_m; 360],
        sweep: None,
    }
}

#[test]
fn localiser_refuses_maps_without_free_space() {
    for state in [CellState::Occupied, CellState::Unknown] {
        for (w, h) in [(1, 1), (60, 40)] {
            let e = Localiser::new(&filled(w, h, state), small_filter(), 1).expect_err("no free cell");
            assert_eq!(e, LocaliserError::NoFreeSpace, "{state:?} {w}x{h}");
        }
    }
}

#[test]
fn localiser_on_a_one_cell_free_map_tracks_without_nan() {
    let map = filled(1, 1, CellState::Free);
    let mut loc = Localiser::new(&map, small_filter(), 1).expect("one free cell is enough");
    // Scans that see nothing (no return) and scans that see a wall that is not in the map.
    for k in 0..20u64 {
        let r = if k % 2 == 0 { f32::INFINITY } else { 1.0 };
        let odom = Pose2::new(0.01 * k as f64, 0.0, 0.0);
        let report = loc.update(odom, &[scan(r, k * 80_000_000)]);
        assert!(report.estimate.pose_in_map.is_finite(), "{report:?}");
        assert!(!matches!(report.outcome, UpdateOutcome::InvalidOdometry));
    }
    assert!(loc.weights().iter().all(|w| w.is_finite()));
}

#[test]
fn localiser_set_map_to_an_all_occupied_map_keeps_running() {
    // The map handed over by the updater may lose its free space; the filter keeps its particles.
    let mut loc = Localiser::new(&filled(60, 40, CellState::Free), small_filter(), 1).expect("free map");
    loc.set_map(&filled(60, 40, CellState::Occupied));
    let report = loc.update(Pose2::new(0.5, 0.5, 0.0), &[scan(0.5, 0)]);
    assert!(report.estimate.pose_in_map.is_finite(), "{report:?}");
    assert_eq!(loc.init_global(), Err(LocaliserError::NoFreeSpace), "and says so when asked to spread");
}

#[test]
fn updater_on_one_cell_and_uniform_maps_never_panics() {
    let maps = [
        filled(1, 1, CellState::Free),
        filled(1, 1, CellState::Occupied),
        filled(1, 1, CellState::Unknown),
        filled(60, 40, CellState::Unknown),
        filled(60, 40, CellState::Occupied),
        filled(60, 40, CellState::Free),
    ];
    for map in maps {
        let cells = map.cells().len();
        for params in [UpdaterParams::paper(), UpdaterParams::always_update(), UpdaterParams::log_odds()] {
            let mut up = MapUpdater::new(map.clone(), params).expect("any non-empty map is accepted");
            // 6 cm a step (past the 5 cm gate), readings cycling through valid and invalid.
            for k in 0..32u64 {
                let pose = Pose2::new(0.02 + 0.06 * k as f64, 0.02, 0.1 * k as f64);
                let r = [0.5, f32::INFINITY, f32::NAN, 0.0][k as usize % 4];
                let report = up.process(pose, pose, &[scan(r, k * 80_000_000)]);
                if r != 0.5 {
                    // No valid beam: skipped and counted, never a crash.
                    assert_eq!(report.outcome, StepOutcome::NoValidBeams, "{report:?}");
                }
            }
            assert_eq!(up.map().cells().len(), cells);
            let st = up.stats();
            assert!(st.skipped_no_valid_beam > 0, "{st:?}");
        }
    }
}
