//! Time per processed dual-S300 step (2 × 541 beams) with the `paper` preset in a map of the
//! default warehouse size (280 × 418 cells at 0.05 m, walls and a dozen box outlines), with ten
//! boxes changed between `M_{i-1}` and the current world (scans synthesised by ray casting the
//! current world). Also prints the updater's state bytes after 10,000 processed scans.
//!
//! Run: `CARGO_TARGET_DIR=/work/target-updater cargo bench -p mapkeeper-updater --bench update_step`
#![allow(missing_docs, clippy::unwrap_used)]

#[path = "../tests/common/mod.rs"]
mod common;

use common::{fill_rect, room, s300_pair};
use criterion::{Criterion, criterion_group, criterion_main};
use mapkeeper_grid::{CellState, OccupancyGrid, Pose2};
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, UpdaterParams};
use std::hint::black_box;

/// A box outline (occupied border, unknown inside), as a SLAM map draws it.
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

fn bench(c: &mut Criterion) {
    let (map, world) = warehouse();
    let poses = route();
    let scans: Vec<Vec<LaserScan>> =
        poses.iter().enumerate().map(|(k, p)| s300_pair(&world, *p, k as u64 * 80_000_000)).collect();
    let mut up = MapUpdater::new(map.clone(), UpdaterParams::paper()).unwrap();
    // Warm up over one lap so that the map already holds changes, as in a long run.
    for (p, s) in poses.iter().zip(&scans) {
        up.process(*p, *p, s);
    }
    let mut k = 0usize;
    c.bench_function("paper preset, dual S300 step (1082 beams), 280x418 map, 10 boxes changed", |b| {
        b.iter(|| {
            k = (k + 1) % poses.len();
            black_box(up.process(poses[k], poses[k], &scans[k]))
        })
    });

    // State bytes after 10,000 processed scans.
    let mut up = MapUpdater::new(map, UpdaterParams::paper()).unwrap();
    let mut processed = 0;
    let mut k = 0;
    while processed < 10_000 {
        let r = up.process(poses[k], poses[k], &scans[k]);
        if r.verdict.is_some() {
            processed += 1;
        }
        k = (k + 1) % poses.len();
    }
    let s = up.stats();
    println!(
        "after {processed} processed scans: state_bytes = {}, scratch_bytes = {}, buffered cells = {}, \
         verdicts update/suspend/lost = {}/{}/{}, cell changes = {}",
        up.state_bytes(),
        up.scratch_bytes(),
        up.buffered_cells(),
        s.updates,
        s.suspends,
        s.losts,
        s.cell_changes
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
