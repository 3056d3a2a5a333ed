//! The closed loop in one world W_i: the simulator drives the route; a chain localiser on
//! M_{i-1} and a baseline localiser on M_1 run on the same scans and odometry; the updater,
//! fed with the chain localiser's pose, turns M_{i-1} into M_i. When the updater says Lost the
//! robot stops, pose updating runs, the chain localiser is re-initialised at the recovered pose
//! and the robot resumes.
//!
//! No wall clock is read here: the time the updater spends per processed scan is measured
//! only if the caller passes a [`Clock`] (the CLI and the benchmarks do); otherwise it is
//! reported as 0 and the work counters (processed scans, beams) stand in for it.

use crate::ScenarioError;
use crate::run_events::{Kidnap, KidnapRecord, TimelineSample, TrackSample};
use mapkeeper_grid::{OccupancyGrid, Pose2, angle_diff, wrap_angle};
use mapkeeper_localiser::{Estimate, FilterParams, Localiser};
use mapkeeper_sensor::{LaserScan, StampedPose};
use mapkeeper_sim::seeds::{stream_rng, stream_seed};
use mapkeeper_sim::{Route, SimParams, Simulator, World};
use mapkeeper_updater::{MapUpdater, PoseRecovery, StepOutcome, UpdaterParams, Verdict};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// A monotonic clock in nanoseconds, injected by the caller (library code reads no clock).
pub trait Clock: Sync {
    /// Nanoseconds since an arbitrary origin.
    fn now_ns(&self) -> u64;
}

/// The clock that always says 0: timings come out as 0 and outputs stay bit-identical.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoClock;

impl Clock for NoClock {
    fn now_ns(&self) -> u64 {
        0
    }
}

/// Parameters of one closed-loop run (everything but the world, the maps and the seed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunnerParams {
    /// The simulator (robot, lidars, odometry, agents). Default [`SimParams::default`].
    pub sim: SimParams,
    /// Both localisers. Default [`FilterParams::default`].
    pub filter: FilterParams,
    /// The updater. Default the `paper` preset.
    pub updater: UpdaterParams,
    /// Distance between the true start and the localisers' initial estimate, metres (in a
    /// seeded random direction). Default 0.05.
    pub start_error_m: f64,
    /// Yaw error of the initial estimate, radians (seeded sign). Default 1° (0.01745).
    pub start_error_yaw_rad: f64,
    /// Standard deviation of the initial particle cloud in x and y, metres. Default 0.1.
    pub init_sigma_xy_m: f64,
    /// Standard deviation of the initial particle cloud in yaw, radians. Default 0.05.
    pub init_sigma_yaw_rad: f64,
    /// Run the updater at all (off: a localiser-only run, M_i = M_{i-1}). Default true.
    pub run_updater: bool,
    /// Run the baseline localiser on M_1. Default true.
    pub run_baseline: bool,
    /// Stop the robot when the updater says Lost and resume after pose updating. Default true.
    pub stop_on_lost: bool,
    /// If pose updating fails, resume anyway after this long stopped, seconds. Default 2.
    pub lost_wait_s: f64,
    /// The run ends after this much simulated time even if the route is not done, seconds.
    /// Default 300.
    pub max_sim_time_s: f64,
    /// Record the true, chain and baseline trajectories (at every scan tick). Default false.
    pub record_trajectories: bool,
    /// Run the baseline localiser on a thread of its own (same results, shorter wall time).
    /// Default true.
    pub parallel_baseline: bool,
    /// Displace the chain localiser's estimate once during the run (a kidnapping of the
    /// estimate; the robot keeps driving). Default none.
    pub kidnap: Option<Kidnap>,
    /// Record the updater's verdict and the chain localiser's error at every processed step
    /// ([`WorldRun::timeline`]). Default false.
    pub record_timeline: bool,
}

