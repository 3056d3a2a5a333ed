//! The warehouse scene of the update-step benchmark and the CPU-time example: a map of the
//! default warehouse's size with 12 box outlines, and a current world where 5 are gone and 5 new
//! ones appeared.
#![allow(dead_code)]

use super::{fill_rect, room};
use mapkeeper_grid::{CellState, OccupancyGrid, Pose2};

/// A box outline (occupied border, unknown inside), as a SLAM map draws it.
pub fn outline(m: &mut OccupancyGrid, x: f64, y: f64, w: f64, h: f64) {
    fill_rect(m, x, y, x + w, y + h, CellState::Occupied);
    fill_rect(m, x + 0.05, y + 0.05, x + w - 0.05, y + h - 0.05, CellState::Unknown);
}

pub fn box_positions() -> Vec<(f64, f64)> {
    let mut v = Vec::new();
    for row in 0..4 {
        for col in 0..3 {
            v.push((2.0 + col as f64 * 4.0, 2.5 + row as f64 * 4.5));
        }
    }
    v
}

/// (M_{i-1}, current world): 12 boxes in the map; in the world 5 are gone, 5 new ones appear.
pub fn warehouse() -> (OccupancyGrid, OccupancyGrid) {
    let mut map = room(14.0, 20.9, 0.05);
    let mut world = room(14.0, 20.9, 0.05);
    for (k, &(x, y)) in box_positions().iter().enumerate() {
        outline(&mut map, x, y, 1.2, 1.0);
        if k % 2 == 1 || k == 0 {
            // kept (7 of 12) ...
            fill_rect(&mut world, x, y, x + 1.2, y + 1.0, CellState::Occupied);
        } else {
            // ... 5 removed, and a new one nearby instead.
            fill_rect(&mut world, x + 1.5, y + 1.6, x + 2.1, y + 2.1, CellState::Occupied);
        }
    }
    (map, world)
}

/// A lap along the free aisle x = 1.0 m then back along x = 13.0 m, 6 cm per step.
pub fn route() -> Vec<Pose2> {
    let mut poses = Vec::new();
    let mut y = 1.0;
    while y < 19.9 {
        poses.push(Pose2::new(1.0, y, std::f64::consts::FRAC_PI_2));
        y += 0.06;
    }
    let mut y = 19.9;
    while y > 1.0 {
        poses.push(Pose2::new(13.0, y, -std::f64::consts::FRAC_PI_2));
        y -= 0.06;
    }
    poses
}
