//! Synthetic scans in a known room: the filter converges to the true pose when tracking from a
//! wrong initial pose and from global initialisation. Tolerances are explicit, over a fixed list
//! of seeds.

#![allow(clippy::unwrap_used)]

mod common;

use mapkeeper_grid::{Pose2, angle_diff};
use mapkeeper_localiser::{FilterParams, Localiser, UpdateOutcome};

const SEEDS: [u64; 3] = [1, 2, 3];

fn params() -> FilterParams {
    FilterParams { min_particles: 300, max_particles: 3000, ..FilterParams::default() }
}

struct Run {
    /// (position error m, yaw error rad) after every call, and whether it was a sensor update.
    errors: Vec<(f64, f64, bool)>,
    max_particles_seen: usize,
    min_particles_seen: usize,
}

fn run(filter: &mut Localiser, beams: usize, noise_m: f64) -> Run {
    let map = common::room();
    let mut errors = Vec::new();
    let (mut max_seen, mut min_seen) = (0, usize::MAX);
    for (k, (truth, odom)) in common::trajectory().iter().enumerate() {
        let scans = common::scans(&map, truth, beams, noise_m, k as u64, k as u64 * 80_000_000);
        let r = filter.update(*odom, &scans);
        assert!(matches!(r.outcome, UpdateOutcome::Updated | UpdateOutcome::Gated), "{:?}", r.outcome);
        max_seen = max_seen.max(r.particles);
        min_seen = min_seen.min(r.particles);
        let e = r.estimate.pose_in_map;
        errors.push((e.distance(truth), angle_diff(e.yaw, truth.yaw).abs(), r.sensor_update));
    }
    Run { errors, max_particles_seen: max_seen, min_particles_seen: min_seen }
}

fn rmse(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0.0);
    for x in v {
        s += x * x;
        n += 1.0;
    }
    (s / n).sqrt()
}

#[test]
fn tracking_converges_from_half_a_metre_of_error() {
    let map = common::room();
    let (truth0, _) = common::trajectory()[0];
    for seed in SEEDS {
        let mut f = Localiser::new(&map, params(), seed).unwrap();
        let wrong = truth0.compose(&Pose2::new(0.4, -0.3, 0.15));
        f.init_pose(wrong, [[0.25, 0.0, 0.0], [0.0, 0.25, 0.0], [0.0, 0.0, 0.07]]).unwrap();
        let r = run(&mut f, 541, 0.02);
        let n = r.errors.len();
        // Sensor updates only: the gated calls extrapolate with the drifting odometry.
        let late = r.errors[n / 3..].iter().filter(|e| e.2);
        let pos = rmse(late.clone().map(|e| e.0));
        let yaw = rmse(late.map(|e| e.1)).to_degrees();
        eprintln!(
            "seed {seed}: position RMSE {pos:.4} m, yaw RMSE {yaw:.3} deg, particles {}..{}",
            r.min_particles_seen, r.max_particles_seen
        );
        assert!(pos < 0.05, "seed {seed}: position RMSE {pos} m");
        assert!(yaw < 1.0, "seed {seed}: yaw RMSE {yaw} deg");
        // KLD sampling shrank the set once converged.
        assert!(r.min_particles_seen < 1000, "seed {seed}: {}", r.min_particles_seen);
    }
}

#[test]
fn global_initialisation_converges() {
    let map = common::room();
    let mut f = Localiser::new(&map, FilterParams { max_particles: 5000, ..params() }, 11).unwrap();
    f.init_global().unwrap();
    let r = run(&mut f, 181, 0.02);
    let n = r.errors.len();
    let last = &r.errors[n / 2..];
    let worst = last.iter().filter(|e| e.2).map(|e| e.0).fold(0.0, f64::max);
    eprintln!("global: worst position error over the second half {worst:.3} m");
    assert!(worst < 0.15, "worst position error {worst} m");
    assert_eq!(r.max_particles_seen, 5000);
}
