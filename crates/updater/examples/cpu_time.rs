//! Mean CPU time per processed step (from /proc/thread-self/schedstat, so it is not inflated by
//! a loaded machine), same scenario as benches/update_step.rs. Linux only.
//!
//! Run: `cargo run --release -p mapkeeper-updater --example cpu_time`
#![allow(missing_docs, clippy::unwrap_used)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::{fill_rect, room, s300_pair};
use mapkeeper_grid::{CellState, OccupancyGrid, Pose2};
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, UpdaterParams};
fn outline(m: &mut OccupancyGrid, x: f64, y: f64, w: f64, h: f64) {
    fill_rect(m, x, y, x + w, y + h, CellState::Occupied);
    fill_rect(m, x + 0.05, y + 0.05, x + w - 0.05, y + h - 0.05, CellState::Unknown);
}

fn box_positions() -> Vec<(f64, f64)> {
    let mut v = Vec::new();
    for row in 0..4 {
        for col in 0..3 {
            v.push((2.0 + col as f64 * 4.0, 2.5 + row as f64 * 4.5));
        }
    }
    v
}

/// (M_{i-1}, current world): 12 boxes in the map; in the world 5 are gone, 5 new ones appear.
fn warehouse() -> (OccupancyGrid, OccupancyGrid) {
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
fn route() -> Vec<Pose2> {
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
fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat").unwrap().split_whitespace().next().unwrap().parse().unwrap()
}
fn main() {
    let (map, world) = warehouse();
    let poses = route();
    let scans: Vec<Vec<LaserScan>> =
        poses.iter().enumerate().map(|(k, p)| s300_pair(&world, *p, k as u64 * 80_000_000)).collect();
    for name in ["paper", "no-update", "log-odds"] {
        let mut up = MapUpdater::new(map.clone(), UpdaterParams::preset(name).unwrap()).unwrap();
        for (p, s) in poses.iter().zip(&scans) {
            up.process(*p, *p, s);
        }
        let laps = 5;
        let t = cpu_ns();
        for _ in 0..laps {
            for (p, s) in poses.iter().zip(&scans) {
                std::hint::black_box(up.process(*p, *p, s));
            }
        }
        let steps = laps * poses.len();
        let ms = (cpu_ns() - t) as f64 / 1e6 / steps as f64;
        println!(
            "{name}: mean CPU time per processed step {ms:.3} ms over {steps} steps; state_bytes {}",
            up.state_bytes()
        );
    }
}
