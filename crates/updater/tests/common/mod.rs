//! Shared helpers of the updater's integration tests and benchmark: hand-made worlds and scans
//! synthesised by ray casting a "current world" grid.
#![allow(dead_code, clippy::unwrap_used)]

pub mod bench_scene;
pub mod digest;

use mapkeeper_grid::{OccupancyGrid, Pose2, RayStop, cast_ray};
use mapkeeper_sensor::LaserScan;
/// The room of these tests, `room(w_m, h_m, res)`: one-cell walls on the border of the grid it
/// fills (`mapkeeper_testkit::rooms::walled`); and furniture set by metre.
pub use mapkeeper_testkit::rooms::{fill_rect, walled as room};

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
