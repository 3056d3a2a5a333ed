//! One repeat's work of each row of `mapkeeper bench` on the scene.

use super::*;

/// What a localiser preset did over the scene: the same in every repeat (same scene, same seed).
#[derive(Clone, Debug, Default)]
pub(super) struct FilterWork {
    /// Frames handed to the filter (those with odometry).
    pub(super) frames: usize,
    /// Particle count after each sensor update.
    pub(super) particles: Vec<usize>,
    /// Beams used by each sensor update.
    pub(super) beams: Vec<usize>,
    /// Particles each sensor update began with (the set it weighted).
    pub(super) weighted: Vec<usize>,
    /// CPU seconds of each call that ran a sensor update (prediction, weighting, resampling and
    /// the estimate), pooled over the repeats: the only part that differs between them.
    pub(super) update_cpu_s: Vec<f64>,
}

impl FilterWork {
    /// Adds another repeat's run of the same scene: its counts are these, its times are pooled.
    pub(super) fn pool(&mut self, other: FilterWork) {
        if self.frames == 0 {
            *self = other;
        } else {
            self.update_cpu_s.extend(other.update_cpu_s);
        }
    }

    /// CPU per weighted particle and beam of each sensor update, nanoseconds (every repeat's).
    pub(super) fn ns_per_particle_beam(&self) -> Vec<f64> {
        let per_repeat = self.weighted.iter().zip(&self.beams).map(|(&n, &b)| (n * b).max(1) as f64);
        let per_repeat: Vec<f64> = per_repeat.collect();
        self.update_cpu_s.iter().zip(per_repeat.iter().cycle()).map(|(&t, &work)| t * 1e9 / work).collect()
    }
}

pub(super) fn run_localiser(scene: &Scene, name: &str, seed: u64) -> anyhow::Result<FilterWork> {
    let mut loc = Localiser::new(&scene.map, FilterParams::preset(name)?, seed)?;
    let first = scene.steps.first().context("empty scene")?;
    let cov: Covariance3 = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.003]];
    loc.init_pose(first.truth, cov)?;
    let mut work = FilterWork::default();
    for s in &scene.steps {
        if let Some(odo) = s.frame.odometry {
            work.frames += 1;
            let weighted = loc.particles().len();
            let (t, r) = timed(|| loc.update(odo, &s.frame.scans));
            if r.sensor_update {
                work.particles.push(r.particles);
                work.beams.push(r.beams);
                work.weighted.push(weighted);
                work.update_cpu_s.push(t);
            }
        }
    }
    Ok(work)
}

pub(super) fn run_updater(scene: &Scene, name: &str) -> anyhow::Result<usize> {
    let mut up = MapUpdater::new(scene.map.clone(), UpdaterParams::preset(name)?)?;
    let mut processed = 0;
    for s in &scene.steps {
        let report = up.process(s.truth, s.frame.odometry.unwrap_or(s.truth), &s.frame.scans);
        processed += usize::from(report.outcome == StepOutcome::Processed);
    }
    Ok(processed)
}

/// The validation's fresh map (its mapper's parameters, on the scene map's grid) integrating
/// every step of the scene at the true pose, as `EstimateMapper` does on the steps it takes;
/// returns the steps integrated. The runs integrate every `fresh_map.scan_stride`-th step.
pub(super) fn run_fresh_map(scene: &Scene) -> anyhow::Result<usize> {
    let fresh = scene.params.runner.fresh_map.context("the validation's runner has no fresh map")?;
    let mut mapper = LogOddsMapper::new(*scene.map.geometry(), fresh.mapper)?;
    let mut counts = BeamCounts::default();
    for s in &scene.steps {
        for scan in &s.frame.scans {
            integrate_scan(&mut mapper, scan, &scan.lidar_in_map(&s.truth), 0.0, &mut counts);
        }
    }
    black_box(mapper.log_odds().first());
    Ok(scene.steps.len())
}

