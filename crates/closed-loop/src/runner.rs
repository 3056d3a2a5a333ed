//! The closed loop in one world W_i: the simulator drives the route; a chain localiser on
//! M_{i-1} and a baseline localiser on M_1 run on the same scans and odometry; the updater,
//! fed with the chain localiser's pose (or, in an experiment, the true pose with or without
//! noise: [`RunnerParams::updater_poses`]), turns M_{i-1} into M_i. When the updater says Lost the
//! robot stops at once and stays stopped while the updater retries pose updating on the scans it
//! keeps receiving; on a recovered pose the chain localiser is re-initialised there and the
//! robot resumes, and after `lost_wait_s` without one it resumes anyway ([`LostPolicy`]).
//!
//! The loop itself is `mapkeeper_harness::run`: this module builds the simulated source, the
//! session and the experiment's controls and observers ([`crate::controls`]), and assembles
//! the [`WorldRun`]. No wall clock is read here: the time the updater spends per processed scan
//! is measured only if the caller passes a [`Clock`] (the CLI and the benchmarks do);
//! otherwise it is reported as 0 and the work counters (processed scans, beams) stand in for it.

use crate::ExperimentError;
use crate::controls::{
    Kidnap, KidnapControl, KidnapRecord, LostCounts, LostEpisode, LostPolicy, PoseErrorControl, PoseErrorHold,
    PoseErrorRecord, RobotKidnap, TimelineRecorder, TimelineSample,
};
use crate::pose_oracle::{GivenPoseError, GivenPoseStats, PoseOracle, UpdaterPoses};
use crate::sim_source::{SimSource, Simulated};
use mapkeeper_common::ParamError;
use mapkeeper_grid::{OccupancyGrid, Pose2};
use mapkeeper_harness::jobs::map::{EstimateMapper, ThreadedEstimateMapper};
use mapkeeper_harness::{Baseline, Control, HandoverHold, LocScore, Observer, PoseSource, Session, UpdaterWork};
pub use mapkeeper_harness::{Clock, ErrorSample, LocStats, NoClock, Trajectories};
use mapkeeper_localiser::{FilterParams, Localiser};
use mapkeeper_sim::seeds::{stream_rng, stream_seed};
use mapkeeper_sim::{Route, SimParams, Simulator, World};
use mapkeeper_updater::{MapUpdater, StructureMemory, UpdaterParams};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// Parameters of one closed-loop run (everything but the world, the maps and the seed).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunnerParams {
    /// The simulator (robot, lidars, odometry, agents). Default [`SimParams::default`].
    pub sim: SimParams,
    /// Name of the localiser preset (`mapkeeper_localiser::LOCALISER_PRESETS`) `filter` was
    /// made from, recorded in the reports (a parameter file may have changed fields of it
    /// since). Default "mapkeeper".
    pub localiser: String,
    /// Both localisers. Default [`FilterParams::default`] (the `mapkeeper` preset).
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
    /// Stop the robot (at once) when the updater says Lost, and keep it stopped until pose
    /// updating returns a pose, a processed step says Update or Suspend, or `lost_wait_s` has
    /// passed. Default true.
    pub stop_on_lost: bool,
    /// The longest a Lost episode waits for a recovered pose before the robot resumes without
    /// one (a give-up), seconds of simulated time. Default 2.
    pub lost_wait_s: f64,
    /// After a stopped Lost episode gave up, the robot walks on along its route for this long,
    /// Lost steps not stopping it, so that pose updating looks from new places
    /// ([`LostPolicy::with_walk`]), seconds. Default 0: it stops again at the next Lost (the
    /// paper's reaction). Not written when 0.
    #[serde(default, skip_serializing_if = "is_zero_f64")]
    pub lost_walk_s: f64,
    /// Hold a handed-over pose with the updater's registration for a while
    /// ([`mapkeeper_harness::HandoverHold`]). Default 30 s after each handover; `hold_s = 0`
    /// turns it off (the behaviour before issue 54).
    #[serde(default)]
    pub handover_hold: HandoverHold,
    /// The run ends after this much simulated time even if the route is not done, seconds.
    /// Default 300.
    pub max_sim_time_s: f64,
    /// Record the true, chain and baseline trajectories (at every scan tick). Default false.
    pub record_trajectories: bool,
    /// Displace the chain localiser's estimate once during the run (a kidnapping of the
    /// estimate; the robot keeps driving). Default none.
    pub kidnap: Option<Kidnap>,
    /// Record the updater's verdict and the chain localiser's error at every processed step
    /// ([`WorldRun::timeline`]). Default false.
    pub record_timeline: bool,
    /// Build a fresh map of the run: the log-odds mapper over M_{i-1}'s grid, fed every
    /// `scan_stride`-th processed step's scans at the chain localiser's estimate (no prior).
    /// Default `None` (off); `ValidationParams`' default turns it on with M_1's mapper and
    /// stride.
    #[serde(default)]
    pub fresh_map: Option<FreshMapParams>,
    /// Hold the pose the updater is given wrong by a fixed offset for a while (the localiser
    /// runs on unbiased; [`PoseErrorHold`]). Default none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose_error: Option<PoseErrorHold>,
    /// Move the robot itself once during the run (odometry does not see it; [`RobotKidnap`]).
    /// Not with `kidnap`. Default none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot_kidnap: Option<RobotKidnap>,
    /// Where the pose the updater is given comes from ([`UpdaterPoses`]): the chain localiser's
    /// estimate (the default, not written then), the true pose, or the true pose plus noise
    /// (an experiment control, [`PoseOracle`], hands it to the session; the chain localiser and
    /// the baseline run and are scored as ever).
    #[serde(default, skip_serializing_if = "UpdaterPoses::is_localiser")]
    pub updater_poses: UpdaterPoses,
    /// Whether scans with a sweep timing (the simulator's `motion-distortion` switch) are
    /// deskewed by the odometry before the estimators see them
    /// (`mapkeeper_harness::Session::set_deskew`). Default true (written only when false).
    #[serde(default = "deskew_default", skip_serializing_if = "is_deskew_default")]
    pub deskew: bool,
}

