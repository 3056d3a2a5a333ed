//! The four behaviours the `amcl` preset takes from ROS / Nav2 amcl (issue 27 item 7), each
//! against the `mapkeeper` choice it replaces: the per-axis update gate, one sensor update and
//! resampling per lidar, AMCL's multinomial KLD resampler, and the estimate read from the
//! resampled set.

#![allow(clippy::unwrap_used)]

mod common;

use mapkeeper_grid::{Pose2, angle_diff};
use mapkeeper_localiser::{
    Bins, ClusterScratch, EstimateFrom, FilterParams, LidarUpdates, Localiser, Resampler, UpdateGate, UpdateOutcome,
    best_cluster, kld_bound,
};

fn small(p: FilterParams) -> FilterParams {
    FilterParams { min_particles: 200, max_particles: 2000, ..p }
}

/// A filter at the first pose of the common trajectory, its first (forced) update done.
fn started(params: FilterParams, cov: f64) -> (Localiser, Pose2) {
    let map = common::room();
    let (truth, odom) = common::trajectory()[0];
    let mut f = Localiser::new(&map, params, 7).unwrap();
    f.init_pose(truth, [[cov, 0.0, 0.0], [0.0, cov, 0.0], [0.0, 0.0, cov / 10.0]]).unwrap();
    let r = f.update(odom, &common::scans(&map, &truth, 181, 0.01, 0, 0));
    assert_eq!(r.outcome, UpdateOutcome::Updated);
    (f, truth)
}

#[test]
fn the_per_axis_gate_waits_for_one_axis_to_pass_the_threshold() {
    let map = common::room();
    for (gate, diagonal_updates, straight_updates) in
        [(UpdateGate::Distance, true, true), (UpdateGate::AmclPerAxis, false, false)]
    {
        let params = small(FilterParams { update_gate: gate, ..FilterParams::amcl() });
        let (mut f, truth) = started(params, 0.01);
        // 0.18 m in x and in y: 0.25 m travelled, but neither axis beyond 0.2 m.
        let odom = Pose2::new(0.18, 0.18, 0.0);
        let r = f.update(odom, &common::scans(&map, &truth, 181, 0.01, 1, 1));
        assert_eq!(r.sensor_update, diagonal_updates, "{gate:?} diagonal");
        // Exactly 0.2 m along x from the last filter pose: `>=` passes, AMCL's `>` does not.
        let (mut f, truth) = started(params, 0.01);
        let r = f.update(Pose2::new(0.2, 0.0, 0.0), &common::scans(&map, &truth, 181, 0.01, 1, 1));
        assert_eq!(r.sensor_update, straight_updates, "{gate:?} at the threshold");
        // Beyond it on one axis both update.
        let r = f.update(Pose2::new(0.0, -0.21, 0.0), &common::scans(&map, &truth, 181, 0.01, 2, 2));
        assert!(r.sensor_update, "{gate:?} past the threshold");
    }
}

#[test]
fn per_lidar_updates_count_one_sensor_update_per_scan() {
    // With resample_interval 2, a joint update of two lidars is one sensor update (no
    // resampling yet); per lidar it is two, so the set is resampled at the first step.
    for (mode, resampled) in [(LidarUpdates::Joint, false), (LidarUpdates::PerLidar, true)] {
        let params = small(FilterParams { lidar_updates: mode, resample_interval: 2, ..FilterParams::amcl() });
        let map = common::room();
        let (truth, odom) = common::trajectory()[0];
        let mut f = Localiser::new(&map, params, 3).unwrap();
        f.init_pose(truth, [[0.04, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, 0.0, 0.004]]).unwrap();
        let scans = common::scans(&map, &truth, 181, 0.01, 0, 0);
        let r = f.update(odom, &scans);
        assert_eq!(r.outcome, UpdateOutcome::Updated);
        assert_eq!(r.resampled, resampled, "{mode:?}");
        // Both lidars' beams are used either way.
        assert!(r.beams > 40, "{mode:?}: {} beams", r.beams);
    }
}

#[test]
fn per_lidar_updates_skip_a_scan_without_beams_and_keep_the_other() {
    let params = small(FilterParams::amcl());
    let map = common::room();
    let (truth, odom) = common::trajectory()[0];
    let mut f = Localiser::new(&map, params, 3).unwrap();
    f.init_pose(truth, [[0.04, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, 0.0, 0.004]]).unwrap();
    let mut scans = common::scans(&map, &truth, 181, 0.01, 0, 0);
    scans[1].ranges_m.iter_mut().for_each(|r| *r = f32::INFINITY);
    let r = f.update(odom, &scans);
    assert_eq!(r.outcome, UpdateOutcome::Updated);
    assert_eq!(r.scans_skipped, 1);
    assert!(r.resampled && r.beams > 0);
}

