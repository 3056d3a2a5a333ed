//! End-to-end localiser accuracy (issue 4): the default warehouse, the noisy dual S300, the map
//! is the world's ground truth G. Short routes and a few seeds keep it fast; the full 10-seed
//! table is `cargo run --release -p mapkeeper-scenario --example localiser_accuracy`.

use mapkeeper_closed_loop::{NoClock, RunInputs, RunnerParams, run_world};
use mapkeeper_scenario::ValidationParams;
use mapkeeper_sim::{World, ground_truth_map};

fn params(start_error_m: f64, start_yaw_deg: f64, sigma_xy_m: f64, sigma_yaw_rad: f64) -> RunnerParams {
    RunnerParams {
        start_error_m,
        start_error_yaw_rad: start_yaw_deg.to_radians(),
        init_sigma_xy_m: sigma_xy_m,
        init_sigma_yaw_rad: sigma_yaw_rad,
        run_updater: false,
        run_baseline: false,
        ..RunnerParams::default()
    }
}

#[test]
fn tracking_from_a_small_start_error_meets_5cm_and_1deg() {
    let world = World::default_warehouse();
    let g = ground_truth_map(&world, &world.default_map_geometry(0.05).unwrap());
    let route = ValidationParams::short_route(25.0);
    let p = params(0.1, 3.0, 0.1, 3f64.to_radians());
    for seed in [1, 2, 3] {
        let inputs = RunInputs { world: &world, route: &route, prev_map: &g, baseline_map: &g, prev_memory: None };
        let run = run_world(&inputs, &p, seed, "accuracy", &NoClock).unwrap();
        assert!(run.route_done, "seed {seed}: route not completed");
        assert!(run.chain.updates >= 50, "seed {seed}: only {} updates", run.chain.updates);
        let yaw_rmse_deg = run.chain.yaw_rmse_rad.to_degrees();
        assert!(run.chain.rmse_m <= 0.05, "seed {seed}: position RMSE {:.4} m", run.chain.rmse_m);
        assert!(yaw_rmse_deg <= 1.0, "seed {seed}: yaw RMSE {yaw_rmse_deg:.3}°");
    }
}

#[test]
fn converges_within_5m_from_half_and_0_7_metre_errors() {
    let world = World::default_warehouse();
    let g = ground_truth_map(&world, &world.default_map_geometry(0.05).unwrap());
    let route = ValidationParams::short_route(12.0);
    for (err, seed) in [(0.5, 4), (0.7, 5)] {
        let p = params(err, 5.0, err, 0.1);
        let inputs = RunInputs { world: &world, route: &route, prev_map: &g, baseline_map: &g, prev_memory: None };
        let run = run_world(&inputs, &p, seed, "convergence", &NoClock).unwrap();
        // Converged: below 0.1 m from some update within the first 5 m, and it stays there.
        let first = run.chain_errors.iter().position(|e| e.error_m < 0.1);
        let first = first.unwrap_or_else(|| panic!("{err} m: never below 0.1 m: {:?}", run.chain_errors));
        let at = run.chain_errors[first].distance_m;
        assert!(at <= 5.0, "{err} m start error: converged only after {at:.2} m");
        let after_5m: Vec<_> = run.chain_errors.iter().filter(|e| e.distance_m > 5.0).collect();
        assert!(!after_5m.is_empty());
        assert!(after_5m.iter().all(|e| e.error_m < 0.1), "{err} m: diverged again after 5 m");
    }
}
