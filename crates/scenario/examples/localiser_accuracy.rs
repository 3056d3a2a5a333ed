//! The localiser accuracy table (issue 4): default warehouse, noisy dual S300, default route,
//! map = ground truth G, 10 seeds; tracking from 0.1 m / 3° and convergence from 0.5 m and
//! 0.7 m. `cargo run --release -p mapkeeper-scenario --example localiser_accuracy`.

use mapkeeper_closed_loop::{NoClock, RunInputs, RunnerParams, WorldRun, run_world};
use mapkeeper_sim::{Route, World, ground_truth_map};

fn run(world: &World, g: &mapkeeper_grid::OccupancyGrid, err: f64, yaw_deg: f64, seed: u64) -> WorldRun {
    let p = RunnerParams {
        start_error_m: err,
        start_error_yaw_rad: yaw_deg.to_radians(),
        init_sigma_xy_m: err.max(0.1),
        init_sigma_yaw_rad: yaw_deg.to_radians().max(0.05),
        run_updater: false,
        run_baseline: false,
        ..RunnerParams::default()
    };
    let route = Route::default_warehouse();
    let inputs = RunInputs { world, route: &route, prev_map: g, baseline_map: g, prev_memory: None };
    match run_world(&inputs, &p, seed, "accuracy", &NoClock) {
        Ok(r) => r,
        Err(e) => panic!("seed {seed}: {e}"),
    }
}

fn main() {
    let world = World::default_warehouse();
    let geometry = match world.default_map_geometry(0.05) {
        Ok(g) => g,
        Err(e) => panic!("{e}"),
    };
    let g = ground_truth_map(&world, &geometry);
    println!("route {:.1} m; map = G; start error 0.1 m / 3°", Route::default_warehouse().length_m());
    println!("| seed | updates | pos RMSE (m) | pos max (m) | yaw RMSE (°) |");
    println!("|---|---|---|---|---|");
    let (mut rm, mut ry, mut wm, mut wy) = (0.0, 0.0, 0.0f64, 0.0f64);
    for seed in 1..=10u64 {
        let r = run(&world, &g, 0.1, 3.0, seed);
        let y = r.chain.yaw_rmse_rad.to_degrees();
        println!("| {seed} | {} | {:.4} | {:.4} | {:.3} |", r.chain.updates, r.chain.rmse_m, r.chain.max_error_m, y);
        rm += r.chain.rmse_m / 10.0;
        ry += y / 10.0;
        wm = wm.max(r.chain.rmse_m);
        wy = wy.max(y);
    }
    println!("| mean | | {rm:.4} | | {ry:.3} |");
    println!("| worst | | {wm:.4} | | {wy:.3} |");
    println!();
    println!("| start error | seed | travel to < 0.1 m (m) | max error after 5 m (m) |");
    println!("|---|---|---|---|");
    for err in [0.5, 0.7] {
        for seed in 1..=10u64 {
            let r = run(&world, &g, err, 5.0, seed);
            let conv = r.chain_errors.iter().find(|e| e.error_m < 0.1).map_or(f64::NAN, |e| e.distance_m);
            let after = r.chain_errors.iter().filter(|e| e.distance_m > 5.0).map(|e| e.error_m).fold(0.0, f64::max);
            println!("| {err} m | {seed} | {conv:.2} | {after:.3} |");
        }
    }
}
