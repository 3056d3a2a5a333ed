//! Simulator throughput in the default warehouse (release):
//! - `lidar/dual_s300_scan`: both S300s (2 × 541 rays) from a pose in the west aisle;
//!   rays/s = 1082 / time.
//! - `sim/one_simulated_second`: 50 physics steps at 50 Hz with 25 scans (both lidars at
//!   12.5 Hz), the route follower and five agents; simulated s per wall s = 1 / time.
//!
//! Run: `cargo bench -p mapkeeper-sim --bench sim`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mapkeeper_sim::{Route, SimParams, Simulator, World};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let world = World::default_warehouse();
    let mut g = c.benchmark_group("lidar");
    g.throughput(Throughput::Elements(2 * 541));
    let mut sim = Simulator::new(&world, SimParams::default(), 1).expect("default world");
    g.bench_function("dual_s300_scan", |b| b.iter(|| black_box(sim.scan_now())));
    g.finish();

    let mut g = c.benchmark_group("sim");
    g.throughput(Throughput::Elements(50));
    let mut sim = Simulator::new(&world, SimParams::default(), 2).expect("default world");
    let route = Route::default_warehouse().points();
    sim.set_route(route.clone());
    g.bench_function("one_simulated_second", |b| {
        b.iter(|| {
            for _ in 0..50 {
                let out = sim.step();
                if out.route_done {
                    sim.set_route(route.clone());
                }
                black_box(out);
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
