//! Unit tests of `updater`.

use super::*;
use mapkeeper_grid::{CellState, cast_ray};
use mapkeeper_testkit::rooms::{fill_cells, walled_cells};

/// A 360° scan of `world` from `robot`, 1° apart, ranges 5 mm beyond the cast.
fn scan(world: &OccupancyGrid, robot: Pose2, stamp_ns: u64) -> LaserScan {
    let inc = 1f64.to_radians();
    let ranges_m = (0..360)
        .map(|i| (cast_ray(world, robot.position(), robot.yaw + i as f64 * inc, 30.0, true).range_m + 0.005) as f32)
        .collect();
    LaserScan {
        stamp_ns,
        lidar_id: 0,
        lidar_in_robot: Pose2::IDENTITY,
        angle_min_rad: 0.0,
        angle_increment_rad: inc,
        range_min_m: 0.05,
        range_max_m: 30.0,
        ranges_m,
        sweep: None,
    }
}

/// Runs 12 processed steps past a box that the map lacks; returns (cache, change state)
/// before and after.
fn run(w: usize, h: usize) -> ((usize, usize), (usize, usize)) {
    // A `w` × `h`-cell room at 0.05 m with one-cell walls on the map's edge.
    let map = walled_cells(w, h, 0.05, Pose2::IDENTITY);
    let mut world = map.clone();
    fill_cells(&mut world, 40..46, 30..36, CellState::Occupied);
    let mut up = MapUpdater::new(map, UpdaterParams::paper()).unwrap();
    let before = (up.cache_bytes(), up.change_state_bytes());
    for k in 0..12 {
        let robot = Pose2::new(1.0 + 0.06 * k as f64, 1.6, 0.0);
        let report = up.process(robot, robot, &[scan(&world, robot, k)]);
        assert_eq!(report.verdict, Some(Verdict::Update), "step {k}");
        // The documented figure, counted independently of `change_state_bytes`: the struct
        // plus a 4-byte key and an 8-byte ring per buffered cell and a 4-byte key and a
        // 40-byte mask per 16 × 16 tile holding a buffer (no memory, no log-odds array here).
        let tiles = up.buffers.tile_origins().count();
        assert!(tiles > 0 && tiles <= up.buffered_cells(), "step {k}: {tiles} tiles");
        let expected = size_of::<MapUpdater>() + (4 + 8) * up.buffered_cells() + (4 + 40) * tiles;
        assert_eq!(up.state_bytes(), expected, "step {k}");
    }
    assert!(up.buffered_cells() > 0);
    (before, (up.cache_bytes(), up.change_state_bytes()))
}

#[test]
fn cache_grows_with_the_map_change_state_with_touched_cells() {
    let (small_before, small_after) = run(80, 60);
    let (large_before, large_after) = run(160, 120);
    // Caches: proportional to the map's area, untouched by the scans.
    assert_eq!(large_before.0, 4 * small_before.0);
    assert_eq!(small_after.0, small_before.0);
    assert_eq!(large_after.0, large_before.0);
    assert_eq!(small_before.0, 7 * 80 * 60);
    // Change state: the struct alone at first, then grows with the buffered cells.
    assert_eq!(small_before.1, size_of::<MapUpdater>());
    assert_eq!(large_before.1, small_before.1);
    assert!(small_after.1 > small_before.1);
    assert!(large_after.1 > large_before.1);
}