/// Runner parameters that passed [`RunnerParams::validate`]: made only by
/// [`RunnerParams::checked`] (or [`Checked::assume`] by a caller that checked a whole it is part
/// of, as the validation's parameters are checked once per seed).
#[derive(Clone, Copy, Debug)]
pub struct Checked<'a>(&'a RunnerParams);

impl<'a> Checked<'a> {
    /// `params` as checked: for a caller whose own `validate` has just checked them as part of
    /// a larger whole (e.g. `ValidationParams::validate` checks its `runner`), or that changed
    /// only flags `validate` does not constrain. Debug builds check them again.
    pub fn assume(params: &'a RunnerParams) -> Self {
        debug_assert!(params.validate().is_ok(), "Checked::assume on parameters that do not validate");
        Checked(params)
    }

    /// The parameters.
    pub fn params(&self) -> &'a RunnerParams {
        self.0
    }
}

/// How a run is executed, apart from what it computes ([`RunnerParams`]) and given beside it
/// ([`Execution`]), never inside it: no option changes a bit of any output, only the threads the
/// run uses (tests: `determinism.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RunOptions {
    /// Run the baseline localiser on a thread of its own, fed the same frames in the same
    /// order (shorter wall time). Default true.
    pub parallel_baseline: bool,
    /// Run the simulator on a thread of its own, ahead of the estimators
    /// ([`crate::sim_source::AheadSource`]; shorter wall time when a core is free, a little
    /// more CPU for the copies it keeps). Default false.
    pub simulate_ahead: bool,
    /// Integrate the fresh map ([`RunnerParams::fresh_map`]) on a thread of its own, fed the
    /// same scans and poses in the same order
    /// ([`mapkeeper_harness::jobs::map::ThreadedEstimateMapper`]; shorter wall time when a core
    /// is free). Default true.
    pub parallel_fresh_map: bool,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self { parallel_baseline: true, simulate_ahead: false, parallel_fresh_map: true }
    }
}