impl Default for RunnerParams {
    fn default() -> Self {
        Self {
            sim: SimParams::default(),
            filter: FilterParams::default(),
            updater: UpdaterParams::paper(),
            start_error_m: 0.05,
            start_error_yaw_rad: 1f64.to_radians(),
            init_sigma_xy_m: 0.1,
            init_sigma_yaw_rad: 0.05,
            run_updater: true,
            run_baseline: true,
            stop_on_lost: true,
            lost_wait_s: 2.0,
            max_sim_time_s: 300.0,
            record_trajectories: false,
            parallel_baseline: true,
            kidnap: None,
            record_timeline: false,
        }
    }
}

impl RunnerParams {
    /// Checks every field (and the components' own parameters).
    pub fn validate(&self) -> Result<(), ScenarioError> {
        self.sim.validate()?;
        self.filter.validate()?;
        self.updater.validate()?;
        let bad =
            |name, v: f64| ScenarioError::InvalidParam { name, problem: format!("must be finite and ≥ 0, got {v}") };
        for (name, v) in [
            ("start_error_m", self.start_error_m),
            ("start_error_yaw_rad", self.start_error_yaw_rad),
            ("init_sigma_xy_m", self.init_sigma_xy_m),
            ("init_sigma_yaw_rad", self.init_sigma_yaw_rad),
            ("lost_wait_s", self.lost_wait_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(name, v));
            }
        }
        if !(self.max_sim_time_s.is_finite() && self.max_sim_time_s > 0.0) {
            return Err(bad("max_sim_time_s", self.max_sim_time_s));
        }
        if let Some(k) = &self.kidnap {
            k.validate()?;
        }
        Ok(())
    }
}

/// One localiser's accuracy and uncertainty over a run, at its sensor updates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LocStats {
    /// Sensor updates recorded.
    pub updates: u64,
    /// Mean position error, metres.
    pub mean_error_m: f64,
    /// Largest position error, metres.
    pub max_error_m: f64,
    /// Root mean square position error, metres.
    pub rmse_m: f64,
    /// Root mean square yaw error, radians.
    pub yaw_rmse_rad: f64,
    /// Mean trace of the 3×3 covariance (m² + rad², as the paper's Fig. 26).
    pub mean_trace: f64,
    /// Standard deviation of the trace.
    pub std_trace: f64,
    /// Mean largest eigenvalue of the covariance.
    pub mean_lambda_max: f64,
    /// Standard deviation of λmax.
    pub std_lambda_max: f64,
    /// Position error at the last update, metres.
    pub final_error_m: f64,
}

/// Running sums for [`LocStats`].
#[derive(Clone, Debug, Default)]
struct LocAcc {
    n: u64,
    sum_e: f64,
    sum_e2: f64,
    max_e: f64,
    sum_yaw2: f64,
    sum_tr: f64,
    sum_tr2: f64,
    sum_l: f64,
    sum_l2: f64,
    last_e: f64,
}

impl LocAcc {
    fn add(&mut self, est: &Estimate, truth: &Pose2) {
        let e = est.pose_in_map.distance(truth);
        let dyaw = angle_diff(est.pose_in_map.yaw, truth.yaw);
        let c = &est.covariance;
        let tr = c[0][0] + c[1][1] + c[2][2];
        let l = est.lambda_max();
        self.n += 1;
        self.sum_e += e;
        self.sum_e2 += e * e;
        self.max_e = self.max_e.max(e);
        self.sum_yaw2 += dyaw * dyaw;
        self.sum_tr += tr;
        self.sum_tr2 += tr * tr;
        self.sum_l += l;
        self.sum_l2 += l * l;
        self.last_e = e;
    }

