//! Shared fixtures: a small asymmetric room, scans synthesised by ray casting from a true pose,
//! and a trajectory with drifting odometry.
#![allow(dead_code, clippy::unwrap_used)]

use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2, cast_ray};
use mapkeeper_sensor::LaserScan;
use std::f64::consts::PI;

/// An 8 m × 6 m room at 0.05 m (origin at (−1, −1)) with walls, a pillar, a box outline with an
/// unknown interior, and an L-shaped shelf, so no two poses look alike.
pub fn room() -> OccupancyGrid {
    let g = GridGeometry::new(160, 120, 0.05, Pose2::new(-1.0, -1.0, 0.0)).unwrap();
    let mut m = OccupancyGrid::filled(g, CellState::Free);
    let mut fill = |x0: i32, y0: i32, x1: i32, y1: i32, s: CellState| {
        for ix in x0..=x1 {
            for iy in y0..=y1 {
                m.set(CellCoord::new(ix, iy), s);
            }
        }
    };
    // Walls.
    fill(0, 0, 159, 1, CellState::Occupied);
    fill(0, 118, 159, 119, CellState::Occupied);
    fill(0, 0, 1, 119, CellState::Occupied);
    fill(158, 0, 159, 119, CellState::Occupied);
    // Pillar.
    fill(40, 80, 44, 84, CellState::Occupied);
    // Box outline with unknown interior.
    fill(100, 30, 119, 45, CellState::Occupied);
    fill(101, 31, 118, 44, CellState::Unknown);
    // L-shaped shelf.
    fill(60, 20, 61, 50, CellState::Occupied);
    fill(60, 20, 80, 21, CellState::Occupied);
    // A notch in the top wall.
    fill(120, 110, 125, 117, CellState::Occupied);
    m
}

/// Two lidars mounted like the Summit-XL's S300s: front-right facing −45°, rear-left facing
/// +135°, 270° each. `beams` per lidar.
pub fn mounts() -> [Pose2; 2] {
    [Pose2::new(0.2865, -0.2089, -PI / 4.0), Pose2::new(-0.2865, 0.2089, 3.0 * PI / 4.0)]
}

/// Scans of both lidars from `robot_in_map`, ranges from exact ray casts plus a deterministic
/// pseudo-noise of amplitude `noise_m` (a hash of the beam index and `salt`).
pub fn scans(
    map: &OccupancyGrid,
    robot_in_map: &Pose2,
    beams: usize,
    noise_m: f64,
    salt: u64,
    stamp_ns: u64,
) -> Vec<LaserScan> {
    let fov = 1.5 * PI;
    let inc = fov / (beams - 1) as f64;
    mounts()
        .iter()
        .enumerate()
        .map(|(id, mount)| {
            let lidar_in_map = robot_in_map.compose(mount);
            let ranges_m = (0..beams)
                .map(|i| {
                    let a = lidar_in_map.yaw - fov / 2.0 + i as f64 * inc;
                    let hit = cast_ray(map, lidar_in_map.position(), a, 30.0, true);
                    let mut h =
                        (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ salt.wrapping_mul(0xD1B5_4A32_D192_ED03);
                    h ^= h >> 29;
                    let u = (h % 10_000) as f64 / 10_000.0 - 0.5;
                    if hit.range_m >= 30.0 { f32::INFINITY } else { (hit.range_m + 2.0 * noise_m * u) as f32 }
                })
                .collect();
            LaserScan {
                stamp_ns,
                lidar_id: id as u32,
                lidar_in_robot: *mount,
                angle_min_rad: -fov / 2.0,
                angle_increment_rad: inc,
                range_min_m: 0.1,
                range_max_m: 30.0,
                ranges_m,
                sweep: None,
            }
        })
        .collect()
}

/// A loop through the room's free space: (true pose in map, odometry pose) every 0.1 m / few
/// degrees. Odometry drifts: +3 % in translation and +2 % in rotation, starting at the identity.
pub fn trajectory() -> Vec<(Pose2, Pose2)> {
    let waypoints = [(0.0, 0.0), (0.0, 2.2), (3.0, 2.2), (6.0, 2.2), (6.0, 0.0), (6.0, 3.8), (3.0, 3.8), (-0.2, 3.8)];
    let mut truth = Pose2::new(0.0, 0.0, PI / 2.0);
    let mut odom = Pose2::IDENTITY;
    let mut out = vec![(truth, odom)];
    for w in waypoints.iter().skip(1) {
        loop {
            let (dx, dy) = (w.0 - truth.x, w.1 - truth.y);
            let dist = dx.hypot(dy);
            if dist < 0.05 {
                break;
            }
            let heading = dy.atan2(dx);
            let turn = mapkeeper_grid::angle_diff(heading, truth.yaw).clamp(-0.15, 0.15);
            let step = if turn.abs() > 0.1 { 0.0 } else { dist.min(0.1) };
            let inc = Pose2::new(step, 0.0, turn);
            truth = truth.compose(&inc);
            odom = odom.compose(&Pose2::new(step * 1.03, 0.0, turn * 1.02));
            out.push((truth, odom));
        }
    }
    out
}
