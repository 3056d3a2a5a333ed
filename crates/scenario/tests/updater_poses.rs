//! The updater's pose source in the closed loop (`RunnerParams::updater_poses`): with `true`
//! the updater is given the simulator's true pose at every step while the chain localiser and
//! the baseline run as ever; with `true+noise` the poses it is given are off the truth by noise
//! of the asked spread; the same seed gives the same noise.

use mapkeeper_closed_loop::{NoClock, PoseNoise, RunInputs, RunnerParams, UpdaterPoses, WorldRun, run_world};
use mapkeeper_grid::angle_diff;
use mapkeeper_scenario::ValidationParams;
use mapkeeper_sim::{World, ground_truth_map};

/// A 20 m drive of the default tour on the world's own map, trajectories recorded (their
/// "chain" track is the pose the updater was given at each step).
fn run(poses: UpdaterPoses) -> WorldRun {
    let world = World::default_warehouse();
    let g = ground_truth_map(&world, &world.default_map_geometry(0.05).expect("geometry"));
    let route = ValidationParams::short_route(20.0);
    let p = RunnerParams { record_trajectories: true, updater_poses: poses, ..RunnerParams::default() };
    let inputs = RunInputs { world: &world, route: &route, prev_map: &g, baseline_map: &g, prev_memory: None };
    run_world(&inputs, &p, 4, "poses-test", &NoClock).expect("run")
}

/// Per step: the given pose minus the truth, (x, y, yaw).
fn given_minus_truth(run: &WorldRun) -> Vec<(f64, f64, f64)> {
    let t = run.trajectories.as_ref().expect("trajectories");
    assert_eq!(t.truth.len(), t.chain.len());
    assert!(t.truth.len() > 150, "{} steps", t.truth.len());
    t.chain
        .iter()
        .zip(&t.truth)
        .map(|(g, t)| {
            assert_eq!(g.stamp_ns, t.stamp_ns);
            (g.pose.x - t.pose.x, g.pose.y - t.pose.y, angle_diff(g.pose.yaw, t.pose.yaw))
        })
        .collect()
}

fn sd(v: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = v.clone().count() as f64;
    let m = v.clone().sum::<f64>() / n;
    (v.map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt()
}

#[test]
fn true_poses_reach_the_updater_and_the_localisers_run_as_ever() {
    let base = run(UpdaterPoses::Localiser);
    let oracle = run(UpdaterPoses::True);
    assert!(given_minus_truth(&oracle).iter().all(|&d| d == (0.0, 0.0, 0.0)), "the updater got the truth");
    let given = oracle.given_pose.expect("scored");
    assert!(given.steps > 100 && given.rmse_m == 0.0 && given.yaw_rmse_rad == 0.0, "{given:?}");
    assert_eq!(base.given_pose, None, "nothing to score with the localiser");
    assert!(oracle.route_done && oracle.updater.processed > 100, "{:?}", oracle.updater);
    assert_eq!(oracle.updater.lost, 0, "no Lost at true poses on the world's own map");
    // No recovered pose re-initialised the chain localiser in either run, so it and the baseline
    // ran exactly as with the localiser feeding the updater (the robot drove the same).
    assert_eq!((base.lost.recoveries, oracle.lost.recoveries), (0, 0));
    assert_eq!(oracle.chain, base.chain);
    assert_eq!(oracle.baseline, base.baseline);
    assert_eq!(oracle.chain_errors, base.chain_errors);
    assert!(oracle.chain.mean_error_m > 0.0, "the chain localiser's own error is still reported");
    let base_t = base.trajectories.as_ref().expect("trajectories");
    assert_eq!(oracle.trajectories.as_ref().expect("trajectories").truth, base_t.truth);
}

#[test]
fn noisy_true_poses_are_off_the_truth_by_the_asked_spread_and_repeat_with_the_seed() {
    let noise = PoseNoise {
        sigma_xy_m: 0.05,
        sigma_yaw_rad: 2f64.to_radians(),
        yaw_bias_sigma_rad: 0.0,
        ..PoseNoise::default()
    };
    let noisy = run(UpdaterPoses::TrueNoise(noise));
    let d = given_minus_truth(&noisy);
    let n = d.len() as f64;
    // A few hundred samples: a sample standard deviation within 15 % of σ (≈ 4 standard errors).
    for (name, s, sigma) in [
        ("x", sd(d.iter().map(|v| v.0)), noise.sigma_xy_m),
        ("y", sd(d.iter().map(|v| v.1)), noise.sigma_xy_m),
        ("yaw", sd(d.iter().map(|v| v.2)), noise.sigma_yaw_rad),
    ] {
        assert!((s / sigma - 1.0).abs() < 0.15, "{name}: sample sd {s} over {n} steps, σ {sigma}");
    }
    let given = noisy.given_pose.expect("scored");
    let want = noise.sigma_xy_m * 2f64.sqrt();
    assert!((given.rmse_m / want - 1.0).abs() < 0.15, "RMSE {} m, √2 σ = {want} m", given.rmse_m);
    // A slow yaw bias: the yaw error's mean wanders with it, here far from 0 for a while.
    let biased = PoseNoise { sigma_xy_m: 0.0, sigma_yaw_rad: 0.0, yaw_bias_sigma_rad: 0.05, yaw_bias_tau_s: 1000.0 };
    let b = given_minus_truth(&run(UpdaterPoses::TrueNoise(biased)));
    let lag1 = b.windows(2).map(|w| (w[1].2 - w[0].2).abs()).fold(0.0, f64::max);
    assert!(lag1 < 0.01 && b.iter().any(|v| v.2 != 0.0), "a slowly varying bias (largest step {lag1} rad)");
    // The same seed, the same noise, bit for bit.
    let again = run(UpdaterPoses::TrueNoise(noise));
    assert_eq!(again.trajectories, noisy.trajectories);
    assert_eq!(again.map, noisy.map);
}