    fn stats(&self) -> LocStats {
        if self.n == 0 {
            return LocStats::default();
        }
        let n = self.n as f64;
        let sd = |s: f64, s2: f64| ((s2 / n) - (s / n).powi(2)).max(0.0).sqrt();
        LocStats {
            updates: self.n,
            mean_error_m: self.sum_e / n,
            max_error_m: self.max_e,
            rmse_m: (self.sum_e2 / n).sqrt(),
            yaw_rmse_rad: (self.sum_yaw2 / n).sqrt(),
            mean_trace: self.sum_tr / n,
            std_trace: sd(self.sum_tr, self.sum_tr2),
            mean_lambda_max: self.sum_l / n,
            std_lambda_max: sd(self.sum_l, self.sum_l2),
            final_error_m: self.last_e,
        }
    }
}

/// The true and estimated trajectories of a run (TUM-ready).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trajectories {
    /// The simulator's true pose.
    pub truth: Vec<StampedPose>,
    /// The chain localiser (on M_{i-1}).
    pub chain: Vec<StampedPose>,
    /// The baseline localiser (on M_1).
    pub baseline: Vec<StampedPose>,
}

/// The updater's verdicts and work over a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct UpdaterCounts {
    /// Steps processed (not gated).
    pub processed: u64,
    /// Verdict Update.
    pub update: u64,
    /// Verdict Suspend.
    pub suspend: u64,
    /// Verdict Lost.
    pub lost: u64,
    /// Pose recoveries that succeeded.
    pub recovered: u64,
    /// Pose recoveries that failed.
    pub not_recovered: u64,
    /// Valid beams processed.
    pub beams: u64,
    /// Cell state changes applied to M_i.
    pub cell_changes: u64,
    /// Largest `state_bytes()` seen.
    pub max_state_bytes: u64,
}

/// The chain localiser's error at one of its sensor updates.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorSample {
    /// Distance the robot had travelled (true), metres.
    pub distance_m: f64,
    /// Position error, metres.
    pub error_m: f64,
    /// Absolute yaw error, radians.
    pub yaw_error_rad: f64,
}

/// Everything one run produced.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldRun {
    /// M_i (= M_{i-1} when the updater is off).
    pub map: OccupancyGrid,
    /// The chain localiser on M_{i-1}.
    pub chain: LocStats,
    /// The baseline localiser on M_1 (zeros if off).
    pub baseline: LocStats,
    /// The updater's verdicts and work.
    pub updater: UpdaterCounts,
    /// Cells whose state differs between M_{i-1} and M_i.
    pub cells_changed: u64,
    /// Contacts of the robot that began during the run.
    pub collisions: u64,
    /// Simulated time, seconds.
    pub sim_time_s: f64,
    /// Distance the robot travelled (true), metres.
    pub distance_m: f64,
    /// Whether the route was completed.
    pub route_done: bool,
    /// Updater time per processed scan, microseconds, in processing order (empty with
    /// [`NoClock`]).
    pub scan_times_us: Vec<u32>,
    /// Trajectories, if asked for.
    pub trajectories: Option<Trajectories>,
    /// The chain localiser's error at each of its sensor updates.
    pub chain_errors: Vec<ErrorSample>,
    /// What happened around the kidnap, if one was asked for and its time was reached.
    pub kidnap: Option<KidnapRecord>,
    /// Every processed step, if asked for.
    pub timeline: Vec<TimelineSample>,
}

/// The initial estimate: the true start displaced by `start_error_m` in a seeded direction and
/// by ±`start_error_yaw_rad`.
pub fn perturbed_start(truth: Pose2, params: &RunnerParams, seed: u64, stream: &str) -> Pose2 {
    let mut rng = stream_rng(seed, stream);
    let dir = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let sign = if rng.random::<f64>() < 0.5 { -1.0 } else { 1.0 };
    Pose2::new(
        truth.x + params.start_error_m * dir.cos(),
        truth.y + params.start_error_m * dir.sin(),
        truth.yaw + sign * params.start_error_yaw_rad,
    )
}

fn init_cov(params: &RunnerParams) -> [[f64; 3]; 3] {
    let (s, a) = (params.init_sigma_xy_m.powi(2), params.init_sigma_yaw_rad.powi(2));
    [[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, a]]
}

