//! Mean CPU time per processed step (from /proc/thread-self/schedstat, so it is not inflated by
//! a loaded machine), same scenario as benches/update_step.rs, and the output digests that
//! tests/output_digest.rs pins. Linux only.
//!
//! Run: `cargo run --release -p mapkeeper-updater --example cpu_time [-- [--laps N] [--no-digest] [PRESET ...]]`
//! (default: 5 laps of `paper`, `no-update` and `log-odds`).
//!
//! Instructions per step under callgrind (only the measured laps are counted):
//! `valgrind --tool=callgrind --toggle-collect='cpu_time::measured_step' \
//!  $CARGO_TARGET_DIR/release/examples/cpu_time --laps 1 --no-digest paper`, then
//! Ir divided by the measured steps it reports (632 per lap).
#![allow(missing_docs, clippy::unwrap_used)]
#[path = "../tests/common/mod.rs"]
mod common;
use common::bench_scene::{route, warehouse};
use common::digest::{SCENARIOS, scenario_digest};
use common::s300_pair;
use mapkeeper_grid::Pose2;
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, StepReport, UpdaterParams};

fn cpu_ns() -> u64 {
    std::fs::read_to_string("/proc/thread-self/schedstat").unwrap().split_whitespace().next().unwrap().parse().unwrap()
}

/// One measured step (a separate symbol, so that callgrind can count it alone).
#[inline(never)]
fn measured_step(up: &mut MapUpdater, pose: Pose2, scans: &[LaserScan]) -> StepReport {
    up.process(pose, pose, scans)
}

fn main() {
    let mut laps = 5;
    let mut digest = true;
    let mut presets = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--laps" => laps = args.next().and_then(|n| n.parse().ok()).expect("--laps N"),
            "--no-digest" => digest = false,
            _ => presets.push(a),
        }
    }
    if presets.is_empty() {
        presets = vec!["paper".into(), "no-update".into(), "log-odds".into()];
    }
    let (map, world) = warehouse();
    let poses = route();
    let scans: Vec<Vec<LaserScan>> =
        poses.iter().enumerate().map(|(k, p)| s300_pair(&world, *p, k as u64 * 80_000_000)).collect();
    for name in &presets {
        let mut up = MapUpdater::new(map.clone(), UpdaterParams::preset(name).unwrap()).unwrap();
        for (p, s) in poses.iter().zip(&scans) {
            up.process(*p, *p, s);
        }
        let t = cpu_ns();
        for _ in 0..laps {
            for (p, s) in poses.iter().zip(&scans) {
                std::hint::black_box(measured_step(&mut up, *p, s));
            }
        }
        let steps = laps * poses.len();
        let ms = (cpu_ns() - t) as f64 / 1e6 / steps as f64;
        println!(
            "{name}: mean CPU time per processed step {ms:.3} ms over {steps} steps; change_state_bytes {}, \
             cache_bytes {}",
            up.change_state_bytes(),
            up.cache_bytes()
        );
    }
    if digest {
        for s in &SCENARIOS {
            let (d, processed) = scenario_digest(s);
            println!("digest {}: {d:#018x} ({processed} processed)", s.name);
        }
    }
}