/// Pose recovery at every 40th step of the scene with the robot 5 m ahead of and turned half a
/// turn from where the estimate and the prediction say (a kidnap the local search cannot reach):
/// each step is Lost, the local search fails and the global search runs. Returns the attempts;
/// fails if the global search did not run or found no right pose on most of them.
pub(super) fn run_global_recovery(scene: &Scene, up: &mut MapUpdater) -> anyhow::Result<usize> {
    let (mut attempts, mut searched, mut right) = (0, 0, 0);
    for s in scene.steps.iter().step_by(40) {
        let wrong = s.truth.compose(&Pose2::new(5.0, 0.0, std::f64::consts::PI));
        let odom = s.frame.odometry.unwrap_or(s.truth);
        up.reset_reference_pose(wrong, odom);
        let r = up.process(wrong, odom, &s.frame.scans);
        let Some(recovery) = r.pose_recovery else { continue };
        attempts += 1;
        searched += usize::from(r.global_search.is_some());
        if let mapkeeper_updater::PoseRecovery::Recovered { pose_in_map, .. } = recovery {
            right += usize::from(pose_in_map.distance(&s.truth) < 0.2);
        }
    }
    anyhow::ensure!(
        searched * 2 > attempts && right * 2 > attempts,
        "global recovery bench: {attempts} attempts, {searched} global searches, {right} right poses"
    );
    Ok(attempts)
}

/// A Lost episode that never ends: the robot drives on along the scene's route, Lost where
/// nothing fits. Every step of the scene is given 5 m ahead of and half a turn from the truth
/// with its scans mirrored (each lidar's ranges in reverse order: a world that is not on the
/// map), so the check says Lost, the local search and the global search (to its node budget)
/// find nothing that passes, and the updater retries every `retry_interval_s` of the scans'
/// clock, each candidate judged on the views kept since (the robot moves, so they count),
/// running the check on the steps between: the most a Lost second costs (standing, the views
/// are not used). Returns the seconds of scans covered and the
/// attempts; fails unless there were about two attempts per second, almost all refused.
pub(super) fn run_lost_seconds(scene: &Scene, up: &mut MapUpdater) -> anyhow::Result<(f64, usize)> {
    let off = Pose2::new(5.0, 0.0, std::f64::consts::PI);
    let (Some(first), Some(last)) = (scene.steps.first(), scene.steps.last()) else {
        anyhow::bail!("Lost-second bench: an empty scene");
    };
    up.reset_reference_pose(first.truth.compose(&off), first.frame.odometry.unwrap_or(first.truth));
    let (mut attempts, mut refused) = (0, 0);
    let mut scans = Vec::new();
    for s in &scene.steps {
        scans.clone_from(&s.frame.scans);
        for scan in &mut scans {
            scan.ranges_m.reverse();
        }
        let r = up.process(s.truth.compose(&off), s.frame.odometry.unwrap_or(s.truth), &scans);
        attempts += usize::from(r.pose_recovery.is_some());
        refused += usize::from(
            matches!(r.pose_recovery, Some(p) if !matches!(p, mapkeeper_updater::PoseRecovery::Recovered { .. })),
        );
    }
    let span_s = last.frame.stamp_ns.saturating_sub(first.frame.stamp_ns) as f64 / 1e9;
    anyhow::ensure!(
        span_s > 0.0
            && attempts as f64 >= span_s
            && attempts as f64 <= 2.0 * span_s + 2.0
            && refused * 10 >= attempts * 9,
        "Lost-second bench: {attempts} attempts ({refused} refused) over {span_s:.1} s of scans"
    );
    Ok((span_s, attempts))
}

/// Rays from every 10th true pose of the scene in 1,082 directions, 30 m, to the first occupied
/// or unknown cell; returns (rays, the sum of the ranges, to keep the work).
pub(super) fn run_traversal(caster: &RayCaster, scene: &Scene) -> (usize, f64) {
    let mut rays = 0;
    let mut sum = 0.0;
    for s in scene.steps.iter().step_by(10) {
        for k in 0..1082 {
            let angle = k as f64 * std::f64::consts::TAU / 1082.0;
            sum += caster.cast(s.truth.position(), angle, 30.0).range_m;
            rays += 1;
        }
    }
    (rays, black_box(sum))
}

/// One closed-loop world with the default validation's runner for `preset`; (process CPU
/// seconds, wall seconds, simulated seconds).
pub(super) fn run_loop(scene: &Scene, m1: &OccupancyGrid, preset: &str, seed: u64) -> anyhow::Result<(f64, f64, f64)> {
    let mut params = ValidationParams::new(2, preset)?;
    params.runner.set_localiser("amcl")?;
    let inputs = RunInputs { world: &scene.w2, route: &scene.route, prev_map: m1, baseline_map: m1, prev_memory: None };
    let start = Instant::now();
    let c0 = process_cpu_s();
    let run = mapkeeper_closed_loop::run_world(&inputs, &params.runner, seed, "bench", &NoClock)?;
    Ok((process_cpu_s() - c0, start.elapsed().as_secs_f64(), run.sim_time_s))
}