/// The world and maps of one run.
#[derive(Clone, Copy, Debug)]
pub struct RunInputs<'a> {
    /// W_i.
    pub world: &'a World,
    /// The route to drive.
    pub route: &'a Route,
    /// M_{i-1}: the chain localiser's map and the updater's initial map.
    pub prev_map: &'a OccupancyGrid,
    /// M_1: the baseline localiser's map.
    pub baseline_map: &'a OccupancyGrid,
}

/// The sensor data of one scan tick, as the baseline localiser consumes it.
struct BaselineMsg {
    stamp_ns: u64,
    odom: Pose2,
    truth: Pose2,
    scans: Vec<LaserScan>,
}

/// The baseline localiser and what it recorded.
struct BaselineState {
    loc: Localiser,
    acc: LocAcc,
    poses: Vec<StampedPose>,
    record: bool,
}

impl BaselineState {
    fn feed(&mut self, m: &BaselineMsg) {
        let r = self.loc.update(m.odom, &m.scans);
        if r.sensor_update {
            self.acc.add(&r.estimate, &m.truth);
        }
        if self.record {
            self.poses.push(StampedPose { stamp_ns: m.stamp_ns, pose: r.estimate.pose_in_map });
        }
    }
}

/// Runs one world. All random streams derive from `seed` and `label` (e.g. `"W007"`); the
/// updater's time per processed scan is read from `clock`. With
/// [`RunnerParams::parallel_baseline`] the baseline localiser runs on its own thread, fed the
/// same scan ticks in the same order, so the results are the same either way.
pub fn run_world(
    inputs: &RunInputs<'_>,
    params: &RunnerParams,
    seed: u64,
    label: &str,
    clock: &dyn Clock,
) -> Result<WorldRun, ScenarioError> {
    params.validate()?;
    let RunInputs { world, route, prev_map, baseline_map } = *inputs;
    let mut sim = Simulator::new(world, params.sim.clone(), stream_seed(seed, &format!("sim/{label}")))?;
    sim.set_route(route.points());
    let start_est = perturbed_start(sim.true_pose(), params, seed, &format!("start/{label}"));
    let cov = init_cov(params);
    let mut chain = Localiser::new(prev_map, params.filter, stream_seed(seed, &format!("chain/{label}")))?;
    chain.init_pose(start_est, cov)?;
    let baseline = if params.run_baseline {
        let mut b = Localiser::new(baseline_map, params.filter, stream_seed(seed, &format!("baseline/{label}")))?;
        b.init_pose(start_est, cov)?;
        Some(BaselineState { loc: b, acc: LocAcc::default(), poses: Vec::new(), record: params.record_trajectories })
    } else {
        None
    };
    let updater =
        if params.run_updater { Some(MapUpdater::new(prev_map.clone(), params.updater.clone())?) } else { None };
    let (mut run, base) = match baseline {
        None => (closed_loop(sim, chain, updater, prev_map, params, clock, &mut |_| {})?, None),
        Some(mut b) if !params.parallel_baseline => {
            let run = closed_loop(sim, chain, updater, prev_map, params, clock, &mut |m| b.feed(&m))?;
            (run, Some(b))
        }
        Some(mut b) => std::thread::scope(|s| {
            let (tx, rx) = std::sync::mpsc::sync_channel::<BaselineMsg>(256);
            let worker = s.spawn(move || {
                for m in rx {
                    b.feed(&m);
                }
                b
            });
            let run = closed_loop(sim, chain, updater, prev_map, params, clock, &mut |m| {
                // The worker only stops when the channel closes, so a send cannot fail.
                let _ = tx.send(m);
            });
            drop(tx);
            let b = worker.join().map_err(|_| ScenarioError::Generator("the baseline thread panicked".into()))?;
            run.map(|r| (r, Some(b)))
        })?,
    };
    if let Some(b) = base {
        run.baseline = b.acc.stats();
        if let Some(t) = run.trajectories.as_mut() {
            t.baseline = b.poses;
        }
    }
    Ok(run)
}

