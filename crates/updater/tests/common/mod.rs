//! Shared helpers of the updater's integration tests and benchmark: hand-made worlds and scans
//! synthesised by ray casting a "current world" grid.
#![allow(dead_code, clippy::unwrap_used)]

pub mod bench_scene;
pub mod digest;

use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2, RayStop, cast_ray};
use mapkeeper_sensor::LaserScan;

/// A `w_m` × `h_m` room at `res` with one-cell walls on its border, interior free, placed at the
/// lower-left of a grid of `cells_w` × `cells_h` cells (the rest free).
pub fn room_in(w_m: f64, h_m: f64, res: f64, cells_w: usize, cells_h: usize) -> OccupancyGrid {
    let g = GridGeometry::new(cells_w, cells_h, res, Pose2::IDENTITY).unwrap();
    let mut m = OccupancyGrid::filled(g, CellState::Free);
    let (nw, nh) = ((w_m / res).round() as i32, (h_m / res).round() as i32);
    for k in 0..nw {
        m.set(CellCoord::new(k, 0), CellState::Occupied);
        m.set(CellCoord::new(k, nh - 1), CellState::Occupied);
    }
    for k in 0..nh {
        m.set(CellCoord::new(0, k), CellState::Occupied);
        m.set(CellCoord::new(nw - 1, k), CellState::Occupied);
    }
    m
}

/// A room filling its grid.
pub fn room(w_m: f64, h_m: f64, res: f64) -> OccupancyGrid {
    room_in(w_m, h_m, res, (w_m / res).round() as usize, (h_m / res).round() as usize)
}

/// Sets every cell whose centre lies in [x0, x1) × [y0, y1) to `state`.
pub fn fill_rect(m: &mut OccupancyGrid, x0: f64, y0: f64, x1: f64, y1: f64, state: CellState) {
    let g = *m.geometry();
    for iy in 0..g.height() as i32 {
        for ix in 0..g.width() as i32 {
            let c = g.cell_center(CellCoord::new(ix, iy));
            if c.x >= x0 && c.x < x1 && c.y >= y0 && c.y < y1 {
                m.set(CellCoord::new(ix, iy), state);
            }
        }
    }
}

/// A synthetic lidar: its mounting pose on the robot and its beams.
#[derive(Clone, Copy, Debug)]
pub struct Lidar {
    /// Mounting pose on the robot.
    pub lidar_in_robot: Pose2,
    /// Angle of beam 0 in the lidar frame, radians.
    pub angle_min_rad: f64,
    /// Angle between consecutive beams, radians.
    pub increment_rad: f64,
    /// Number of beams.
    pub beams: usize,
    /// Maximum range, metres.
    pub range_max_m: f32,
}

impl Lidar {
    /// A lidar at the robot centre with `beams` beams `increment_rad` apart from `angle_min_rad`,
    /// range 30 m.
    pub fn centred(angle_min_rad: f64, increment_rad: f64, beams: usize) -> Self {
        Self { lidar_in_robot: Pose2::IDENTITY, angle_min_rad, increment_rad, beams, range_max_m: 30.0 }
    }
}

/// A scan of `world` by `lidar` on a robot at `robot`: each range is the ray-cast range plus
/// `bias_m` (so hit points land inside the hit cell), `+inf` for no hit.
pub fn synth_scan(world: &OccupancyGrid, robot: Pose2, lidar: &Lidar, stamp_ns: u64) -> LaserScan {
    let Lidar { lidar_in_robot, angle_min_rad, increment_rad, beams, range_max_m } = *lidar;
    let lidar = robot.compose(&lidar_in_robot);
    let bias_m = 0.005;
    let ranges_m = (0..beams)
        .map(|i| {
            let a = lidar.yaw + angle_min_rad + i as f64 * increment_rad;
            let hit = cast_ray(world, lidar.position(), a, range_max_m as f64, true);
            match hit.stop {
                RayStop::Occupied | RayStop::Unknown => (hit.range_m + bias_m) as f32,
                _ => f32::INFINITY,
            }
        })
        .collect();
    LaserScan {
        stamp_ns,
        lidar_id: 0,
        lidar_in_robot,
        angle_min_rad,
        angle_increment_rad: increment_rad,
        range_min_m: 0.05,
        range_max_m,
        ranges_m,
        sweep: None,
    }
}

/// One 360° scan at the robot centre, 0.5° apart.
pub fn scan360(world: &OccupancyGrid, robot: Pose2, stamp_ns: u64) -> LaserScan {
    let inc = std::f64::consts::PI / 360.0;
    synth_scan(world, robot, &Lidar::centred(-std::f64::consts::PI, inc, 720), stamp_ns)
}

/// The default robot's two SICK S300 (541 beams over 270°, 0.5°) at opposite corners.
pub fn s300_pair(world: &OccupancyGrid, robot: Pose2, stamp_ns: u64) -> Vec<LaserScan> {
    let inc = 0.5f64.to_radians();
    let half = 135f64.to_radians();
    let mounts = [Pose2::new(0.2865, -0.2089, -45f64.to_radians()), Pose2::new(-0.2865, 0.2089, 135f64.to_radians())];
    mounts
        .iter()
        .enumerate()
        .map(|(k, m)| {
            let lidar = Lidar { lidar_in_robot: *m, ..Lidar::centred(-half, inc, 541) };
            let mut s = synth_scan(world, robot, &lidar, stamp_ns);
            s.lidar_id = k as u32;
            s
        })
        .collect()
}