/// How a run is executed, beside what it computes ([`RunnerParams`]) and what it is given
/// ([`RunInputs`]): its threads ([`RunOptions`]) and the clock the updater's time per processed
/// scan is read from (the only thing of a run that is measured, not computed).
#[derive(Clone, Copy)]
pub struct Execution<'a> {
    /// The threads the run uses.
    pub options: RunOptions,
    /// The clock of the updater's time per scan.
    pub clock: &'a dyn Clock,
}

impl<'a> Execution<'a> {
    /// The default threads, timed by `clock`.
    pub fn timed_by(clock: &'a dyn Clock) -> Self {
        Execution { options: RunOptions::default(), clock }
    }
}

fn deskew_default() -> bool {
    true
}

fn is_deskew_default(on: &bool) -> bool {
    *on
}

/// How the fresh map of a run is made ([`RunnerParams::fresh_map`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FreshMapParams {
    /// The log-odds mapper.
    pub mapper: mapkeeper_grid::mapper::MapperParams,
    /// Integrate every k-th processed step (≥ 1).
    pub scan_stride: u32,
}

impl Default for RunnerParams {
    fn default() -> Self {
        Self {
            sim: SimParams::default(),
            localiser: "mapkeeper".into(),
            filter: FilterParams::default(),
            updater: UpdaterParams::paper(),
            start_error_m: 0.05,
            start_error_yaw_rad: 1f64.to_radians(),
            init_sigma_xy_m: 0.1,
            init_sigma_yaw_rad: 0.05,
            run_updater: true,
            run_baseline: true,
            stop_on_lost: true,
            lost_wait_s: mapkeeper_harness::DEFAULT_LOST_WAIT_S,
            lost_walk_s: 0.0,
            handover_hold: HandoverHold::default(),
            max_sim_time_s: 300.0,
            record_trajectories: false,
            kidnap: None,
            record_timeline: false,
            fresh_map: None,
            pose_error: None,
            robot_kidnap: None,
            updater_poses: UpdaterPoses::Localiser,
            deskew: true,
        }
    }
}

impl RunnerParams {
    /// Both localisers from the preset `name` (`filter` and `localiser` set).
    pub fn set_localiser(&mut self, name: &str) -> Result<(), ExperimentError> {
        self.filter = FilterParams::preset(name)?;
        self.localiser = name.to_string();
        Ok(())
    }