/// The simulator, the chain localiser and the updater in lock step; each scan tick is also
/// handed to `baseline`.
fn closed_loop(
    mut sim: Simulator,
    mut chain: Localiser,
    mut updater: Option<MapUpdater>,
    prev_map: &OccupancyGrid,
    params: &RunnerParams,
    clock: &dyn Clock,
    baseline: &mut dyn FnMut(BaselineMsg),
) -> Result<WorldRun, ScenarioError> {
    let start_truth = sim.true_pose();
    let max_ticks = (params.max_sim_time_s * 1e9 / params.sim.tick_ns as f64).ceil() as u64;
    let lost_wait_ticks = (params.lost_wait_s * 1e9 / params.sim.tick_ns as f64).ceil() as u64;
    let mut acc_chain = LocAcc::default();
    let mut counts = UpdaterCounts::default();
    let mut collisions = 0u64;
    let mut distance_m = 0.0;
    let mut prev_truth = start_truth;
    let mut route_done = false;
    let mut stopped_since: Option<u64> = None;
    let mut scan_times_us = Vec::new();
    let mut traj = params.record_trajectories.then(Trajectories::default);
    let mut chain_errors = Vec::new();
    let mut kidnap: Option<KidnapRecord> = None;
    let mut timeline = Vec::new();

    while sim.tick() < max_ticks {
        let out = sim.step();
        collisions += out.collisions.iter().filter(|c| c.started).count() as u64;
        let truth = out.truth.pose_in_map;
        distance_m += prev_truth.distance(&truth);
        prev_truth = truth;
        if !out.scans.is_empty() {
            let odom = out.odometry.pose_in_odom;
            let t_s = out.stamp_ns as f64 / 1e9;
            if let Some(k) = params.kidnap
                && kidnap.is_none()
                && t_s >= k.at_s
            {
                let estimate = Pose2::new(truth.x + k.dx_m, truth.y + k.dy_m, wrap_angle(truth.yaw + k.dyaw_rad));
                let (s2, a2) = (k.sigma_xy_m.powi(2), k.sigma_yaw_rad.powi(2));
                chain.init_pose(estimate, [[s2, 0.0, 0.0], [0.0, s2, 0.0], [0.0, 0.0, a2]])?;
                kidnap = Some(KidnapRecord {
                    at_s: t_s,
                    truth,
                    estimate,
                    lost_before: counts.lost,
                    first_lost_s: None,
                    recoveries: Vec::new(),
                    failed_recoveries: 0,
                    track: Vec::new(),
                });
            }
            let rep = chain.update(odom, &out.scans);
            if let Some(k) = kidnap.as_mut() {
                k.track.push(TrackSample {
                    t_s,
                    error_m: rep.estimate.pose_in_map.distance(&truth),
                    yaw_error_rad: angle_diff(rep.estimate.pose_in_map.yaw, truth.yaw).abs(),
                });
            }
            if rep.sensor_update {
                acc_chain.add(&rep.estimate, &truth);
                chain_errors.push(ErrorSample {
                    distance_m,
                    error_m: rep.estimate.pose_in_map.distance(&truth),
                    yaw_error_rad: angle_diff(rep.estimate.pose_in_map.yaw, truth.yaw).abs(),
                });
            }
            let chain_pose = rep.estimate.pose_in_map;
            if let Some(u) = updater.as_mut() {
                let t0 = clock.now_ns();
                let step = u.process(chain_pose, odom, &out.scans);
                let t1 = clock.now_ns();
                if step.outcome == StepOutcome::Processed {
                    counts.processed += 1;
                    counts.beams += step.n_valid as u64;
                    if t1 > 0 {
                        scan_times_us.push(u32::try_from(t1.saturating_sub(t0) / 1000).unwrap_or(u32::MAX));
                    }
                    counts.max_state_bytes = counts.max_state_bytes.max(u.state_bytes() as u64);
                }
                if params.record_timeline
                    && let Some(verdict) = step.verdict
                {
                    timeline.push(TimelineSample {
                        t_s,
                        verdict,
                        n_valid: u32::try_from(step.n_valid).unwrap_or(u32::MAX),
                        n_dc: u32::try_from(step.n_dc).unwrap_or(u32::MAX),
                        error_m: chain_pose.distance(&truth),
                        yaw_error_rad: angle_diff(chain_pose.yaw, truth.yaw).abs(),
                        recovered: step.pose_recovery.as_ref().map(|r| matches!(r, PoseRecovery::Recovered { .. })),
                    });
                }
                if step.verdict == Some(Verdict::Lost)
                    && let Some(k) = kidnap.as_mut()
                {
                    k.first_lost_s.get_or_insert(t_s);
                    match &step.pose_recovery {
                        Some(PoseRecovery::Recovered { pose_in_map, .. }) => k.recoveries.push(TrackSample {
                            t_s,
                            error_m: pose_in_map.distance(&truth),
                            yaw_error_rad: angle_diff(pose_in_map.yaw, truth.yaw).abs(),
                        }),
                        Some(PoseRecovery::NotRecovered { .. }) => k.failed_recoveries += 1,
                        None => {}
                    }
                }
                match step.verdict {
                    Some(Verdict::Update) => counts.update += 1,
                    Some(Verdict::Suspend) => counts.suspend += 1,
                    Some(Verdict::Lost) => {
                        counts.lost += 1;
                        if params.stop_on_lost && stopped_since.is_none() {
                            sim.stop();
                            stopped_since = Some(sim.tick());
                        }
                        match step.pose_recovery {
                            Some(PoseRecovery::Recovered { pose_in_map, covariance, .. }) => {
                                counts.recovered += 1;
                                // Inflate the ICP covariance a little: it is optimistic.
                                let mut c = covariance;
                                let floor = init_cov(params);
                                for k in 0..3 {
                                    c[k][k] = c[k][k].max(floor[k][k] * 0.25);
                                }
                                if chain.init_pose(pose_in_map, c).is_err() {
                                    chain.init_pose(pose_in_map, floor)?;
                                }
                                u.reset_reference_pose(pose_in_map, odom);
                                if stopped_since.take().is_some() {
                                    sim.resume();
                                }
                            }
                            Some(PoseRecovery::NotRecovered { .. }) => counts.not_recovered += 1,
                            None => {}
                        }
                    }
                    None => {}
                }
            }
            if let Some(t) = traj.as_mut() {
                let s = out.stamp_ns;
                t.truth.push(StampedPose { stamp_ns: s, pose: truth });
                t.chain.push(StampedPose { stamp_ns: s, pose: chain_pose });
            }
            baseline(BaselineMsg { stamp_ns: out.stamp_ns, odom, truth, scans: out.scans });
        }
        if let Some(since) = stopped_since
            && sim.tick() - since >= lost_wait_ticks
        {
            sim.resume();
            stopped_since = None;
        }
        if out.route_done {
            route_done = true;
            break;
        }
    }
    let map = match updater {
        Some(u) => {
            counts.cell_changes = u.stats().cell_changes;
            u.map().clone()
        }
        None => prev_map.clone(),
    };
    let cells_changed = map.cells().iter().zip(prev_map.cells()).filter(|(a, b)| a != b).count() as u64;
    Ok(WorldRun {
        map,
        chain: acc_chain.stats(),
        baseline: LocStats::default(),
        updater: counts,
        cells_changed,
        collisions,
        sim_time_s: sim.stamp_ns() as f64 / 1e9,
        distance_m,
        route_done,
        scan_times_us,
        trajectories: traj,
        chain_errors,
        kidnap,
        timeline,
    })
}
