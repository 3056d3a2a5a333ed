//! Determinism contract: the same seed gives bit-identical summaries (wall time and timings
//! are not measured here: no clock) and maps, whatever the number of threads running seeds;
//! and a summary recomputed from the seeds' records read back from `runs.json` (in any
//! grouping of seeds, as `mapkeeper merge` does) is the very same summary.
//!
//! The CLI-level twin (`crates/cli/tests/validate_cli.rs`) runs the binary twice and compares
//! the folders, and merges shards.

use mapkeeper_closed_loop::NoClock;
use mapkeeper_scenario::experiments::validation::report::{runs_json, summary_json, worlds_csv};
use mapkeeper_scenario::{
    SeedRun, Shard, ValidationParams, ValidationRecord, ValidationRun, run_seed, summarise, summarise_records,
};
use rayon::prelude::*;

fn params() -> ValidationParams {
    let mut p = ValidationParams::new(3, "paper").expect("valid params");
    p.route = ValidationParams::short_route(12.0);
    p.exploration_route = ValidationParams::short_route(20.0);
    p.saved_worlds = vec![2, 3];
    p
}

fn run_on(threads: usize, seeds: &[u64]) -> Vec<SeedRun> {
    let p = params();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
    let given = ValidationRun::timed_by(&NoClock);
    pool.install(|| seeds.par_iter().map(|&s| run_seed(&p, s, &given, &|_| {}).expect("run")).collect())
}

#[test]
fn same_seed_same_summary_and_maps_on_one_and_two_threads() {
    let p = params();
    let a = run_on(1, &[5, 6]);
    let b = run_on(2, &[5, 6]);
    let (sa, sb) = (summarise(&p, &a, 0.0), summarise(&p, &b, 0.0));
    assert_eq!(summary_json(&sa).unwrap(), summary_json(&sb).unwrap());
    let records = |r: &[SeedRun]| r.iter().map(SeedRun::record).collect::<Vec<_>>();
    assert_eq!(worlds_csv(&records(&a)), worlds_csv(&records(&b)));
    // The simulator run ahead of the estimators on a thread of its own: the same seeds.
    let pa = params();
    let mut ahead = ValidationRun::timed_by(&NoClock);
    ahead.exec.options.simulate_ahead = true;
    let c: Vec<SeedRun> = [5, 6].iter().map(|&s| run_seed(&pa, s, &ahead, &|_| {}).expect("run")).collect();
    assert_eq!(summary_json(&summarise(&pa, &c, 0.0)).unwrap(), summary_json(&sa).unwrap());
    assert_eq!(worlds_csv(&records(&c)), worlds_csv(&records(&a)));
    for (ra, rc) in a.iter().zip(&c) {
        assert_eq!(ra.saved, rc.saved, "seed {}: saved worlds differ with the simulator ahead", ra.seed);
    }
    for (ra, rb) in a.iter().zip(&b) {
        assert_eq!(ra.initial_map, rb.initial_map);
        assert_eq!(ra.saved.len(), 2);
        for (wa, wb) in ra.saved.iter().zip(&rb.saved) {
            assert_eq!(wa.map, wb.map, "M_{} differs", wa.world);
            assert_eq!(wa.trajectories, wb.trajectories);
        }
    }
    // Different seeds differ.
    assert_ne!(a[0].rows[0].loc_updated, a[1].rows[0].loc_updated);

    // The records survive runs.json exactly, and give the same summary, whole or in shards.
    let whole = ValidationRecord::new(&p, &a, false, 0.0, None);
    let back: ValidationRecord = serde_json::from_str(&runs_json(&whole).unwrap()).unwrap();
    assert_eq!(back, whole, "runs.json does not round-trip");
    assert_eq!(back.summary(), sa);
    let shard = |k| ValidationRecord::new(&p, &a[k - 1..k], false, 0.0, Some(Shard { index: k as u64, count: 2 }));
    let (s1, s2) = (shard(1), shard(2));
    // Shards read in any order, put in seed order (as `merge` does).
    let mut sorted: Vec<_> = s2.seeds.iter().chain(&s1.seeds).cloned().collect();
    sorted.sort_by_key(|r| r.seed);
    assert_eq!(summary_json(&summarise_records(&p, &sorted, 0.0)).unwrap(), summary_json(&sa).unwrap());
}

#[test]
fn baseline_and_fresh_map_on_threads_of_their_own_give_the_same_run() {
    use mapkeeper_closed_loop::{Execution, RunInputs, RunnerParams, run_world, run_world_with};
    use mapkeeper_sim::{World, ground_truth_map};
    let world = World::default_warehouse();
    let g = ground_truth_map(&world, &world.default_map_geometry(0.05).unwrap());
    let route = ValidationParams::short_route(8.0);
    let inputs = RunInputs { world: &world, route: &route, prev_map: &g, baseline_map: &g, prev_memory: None };
    let fresh_map = ValidationParams::default().runner.fresh_map;
    assert!(fresh_map.is_some(), "the validation makes a fresh map");
    let p = RunnerParams { record_trajectories: true, fresh_map, ..RunnerParams::default() };
    let mut exec = Execution::timed_by(&NoClock);
    assert!(exec.options.parallel_baseline && exec.options.parallel_fresh_map, "threads by default");
    let a = run_world(&inputs, &p, 9, "W002", &NoClock).unwrap();
    exec.options.parallel_baseline = false;
    let b = run_world_with(&inputs, p.checked().unwrap(), 9, "W002", &exec, &mut []).unwrap();
    exec.options.parallel_fresh_map = false;
    let c = run_world_with(&inputs, p.checked().unwrap(), 9, "W002", &exec, &mut []).unwrap();
    assert_eq!(a, b);
    assert_eq!(a, c);
    assert!(a.baseline.updates > 0);
    let fresh = a.fresh_map.as_ref().expect("a fresh map");
    assert!(fresh.count(mapkeeper_grid::CellState::Occupied) > 0);
}