    /// The parameters, checked once where a run starts ([`RunnerParams::validate`]): what
    /// [`run_world_with`] takes, so a chain of worlds checks its parameters once, not per world.
    pub fn checked(&self) -> Result<Checked<'_>, ExperimentError> {
        self.validate()?;
        Ok(Checked(self))
    }

    /// Checks every field (and the components' own parameters).
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if !mapkeeper_localiser::LOCALISER_PRESETS.contains(&self.localiser.as_str()) {
            return Err(ExperimentError::InvalidParam(ParamError::rule(
                "localiser",
                format!(
                    "unknown localiser preset '{}' (known: {})",
                    self.localiser,
                    mapkeeper_localiser::LOCALISER_PRESETS.join(", ")
                ),
            )));
        }
        self.sim.validate()?;
        self.filter.validate()?;
        self.updater.validate()?;
        if let Some(f) = &self.fresh_map {
            if f.scan_stride == 0 {
                return Err(ExperimentError::InvalidParam(ParamError::rule("fresh_map.scan_stride", "must be ≥ 1")));
            }
            f.mapper
                .validate()
                .map_err(|e| ExperimentError::InvalidParam(ParamError::rule("fresh_map.mapper", e.to_string())))?;
        }
        let bad = |name, v: f64| ExperimentError::InvalidParam(ParamError::new(name, v, "must be finite and ≥ 0"));
        for (name, v) in [
            ("start_error_m", self.start_error_m),
            ("start_error_yaw_rad", self.start_error_yaw_rad),
            ("init_sigma_xy_m", self.init_sigma_xy_m),
            ("init_sigma_yaw_rad", self.init_sigma_yaw_rad),
            ("lost_wait_s", self.lost_wait_s),
            ("lost_walk_s", self.lost_walk_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(name, v));
            }
        }
        if !(self.max_sim_time_s.is_finite() && self.max_sim_time_s > 0.0) {
            return Err(ParamError::new("max_sim_time_s", self.max_sim_time_s, "must be finite and > 0 s").into());
        }
        self.handover_hold.validate()?;
        if let Some(k) = &self.kidnap {
            k.validate()?;
        }
        if let Some(h) = &self.pose_error {
            h.validate()?;
        }
        if let Some(r) = &self.robot_kidnap {
            if self.kidnap.is_some() {
                return Err(ExperimentError::InvalidParam(ParamError::rule(
                    "robot_kidnap",
                    "a run has one kidnap: of the estimate (kidnap) or of the robot (robot_kidnap)",
                )));
            }
            r.validate()?;
        }
        self.updater_poses.validate()
    }
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
    /// Largest change state seen (`MapUpdater::change_state_bytes`: the sparse cell buffers;
    /// grows with the touched cells).
    pub max_state_bytes: u64,
    /// The updater's map-sized caches at the end of the run (`MapUpdater::cache_bytes`: both
    /// grids, clearance field, interior mask, score grid; grows with the map, not the scans).
    #[serde(default)]
    pub cache_bytes: u64,
    /// Registration before writing: steps refined, refused (by reason), writes withheld, and
    /// the distributions of the corrections (zeros when registration is off).
    #[serde(default)]
    pub registration: mapkeeper_updater::RegistrationStats,
    /// "Changed" votes of the memory's healing rule.
    #[serde(default)]
    pub heal_votes: u64,
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
    /// When the held pose error began and ended, if one was asked for and its time reached.
    pub pose_error: Option<PoseErrorRecord>,
    /// Every processed step, if asked for.
    pub timeline: Vec<TimelineSample>,
    /// The reaction to Lost: episodes, attempts, recoveries, give-ups, time stopped.
    pub lost: LostCounts,
    /// The Lost episodes, in order.
    pub lost_episodes: Vec<LostEpisode>,
    /// The fresh map of this run at the estimated poses ([`RunnerParams::fresh_map`]).
    pub fresh_map: Option<OccupancyGrid>,
    /// The updater's cross-world memory to hand to the next world with [`WorldRun::map`]
    /// (empty when the memory is off).
    pub memory: StructureMemory,
    /// The error of the poses the updater was given, with a pose source other than the chain
    /// localiser ([`RunnerParams::updater_poses`]; `None` with the localiser, whose error is
    /// `chain`).
    pub given_pose: Option<GivenPoseStats>,
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

pub(crate) fn init_cov(params: &RunnerParams) -> [[f64; 3]; 3] {
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
    /// The updater's cross-world memory of M_{i-1} (`None`: M_{i-1} is a surveyed map, every
    /// occupied cell established; ignored unless the updater's memory is on).
    pub prev_memory: Option<&'a StructureMemory>,
}

/// Runs one world with the default threads ([`RunOptions`]). All random streams derive from
/// `seed` and `label` (e.g. `"W007"`); the updater's time per processed scan is read from
/// `clock`. The parameters are checked here, where the run starts.
pub fn run_world(
    inputs: &RunInputs<'_>,
    params: &RunnerParams,
    seed: u64,
    label: &str,
    clock: &dyn Clock,
) -> Result<WorldRun, ExperimentError> {
    run_world_with(inputs, params.checked()?, seed, label, &Execution::timed_by(clock), &mut [])
}

/// The baseline localiser on M_1 (if the run has one), started where the chain starts.
fn baseline(
    params: &RunnerParams,
    baseline_map: &OccupancyGrid,
    seed: u64,
    label: &str,
    start_est: Pose2,
    cov: mapkeeper_localiser::Covariance3,
    threaded: bool,
) -> Result<Option<Baseline>, ExperimentError> {
    if !params.run_baseline {
        return Ok(None);
    }
    let mut b = Localiser::new(baseline_map, params.filter, stream_seed(seed, &format!("baseline/{label}")))?;
    b.init_pose(start_est, cov)?;
    Ok(Some(if threaded { Baseline::threaded(b) } else { Baseline::inline(b) }))
}

