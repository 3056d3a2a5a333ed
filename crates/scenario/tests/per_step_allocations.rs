//! Nothing map-sized is built per step (issue 29 item 1). Map-sized work (the updater's and the
//! localisers' fields of M_{i-1}, the fresh map's grid, the metrics) belongs to the start and the
//! end of a world: once a run is under way, no step's allocations on all its threads (the loop,
//! the baseline localiser, the fresh map) add up to half a map's cells at a byte each.
//! With the simulator run ahead, each step also keeps one copy of the simulator (to rewind to),
//! and nothing else. The global allocator counts (`stats_alloc`); an observer reads it at the 30th
//! step and at the 90th.
#![allow(clippy::unwrap_used)]

use mapkeeper_closed_loop::{Execution, RunInputs, RunOptions, RunnerParams, run_world_with};
use mapkeeper_harness::{NoClock, Observer, Session, SessionStep, Step};
use mapkeeper_localiser::FilterParams;
use mapkeeper_scenario::ValidationParams;
use mapkeeper_sim::{Simulator, World, ground_truth_map};
use stats_alloc::{INSTRUMENTED_SYSTEM, Region, Stats, StatsAlloc};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

/// The allocator's counts at step `from` and at step `to`, and the most bytes any one step in
/// between allocated.
struct Window {
    k: usize,
    from: usize,
    to: usize,
    start: Option<Stats>,
    end: Option<Stats>,
    last: Option<Stats>,
    most_in_a_step: usize,
}

/// Bytes allocated from `a` to `b`, reallocations counted at their growth.
fn bytes_between(a: &Stats, b: &Stats) -> usize {
    let grown = (b.bytes_reallocated - a.bytes_reallocated).max(0).unsigned_abs();
    b.bytes_allocated - a.bytes_allocated + grown
}

impl Observer for Window {
    fn on_step(&mut self, _step: &Step, _report: &SessionStep, _session: &Session<'_>) {
        self.k += 1;
        if !(self.from..=self.to).contains(&self.k) {
            return;
        }
        let now = GLOBAL.stats();
        if let Some(last) = &self.last {
            self.most_in_a_step = self.most_in_a_step.max(bytes_between(last, &now));
        }
        if self.k == self.from {
            self.start = Some(now);
        }
        if self.k == self.to {
            self.end = Some(now);
        }
        self.last = Some(now);
    }
}

/// Blocks and bytes allocated from the window's start to its end, and the most bytes in one
/// step, running one world with `p`.
fn window_allocations(inputs: &RunInputs<'_>, p: &RunnerParams, options: RunOptions) -> (usize, usize, usize) {
    let mut window = Window { k: 0, from: 30, to: 90, start: None, end: None, last: None, most_in_a_step: 0 };
    let exec = Execution { options, clock: &NoClock };
    let run = run_world_with(inputs, p.checked().unwrap(), 5, "W002", &exec, &mut [&mut window]).unwrap();
    assert!(run.updater.processed > 60, "the updater should have worked through the window");
    let (Some(a), Some(b)) = (window.start, window.end) else {
        panic!("the route should last past the window ({} steps)", window.k);
    };
    let blocks = (b.allocations + b.reallocations) - (a.allocations + a.reallocations);
    (blocks, bytes_between(&a, &b), window.most_in_a_step)
}

#[test]
fn no_map_sized_allocation_while_a_world_runs() {
    let world = World::default_warehouse();
    let map = ground_truth_map(&world, &world.default_map_geometry(0.05).unwrap());
    let route = ValidationParams::short_route(12.0);
    let inputs = RunInputs { world: &world, route: &route, prev_map: &map, baseline_map: &map, prev_memory: None };
    // The validation's run: the `mapkeeper` updater, the `amcl` localiser, the fresh map, the
    // baseline and the fresh map on threads of their own.
    let mut p = ValidationParams::new(2, "mapkeeper").unwrap().runner;
    p.filter = FilterParams::amcl();
    let mut options = RunOptions::default();
    assert!(options.parallel_baseline && options.parallel_fresh_map && p.fresh_map.is_some());
    // A map's cells at one byte a cell (the smallest of the per-cell arrays: states; the fields
    // and log-odds take four bytes a cell).
    let cells = map.geometry().width() * map.geometry().height();

    // Everything in order (the simulator not ahead: the default validation's six runs).
    let (blocks, bytes, most) = window_allocations(&inputs, &p, options);
    println!("60 steps: {blocks} blocks, {bytes} bytes, at most {most} in a step; the map has {cells} cells");
    // The count works: a step allocates (its scans, and their copies for the other threads).
    assert!(blocks > 60 && bytes > 0 && most > 0, "{blocks} blocks, {bytes} bytes");
    assert!(most < cells / 2, "{most} bytes allocated in one step: a map has {cells} cells");

    // The simulator ahead (a single run): one copy of the simulator a step on top.
    let mut sim = Simulator::new(&world, p.sim.clone(), 5).unwrap();
    sim.set_route(route.points());
    for _ in 0..30 {
        sim.step();
    }
    let copy = Region::new(GLOBAL);
    let twin = sim.clone();
    let c = copy.change();
    drop(twin);
    let copy_bytes = c.bytes_allocated;
    options.simulate_ahead = true;
    let (blocks_ahead, bytes_ahead, _) = window_allocations(&inputs, &p, options);
    println!("ahead: {blocks_ahead} blocks, {bytes_ahead} bytes; a copy of the simulator {copy_bytes} bytes");
    let extra = bytes_ahead.saturating_sub(bytes);
    assert!(
        extra <= 60 * copy_bytes + cells,
        "{extra} bytes more in 60 steps with the simulator ahead, one copy being {copy_bytes} bytes"
    );
}
