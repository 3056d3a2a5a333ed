//! Mean CPU time per processed step (from /proc/thread-self/schedstat, so it is not inflated by
//! a loaded machine), same scenario as benches/update_step.rs. Linux only.
//!
//! Run: `cargo run --release -p mapkeeper-updater --example cpu_time`
#![allow(missing_docs, clippy::unwrap_used)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::bench_scene::{route, warehouse};
use common::s300_pair;
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, UpdaterParams};
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