/// The run's updater on M_{i-1} with its memory, if the run has one.
fn updater(
    params: &RunnerParams,
    prev_map: &OccupancyGrid,
    prev_memory: Option<&StructureMemory>,
) -> Result<Option<MapUpdater>, ExperimentError> {
    if !params.run_updater {
        return Ok(None);
    }
    let memory = prev_memory.cloned().unwrap_or_default();
    Ok(Some(MapUpdater::with_memory(prev_map.clone(), params.updater.clone(), memory)?))
}

/// The mapper of a run's fresh map: on the loop's thread or on one of its own (the same map).
enum FreshMapper {
    Inline(EstimateMapper),
    Threaded(ThreadedEstimateMapper),
}

impl FreshMapper {
    fn observer(&mut self) -> &mut dyn Observer {
        match self {
            Self::Inline(m) => m,
            Self::Threaded(m) => m,
        }
    }

    fn finish(self) -> Result<OccupancyGrid, ExperimentError> {
        Ok(match self {
            Self::Inline(m) => m.mapper.to_grid(),
            Self::Threaded(m) => m.finish()?.mapper.to_grid(),
        })
    }
}

/// The mapper of the run's fresh map on M_{i-1}'s grid, if the run makes one.
fn fresh_mapper(
    params: &RunnerParams,
    prev_map: &OccupancyGrid,
    threaded: bool,
) -> Result<Option<FreshMapper>, ExperimentError> {
    let Some(f) = params.fresh_map else { return Ok(None) };
    let m = EstimateMapper::new(*prev_map.geometry(), f.mapper, u64::from(f.scan_stride))
        .map_err(|e| ExperimentError::InvalidParam(ParamError::rule("fresh_map", e.to_string())))?;
    Ok(Some(if threaded { FreshMapper::Threaded(ThreadedEstimateMapper::spawn(m)) } else { FreshMapper::Inline(m) }))
}

/// The session of one world: the chain localiser, the updater and the baseline, with the
/// run's deskewing.
fn session<'c>(
    params: &RunnerParams,
    chain: Localiser,
    updater: Option<MapUpdater>,
    baseline: Option<Baseline>,
    clock: &'c dyn Clock,
) -> Session<'c> {
    let mut session = Session::new(PoseSource::Localiser(Box::new(chain)), updater, baseline, clock);
    session.set_deskew(params.deskew);
    session
}

/// The reaction to Lost the runner's parameters say: stop, wait, hold, walk.
fn lost_policy(params: &RunnerParams, cov: [[f64; 3]; 3]) -> LostPolicy {
    LostPolicy::new(params.stop_on_lost, params.lost_wait_s, cov)
        .with_hold(params.handover_hold)
        .with_walk(params.lost_walk_s)
}