#[test]
fn amcl_resampling_keeps_max_particles_in_one_bin_and_just_over_the_bound_in_several() {
    let map = common::room();
    let (truth, odom) = common::trajectory()[0];
    let scans = common::scans(&map, &truth, 181, 0.01, 0, 0);
    let params = small(FilterParams::amcl());
    assert_eq!(params.resampler, Resampler::MultinomialKld);
    let bins = Bins::new(params.kld_bin_xy_m, params.kld_bin_yaw_rad);

    // All particles in one bin (a pose at a bin's centre, millimetres of spread): AMCL's limit is
    // max_particles while a single bin is filled, so the set stays at the maximum.
    let centre = Pose2::new(0.25, 0.25, bins_centre_yaw(&bins, truth.yaw));
    let mut f = Localiser::new(&map, params, 5).unwrap();
    f.init_pose(centre, [[1e-6, 0.0, 0.0], [0.0, 1e-6, 0.0], [0.0, 0.0, 1e-8]]).unwrap();
    let r = f.update(odom, &scans);
    assert!(r.resampled);
    assert_eq!(r.particles, params.max_particles);

    // A spread over a few bins: drawing stops at the first count past the bound (clamped to
    // min_particles), i.e. min_particles + 1 when the bound is below the minimum.
    let mut f = Localiser::new(&map, params, 5).unwrap();
    f.init_pose(truth, [[0.04, 0.0, 0.0], [0.0, 0.04, 0.0], [0.0, 0.0, 0.01]]).unwrap();
    let r = f.update(odom, &scans);
    let k = {
        let mut keys: Vec<_> = f.particles().iter().map(|p| bins.key(p)).collect();
        keys.sort_unstable();
        keys.dedup();
        keys.len()
    };
    assert!(k >= 2, "{k} bins");
    let limit = kld_bound(k, params.kld_err, params.kld_z).clamp(params.min_particles, params.max_particles);
    assert!(r.particles <= limit + 1, "{} particles, limit {limit} for {k} bins", r.particles);
    assert!(r.particles > params.min_particles, "{}", r.particles);

    // The systematic resampler on the same set stops at the minimum (its rounds are complete).
    let sys = FilterParams { resampler: Resampler::SystematicKld, ..params };
    let mut f = Localiser::new(&map, sys, 5).unwrap();
    f.init_pose(centre, [[1e-6, 0.0, 0.0], [0.0, 1e-6, 0.0], [0.0, 0.0, 1e-8]]).unwrap();
    assert_eq!(f.update(odom, &scans).particles, params.min_particles);
}

fn bins_centre_yaw(bins: &Bins, near: f64) -> f64 {
    // The yaw bin of `near`, at its centre.
    let w = 2.0 * std::f64::consts::PI / f64::from(bins.yaw_bins());
    let k = ((near + std::f64::consts::PI) / w).floor();
    -std::f64::consts::PI + (k + 0.5) * w
}

#[test]
fn the_estimate_is_read_from_the_set_the_preset_names() {
    let map = common::room();
    let (truth, odom) = common::trajectory()[0];
    let scans = common::scans(&map, &truth, 181, 0.01, 0, 0);
    for from in [EstimateFrom::WeightedSet, EstimateFrom::ResampledSet] {
        let params = small(FilterParams { estimate_from: from, ..FilterParams::amcl() });
        let mut f = Localiser::new(&map, params, 9).unwrap();
        f.init_pose(
            truth.compose(&Pose2::new(0.1, -0.1, 0.05)),
            [[0.09, 0.0, 0.0], [0.0, 0.09, 0.0], [0.0, 0.0, 0.02]],
        )
        .unwrap();
        let r = f.update(odom, &scans);
        assert!(r.resampled);
        let bins = Bins::new(params.kld_bin_xy_m, params.kld_bin_yaw_rad);
        let resampled = best_cluster(f.particles(), f.weights(), &bins, &mut ClusterScratch::default());
        let e = r.estimate.pose_in_map;
        let same = e.distance(&resampled.mean) < 1e-12 && angle_diff(e.yaw, resampled.mean.yaw).abs() < 1e-12;
        assert_eq!(same, from == EstimateFrom::ResampledSet, "{from:?}: {e:?} vs {:?}", resampled.mean);
    }
}

#[test]
fn the_amcl_preset_still_tracks() {
    // The preset with all four behaviours converges from a 0.3 m / 5° error in the room, as
    // the preset before them did.
    for (name, params) in [("amcl", FilterParams::amcl()), ("amcl-joint", FilterParams::amcl_joint())] {
        let params = FilterParams { min_particles: 300, max_particles: 3000, ..params };
        for seed in [1, 2, 3] {
            let (worst, rmse) = track(params, seed);
            eprintln!("{name} seed {seed}: late largest error {worst:.3} m, RMSE {rmse:.3} m");
            assert!(worst < 0.25 && rmse < 0.08, "{name} seed {seed}: largest {worst} m, RMSE {rmse} m");
        }
    }
}

fn track(params: FilterParams, seed: u64) -> (f64, f64) {
    let map = common::room();
    let traj = common::trajectory();
    let mut f = Localiser::new(&map, params, seed).unwrap();
    f.init_pose(traj[0].0.compose(&Pose2::new(0.3, 0.0, 0.09)), params.initial_covariance()).unwrap();
    let mut late = Vec::new();
    for (k, (truth, odom)) in traj.iter().enumerate() {
        let r = f.update(*odom, &common::scans(&map, truth, 541, 0.02, k as u64, k as u64 * 80_000_000));
        if k > traj.len() / 3 && r.sensor_update {
            late.push(r.estimate.pose_in_map.distance(truth));
        }
    }
    assert!(!late.is_empty());
    let worst = late.iter().copied().fold(0.0, f64::max);
    let rmse = (late.iter().map(|e| e * e).sum::<f64>() / late.len() as f64).sqrt();
    (worst, rmse)
}
