//! Degenerate weights, bad inputs, re-initialisation and map replacement: reported as outcomes,
//! recovered from explicitly, never a panic.

#![allow(clippy::unwrap_used)]

mod common;

use mapkeeper_grid::{CellState, GridGeometry, OccupancyGrid, Pose2};
use mapkeeper_localiser::{Degeneracy, FilterParams, Localiser, LocaliserError, Recovery, UpdateOutcome};

fn small() -> FilterParams {
    FilterParams { min_particles: 100, max_particles: 500, ..FilterParams::default() }
}

/// With no random term and a very narrow hit term, a scan that fits no particle drives every
/// weight to exactly zero: reported as `AllWeightsZero`, weights reset uniform, no resampling.
#[test]
fn all_zero_weights_are_reported_and_recovered() {
    let map = common::room();
    let params = FilterParams { z_rand: 0.0, sigma_hit_m: 0.001, ..small() };
    let mut f = Localiser::new(&map, params, 3).unwrap();
    let truth = common::trajectory()[0].0;
    f.init_pose(truth, [[0.0; 3]; 3]).unwrap();
    // Scans taken 1.3 m away: every endpoint lies > 0.05 m from any wall for the particles.
    let elsewhere = truth.compose(&Pose2::new(1.3, 0.37, 0.9));
    let scans = common::scans(&map, &elsewhere, 541, 0.0, 0, 0);
    let r = f.update(Pose2::IDENTITY, &scans);
    assert_eq!(
        r.outcome,
        UpdateOutcome::Degenerate { kind: Degeneracy::AllWeightsZero, recovery: Recovery::UniformWeights }
    );
    assert!(r.sensor_update && !r.resampled);
    assert_eq!(r.particles, 500);
    assert!(f.weights().iter().all(|&w| w == 1.0 / 500.0));
    assert!(r.estimate.pose_in_map.distance(&truth) < 1e-9);
    // The recovered filter keeps working: a scan from the true pose after a 0.6 rad turn (past
    // the 0.5 rad gate) runs a sensor update again. With σ_hit = 1 mm and no random term it is
    // not an ordinary update, though: a beam's likelihood underflows to 0 beyond ≈ 0.039 m
    // (d² / 2σ² > 745), and the likelihood field holds one distance per 5 cm cell, so an exact
    // endpoint on an occupied cell's edge that looks up the free cell in front of it is 0.05 m
    // off. Every particle is scored 0 (even one at the scan's exact pose), and the filter
    // reports the degeneracy and recovers the same way again.
    let scans = common::scans(&map, &truth, 541, 0.0, 0, 0);
    let r = f.update(Pose2::new(0.0, 0.0, 0.6), &scans);
    assert_eq!(
        r.outcome,
        UpdateOutcome::Degenerate { kind: Degeneracy::AllWeightsZero, recovery: Recovery::UniformWeights }
    );
    assert!(r.sensor_update && !r.resampled && r.beams > 0, "{r:?}");
    assert_eq!(r.particles, 500);
    assert!(f.weights().iter().all(|&w| w == 1.0 / 500.0));
    assert!(r.estimate.pose_in_map.is_finite());
}

#[test]
fn bad_inputs_are_outcomes_not_panics() {
    let map = common::room();
    let mut f = Localiser::new(&map, small(), 1).unwrap();
    let r = f.update(Pose2::new(f64::NAN, 0.0, 0.0), &[]);
    assert_eq!(r.outcome, UpdateOutcome::InvalidOdometry);
    let r = f.update(Pose2::IDENTITY, &[]);
    assert_eq!(r.outcome, UpdateOutcome::NoUsableBeams);
    // All beams invalid, and a scan with a broken header.
    let truth = common::trajectory()[0].0;
    let mut scans = common::scans(&map, &truth, 101, 0.0, 0, 0);
    scans[0].ranges_m.iter_mut().for_each(|r| *r = f32::NAN);
    scans[1].angle_increment_rad = 0.0;
    let r = f.update(Pose2::IDENTITY, &scans);
    assert_eq!((r.outcome, r.scans_skipped), (UpdateOutcome::NoUsableBeams, 2));
    // Gating: after a real update, a 1 cm move does not update.
    let scans = common::scans(&map, &truth, 101, 0.0, 0, 0);
    assert_eq!(f.update(Pose2::IDENTITY, &scans).outcome, UpdateOutcome::Updated);
    let r = f.update(Pose2::new(0.01, 0.0, 0.0), &scans);
    assert_eq!(r.outcome, UpdateOutcome::Gated);
    assert!(!r.sensor_update);
}

