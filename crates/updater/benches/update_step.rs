//! Time per processed dual-S300 step (2 × 541 beams) with the `paper` preset in a map of the
//! default warehouse size (280 × 418 cells at 0.05 m, walls and a dozen box outlines), with ten
//! boxes changed between `M_{i-1}` and the current world (scans synthesised by ray casting the
//! current world). Also prints the updater's state bytes after 10,000 processed scans.
//!
//! Run: `cargo bench -p mapkeeper-updater --bench update_step`
#![allow(missing_docs, clippy::unwrap_used)]

#[path = "../tests/common/mod.rs"]
mod common;

use common::bench_scene::{route, warehouse};
use common::s300_pair;
use criterion::{Criterion, criterion_group, criterion_main};
use mapkeeper_sensor::LaserScan;
use mapkeeper_updater::{MapUpdater, UpdaterParams};
use std::hint::black_box;

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
        "after {processed} processed scans: change_state_bytes = {}, cache_bytes = {}, scratch_bytes = {}, \
         buffered cells = {}, verdicts update/suspend/lost = {}/{}/{}, cell changes = {}",
        up.change_state_bytes(),
        up.cache_bytes(),
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