/// [`run_world`] with parameters checked where the run started ([`RunnerParams::checked`]),
/// run as `exec` says (threads, clock), and `extra` observers seeing every step after the run's
/// own (an MCAP recorder, say); observers cannot change the run. With
/// [`RunOptions::parallel_baseline`] the baseline localiser runs on its own thread, fed the same
/// scan ticks in the same order, so the results are the same either way.
pub fn run_world_with(
    inputs: &RunInputs<'_>,
    params: Checked<'_>,
    seed: u64,
    label: &str,
    exec: &Execution<'_>,
    extra: &mut [&mut dyn Observer],
) -> Result<WorldRun, ExperimentError> {
    let Checked(params) = params;
    let (options, clock) = (exec.options, exec.clock);
    let RunInputs { world, route, prev_map, baseline_map, prev_memory } = *inputs;
    let mut sim = Simulator::new(world, params.sim.clone(), stream_seed(seed, &format!("sim/{label}")))?;
    sim.set_route(route.points());
    let start_est = perturbed_start(sim.true_pose(), params, seed, &format!("start/{label}"));
    let cov = init_cov(params);
    let mut chain = Localiser::new(prev_map, params.filter, stream_seed(seed, &format!("chain/{label}")))?;
    chain.init_pose(start_est, cov)?;
    let baseline = baseline(params, baseline_map, seed, label, start_est, cov, options.parallel_baseline)?;
    let updater = updater(params, prev_map, prev_memory)?;
    let mut session = session(params, chain, updater, baseline, clock);
    let mut source = Simulated::new(SimSource::new(sim, params.max_sim_time_s), options.simulate_ahead);
    let mut score = LocScore::new(params.record_trajectories);
    let mut work = UpdaterWork::default();
    let mut timeline = TimelineRecorder::default();
    let mut kidnap = params.kidnap.map(KidnapControl::new).or(params.robot_kidnap.map(KidnapControl::robot));
    let mut pose_error = params.pose_error.map(PoseErrorControl::new);
    let mut lost = lost_policy(params, cov);
    let mut oracle = PoseOracle::new(&params.updater_poses, seed, label);
    let mut given = GivenPoseError::default();
    let mut fresh = fresh_mapper(params, prev_map, options.parallel_fresh_map)?;
    let result = {
        let mut observers: Vec<&mut dyn Observer> = vec![&mut score, &mut work];
        if let Some(f) = fresh.as_mut() {
            observers.push(f.observer());
        }
        if params.record_timeline {
            observers.push(&mut timeline);
        }
        let mut controls: Vec<&mut dyn Control> = Vec::new();
        if let Some(o) = oracle.as_mut() {
            controls.push(o);
            observers.push(&mut given);
        }
        if let Some(k) = kidnap.as_mut() {
            controls.push(k);
        }
        if let Some(h) = pose_error.as_mut() {
            controls.push(h);
        }
        controls.push(&mut lost);
        for o in extra.iter_mut() {
            observers.push(&mut **o);
        }
        mapkeeper_harness::run(&mut source, &mut session, &mut controls, &mut observers)
    };
    // Join the baseline and the fresh map's threads before reporting any error of the loop.
    let out = session.finish()?;
    let source = source.finish().map_err(mapkeeper_harness::HarnessError::from)?;
    let fresh_map = fresh.map(FreshMapper::finish).transpose()?;
    result?;
    let baseline_stats = if params.run_baseline { score.score_baseline(&out.baseline) } else { LocStats::default() };
    let (map, updater, memory) = match &out.updater {
        Some(u) => (u.map().clone(), UpdaterCounts::from_run(u, &work), u.next_memory()),
        None => (prev_map.clone(), UpdaterCounts::default(), prev_memory.cloned().unwrap_or_default()),
    };
    let cells_changed = map.cells().iter().zip(prev_map.cells()).filter(|(a, b)| a != b).count() as u64;
    let (lost_counts, lost_episodes) = lost.finish();
    Ok(WorldRun {
        map,
        chain: score.chain.stats(),
        baseline: baseline_stats,
        updater,
        cells_changed,
        collisions: source.collisions(),
        sim_time_s: source.sim_time_s(),
        distance_m: source.distance_m(),
        route_done: source.route_done(),
        scan_times_us: work.step_times_us,
        trajectories: score.trajectories,
        chain_errors: score.chain_errors,
        kidnap: kidnap.and_then(KidnapControl::into_record),
        pose_error: pose_error.and_then(PoseErrorControl::into_record),
        timeline: timeline.samples,
        lost: lost_counts,
        lost_episodes,
        fresh_map,
        memory,
        given_pose: oracle.map(|_| given.stats()),
    })
}

impl UpdaterCounts {
    /// The counts of a finished run: verdicts and recoveries from the updater's own statistics,
    /// beams and the largest change state from the loop's [`UpdaterWork`].
    pub fn from_run(updater: &MapUpdater, work: &UpdaterWork) -> Self {
        let s = updater.stats();
        Self {
            processed: s.processed,
            update: s.updates,
            suspend: s.suspends,
            lost: s.losts,
            recovered: s.recoveries,
            not_recovered: s.failed_recoveries,
            beams: work.beams,
            cell_changes: s.cell_changes,
            max_state_bytes: work.max_state_bytes,
            cache_bytes: updater.cache_bytes() as u64,
            registration: s.registration,
            heal_votes: s.heal_votes,
        }
    }
}

/// Whether a duration is 0 (then not written).
fn is_zero_f64(v: &f64) -> bool {
    *v == 0.0
}
