//! Times the pieces of one validation world (release build):
//! `cargo run --release -p mapkeeper-scenario --example one_world`.
#![allow(clippy::disallowed_methods)] // an example times itself; the libraries read no clock

use mapkeeper_closed_loop::{
    Clock, GeneratorParams, MappingParams, RunInputs, RunnerParams, build_initial_map, generate_worlds, run_world,
};
use mapkeeper_sim::{Route, SimParams, World, ground_truth_map};
use std::time::Instant;

struct Wall(Instant);
impl Clock for Wall {
    fn now_ns(&self) -> u64 {
        self.0.elapsed().as_nanos() as u64
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let w1 = World::default_warehouse();
    let route = Route::default_warehouse();
    let geometry = w1.default_map_geometry(0.05)?;
    let t = Instant::now();
    let chain = generate_worlds(&w1, &route, 3, 1, &GeneratorParams::default())?;
    println!("generate 3 worlds: {:.3} s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let m1 = build_initial_map(
        &w1,
        &Route::exploration_warehouse(),
        &geometry,
        &SimParams::default(),
        &MappingParams::default(),
        1,
    )?;
    println!("M_1: {:.3} s ({} scans, {:.1} s simulated)", t.elapsed().as_secs_f64(), m1.scans, m1.sim_time_s);
    let t = Instant::now();
    let g2 = ground_truth_map(&chain.worlds[1], &geometry);
    println!("G_2: {:.3} s", t.elapsed().as_secs_f64());
    let clock = Wall(Instant::now());
    for (label, upd, base) in [("sim only", false, false), ("sim+chain", false, true), ("full", true, true)] {
        let mut p = RunnerParams { run_updater: upd, run_baseline: base, ..RunnerParams::default() };
        if label == "sim only" {
            p.run_baseline = false;
        }
        let t = Instant::now();
        let inputs = RunInputs {
            world: &chain.worlds[1],
            route: &route,
            prev_map: &m1.map,
            baseline_map: &m1.map,
            prev_memory: None,
        };
        let r = run_world(&inputs, &p, 1, "W002", &clock)?;
        let wall = t.elapsed().as_secs_f64();
        println!(
            "{label}: {wall:.3} s wall, {:.1} s sim ({:.0}x), chain err mean {:.3} max {:.3}, base mean {:.3}, \
             verdicts U{} S{} L{}, cells changed {}, collisions {}, done {}",
            r.sim_time_s,
            r.sim_time_s / wall,
            r.chain.mean_error_m,
            r.chain.max_error_m,
            r.baseline.mean_error_m,
            r.updater.update,
            r.updater.suspend,
            r.updater.lost,
            r.cells_changed,
            r.collisions,
            r.route_done
        );
        if !r.scan_times_us.is_empty() {
            let mut v = r.scan_times_us.clone();
            v.sort_unstable();
            println!("  updater median {} us per processed scan ({} scans)", v[v.len() / 2], v.len());
        }
    }
    let _ = g2;
    Ok(())
}