#[test]
fn bad_initialisation_is_refused() {
    let map = common::room();
    let mut f = Localiser::new(&map, small(), 1).unwrap();
    let p = Pose2::new(1.0, 1.0, 0.0);
    assert!(matches!(
        f.init_pose(Pose2::new(f64::NAN, 0.0, 0.0), [[0.0; 3]; 3]),
        Err(LocaliserError::NonFinitePose(_))
    ));
    let asym = [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!(matches!(f.init_pose(p, asym), Err(LocaliserError::BadCovariance(_))));
    let indefinite = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]];
    assert!(matches!(f.init_pose(p, indefinite), Err(LocaliserError::BadCovariance(_))));
    let g = GridGeometry::new(10, 10, 0.1, Pose2::IDENTITY).unwrap();
    let blocked = OccupancyGrid::filled(g, CellState::Occupied);
    assert!(matches!(Localiser::new(&blocked, small(), 1), Err(LocaliserError::NoFreeSpace)));
    let bad = FilterParams { kld_z: f64::NAN, ..small() };
    assert!(matches!(Localiser::new(&map, bad, 1), Err(LocaliserError::InvalidParameter(p)) if p.name == "kld_z"));
}

/// The initial covariance is honoured: the particle cloud's sample covariance matches it.
#[test]
fn init_pose_samples_the_given_covariance() {
    let map = common::room();
    let params = FilterParams { max_particles: 20_000, ..small() };
    let mut f = Localiser::new(&map, params, 9).unwrap();
    let cov = [[0.09, 0.03, 0.0], [0.03, 0.04, 0.01], [0.0, 0.01, 0.02]];
    f.init_pose(Pose2::new(2.0, 2.5, 0.3), cov).unwrap();
    let ps = f.particles();
    let n = ps.len() as f64;
    let m = [ps.iter().map(|p| p.x).sum::<f64>() / n, ps.iter().map(|p| p.y).sum::<f64>() / n, 0.3];
    let d = |p: &Pose2| [p.x - m[0], p.y - m[1], p.yaw - m[2]];
    for (r, row) in cov.iter().enumerate() {
        for (c, want) in row.iter().enumerate() {
            let s = ps.iter().map(|p| d(p)[r] * d(p)[c]).sum::<f64>() / n;
            assert!((s - want).abs() < 0.004, "cov[{r}][{c}] = {s}, want {want}");
        }
    }
    let e = f.estimate();
    assert!(e.pose_in_map.distance(&Pose2::new(2.0, 2.5, 0.3)) < 0.01);
}

/// Swapping the map keeps the particles, and later updates use the new map: two filters start
/// halfway between the poses that explain the scans in the old and in a shifted map; the one
/// given the shifted map follows it, the other the old one.
#[test]
fn map_replacement_at_run_time() {
    let map = common::room();
    let g = map.geometry();
    let shift = 0.4;
    let shifted_geometry =
        GridGeometry::new(g.width(), g.height(), g.resolution_m(), Pose2::new(-1.0 + shift, -1.0, 0.0)).unwrap();
    let shifted = OccupancyGrid::from_cells(shifted_geometry, map.cells().to_vec()).unwrap();
    let cov = [[0.02, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.005]];
    let mut a = Localiser::new(&map, small(), 4).unwrap();
    let mut b = Localiser::new(&map, small(), 4).unwrap();
    let traj = common::trajectory();
    let mid = Pose2::new(traj[0].0.x + shift / 2.0, traj[0].0.y, traj[0].0.yaw);
    for f in [&mut a, &mut b] {
        f.init_pose(mid, cov).unwrap();
    }
    let before = a.particles().to_vec();
    a.set_map(&shifted);
    assert_eq!(a.particles(), &before[..]);
    for (k, (truth, odom)) in traj.iter().take(60).enumerate() {
        // The robot drives in the shifted world.
        let truth_shifted = Pose2::new(truth.x + shift, truth.y, truth.yaw);
        let scans = common::scans(&shifted, &truth_shifted, 271, 0.01, k as u64, 0);
        a.update(*odom, &scans);
        b.update(*odom, &scans);
    }
    let (truth, _) = traj[59];
    let ea = a.estimate().pose_in_map;
    let eb = b.estimate().pose_in_map;
    assert!(ea.distance(&Pose2::new(truth.x + shift, truth.y, 0.0)) < 0.1, "{ea:?} vs {truth:?} + {shift}");
    assert!(eb.distance(&truth) < 0.1, "{eb:?} vs {truth:?}");
}
