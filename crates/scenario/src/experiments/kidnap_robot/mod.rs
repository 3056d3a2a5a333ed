//! Real kidnaps (issue 12, item 6; `docs/recovery.md`, "Real kidnaps"): the robot itself is
//! moved (its odometry does not see it) in a late, stale world, and nobody tells the localiser
//! or the updater. Each trial draws a world W_k (k in `min_world..=max_world`), a place on the
//! tour, a time, a displacement (0.5-3 m, any direction) and a turn (up to ±180°); the target
//! is put in free space of G_k (the drawn direction first, then others, then shorter). Each
//! trial is paired with the same run without the kidnap (identical until then): the false-Lost
//! rate of a well-localised robot in a stale world, and the map damage (CC, MS, OPDF of the
//! reference's M_k minus the kidnapped run's, against G_k). A recovery (the localiser's error
//! under the success criterion from some time on, to the end) counts for pose updating if a
//! pose from pose updating came at or before the start of that good stretch, for the filter
//! otherwise.

pub mod report;
pub mod summary;

use crate::experiments::ExperimentError;
use crate::experiments::scores::Scores;
use crate::experiments::scores::scores;
use mapkeeper_closed_loop::controls::{KidnapRecord, RobotKidnap, TimelineSample, TrackSample};
use mapkeeper_closed_loop::setup::chain::ChainMap;
use mapkeeper_closed_loop::setup::params::{RecoveryParams, SuccessCriterion};
use mapkeeper_closed_loop::setup::{Setup, prepare, recovery_time};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_common::ParamError;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, Pose2, wrap_angle};
use mapkeeper_sim::World;
use mapkeeper_sim::seeds::stream_rng;
use mapkeeper_updater::{StructureMemory, UpdaterParams};
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::f64::consts::PI;
pub use summary::{KidnapBin, KidnapRobotSummary, summarise_robot_kidnap};

/// Parameters (`[kidnap_robot]` of a parameter file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KidnapRobotParams {
    /// Trials. Default 100.
    pub trials: usize,
    /// Updater preset. Default `paper`.
    pub preset: String,
    /// Worlds W_min … W_max. Default 50.
    pub min_world: usize,
    /// Default 100.
    pub max_world: usize,
    /// Displacement range, metres. Default 0.5.
    pub min_displacement_m: f64,
    /// Default 3.0.
    pub max_displacement_m: f64,
    /// Largest turn, radians. Default π.
    pub max_yaw_rad: f64,
    /// Kidnap time range, seconds. Default 3.
    pub kidnap_min_s: f64,
    /// Default 6.
    pub kidnap_max_s: f64,
    /// A trial recovers if its good stretch starts within this long of the kidnap, seconds.
    /// Default 20.
    pub recovery_window_s: f64,
    /// Length of the drive from the start place, metres. Default 60.
    pub route_length_m: f64,
    /// The target must have free cells of G_k within this radius, metres. Default 0.5.
    pub free_radius_m: f64,
    /// A reference run's localiser counts as well localised at a step when its error is at
    /// most this, metres (a Lost then is a false alarm proper). Default 0.05, the clean
    /// tolerance of `experiment check-detection`.
    pub well_localised_max_error_m: f64,
    /// …and its heading error at most this, radians. Default 2° (0.0349).
    pub well_localised_max_yaw_rad: f64,
    /// The maps the robot localises on (and the updater starts from), each trial run on each,
    /// reported side by side. Default all three: `w1`, `chain`, `truth` ([`KidnapMap`]).
    pub maps: Vec<KidnapMap>,
}

/// The map the robot localises on in W_k when it is kidnapped (`[kidnap_robot] maps`,
/// `--maps`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KidnapMap {
    /// The map of W_1 (`[recovery] initial_map`: G_1 by default), k − 1 worlds stale: the
    /// harshest case, and the suite's only one before issue 54.
    W1,
    /// M_{k-1}: the map the preset's updater kept through W_2 … W_{k-1} from M_1, with its
    /// cross-world memory, as `validate` runs the chain with the same seed (the lifelong
    /// setting: the robot's map kept current by the updater under test).
    Chain,
    /// G_{k-1}, the true map of the world before: a perfect updater's map.
    Truth,
}

impl KidnapMap {
    /// Every map, in report order.
    pub const ALL: [KidnapMap; 3] = [KidnapMap::W1, KidnapMap::Chain, KidnapMap::Truth];

    /// `w1`, `chain` or `truth` (as serialised).
    pub fn name(self) -> &'static str {
        match self {
            KidnapMap::W1 => "w1",
            KidnapMap::Chain => "chain",
            KidnapMap::Truth => "truth",
        }
    }

    /// How a report names it: `W_1's map`, `M_{k-1} (chain)`, `G_{k-1} (truth)`.
    pub fn label(self) -> &'static str {
        match self {
            KidnapMap::W1 => "W_1's map",
            KidnapMap::Chain => "M_{k-1} (chain)",
            KidnapMap::Truth => "G_{k-1} (truth)",
        }
    }

    /// A comma-separated list of names (`w1,chain,truth`), each once, at least one; the
    /// error says which name is unknown or repeated.
    pub fn parse_list(s: &str) -> Result<Vec<KidnapMap>, String> {
        let mut out = Vec::new();
        for name in s.split(',').map(str::trim) {
            let m = KidnapMap::ALL
                .into_iter()
                .find(|m| m.name() == name)
                .ok_or_else(|| format!("unknown map {name:?} (expected w1, chain or truth)"))?;
            if out.contains(&m) {
                return Err(format!("map {name:?} given twice"));
            }
            out.push(m);
        }
        Ok(out)
    }
}

impl Default for KidnapRobotParams {
    fn default() -> Self {
        Self {
            trials: 100,
            preset: "paper".into(),
            min_world: 50,
            max_world: 100,
            min_displacement_m: 0.5,
            max_displacement_m: 3.0,
            max_yaw_rad: PI,
            kidnap_min_s: 3.0,
            kidnap_max_s: 6.0,
            recovery_window_s: 20.0,
            route_length_m: 60.0,
            free_radius_m: 0.5,
            well_localised_max_error_m: 0.05,
            well_localised_max_yaw_rad: 2f64.to_radians(),
            maps: KidnapMap::ALL.to_vec(),
        }
    }
}

impl KidnapRobotParams {
    /// The short setting of `--quick` (tests, a first look): 3 trials in W_2-W_3, 15 m, a 6 s window.
    pub fn quick() -> Self {
        Self { trials: 3, min_world: 2, max_world: 3, recovery_window_s: 6.0, route_length_m: 15.0, ..Self::default() }
    }
}

/// The largest free disc a kidnap's destination may be asked to have around it, metres (a
/// disc wider than a warehouse aisle never fits; the bound keeps the check's cell loop finite).
pub const MAX_FREE_RADIUS_M: f64 = 5.0;

impl KidnapRobotParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if self.trials == 0 {
            return Err(ExperimentError::from(ParamError::rule("kidnap_robot.trials", "must be ≥ 1")));
        }
        UpdaterParams::preset(&self.preset)
            .map_err(|e| ExperimentError::from(ParamError::rule("kidnap_robot.preset", e.to_string())))?;
        if self.min_world < 2 || self.min_world > self.max_world || self.max_world > 1000 {
            return Err(ExperimentError::from(ParamError::rule(
                "kidnap_robot.min_world",
                format!("needs 2 ≤ min_world ≤ max_world ≤ 1000, got {}..{}", self.min_world, self.max_world),
            )));
        }
        for (name, v) in [
            ("kidnap_robot.min_displacement_m", self.min_displacement_m),
            ("kidnap_robot.max_displacement_m", self.max_displacement_m),
            ("kidnap_robot.max_yaw_rad", self.max_yaw_rad),
            ("kidnap_robot.kidnap_min_s", self.kidnap_min_s),
            ("kidnap_robot.kidnap_max_s", self.kidnap_max_s),
            ("kidnap_robot.free_radius_m", self.free_radius_m),
            ("kidnap_robot.well_localised_max_error_m", self.well_localised_max_error_m),
            ("kidnap_robot.well_localised_max_yaw_rad", self.well_localised_max_yaw_rad),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ExperimentError::from(ParamError::new(name, v, "must be finite and ≥ 0")));
            }
        }
        for (name, v) in [
            ("kidnap_robot.recovery_window_s", self.recovery_window_s),
            ("kidnap_robot.route_length_m", self.route_length_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ExperimentError::from(ParamError::new(name, v, "must be finite and > 0")));
            }
        }
        if self.min_displacement_m > self.max_displacement_m || self.kidnap_min_s > self.kidnap_max_s {
            return Err(ExperimentError::from(ParamError::rule(
                "kidnap_robot.min_displacement_m",
                "ranges need min ≤ max",
            )));
        }
        crate::experiments::check_turn("kidnap_robot.max_yaw_rad", self.max_yaw_rad)?;
        if self.maps.is_empty() {
            return Err(ExperimentError::from(ParamError::rule("kidnap_robot.maps", "needs at least one map")));
        }
        if let Some(m) = self.maps.iter().enumerate().find_map(|(i, m)| self.maps[..i].contains(m).then_some(m)) {
            return Err(ExperimentError::from(ParamError::rule(
                "kidnap_robot.maps",
                format!("map {:?} given twice", m.name()),
            )));
        }
        if self.free_radius_m > MAX_FREE_RADIUS_M {
            return Err(ExperimentError::from(ParamError::rule(
                "kidnap_robot.free_radius_m",
                format!("must be at most {MAX_FREE_RADIUS_M} m, got {}", self.free_radius_m),
            )));
        }
        Ok(())
    }
}

/// One trial's draw.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotKidnapDraw {
    /// Trial index.
    pub trial: usize,
    /// k of W_k.
    pub world: usize,
    /// Start on the tour, metres.
    pub tour_position_m: f64,
    /// Kidnap time, seconds.
    pub kidnap_s: f64,
    /// Drawn displacement, metres.
    pub displacement_m: f64,
    /// Its direction, map frame, radians.
    pub direction_rad: f64,
    /// Turn, radians.
    pub yaw_rad: f64,
}

/// The draw of trial `t`.
pub fn draw_robot_kidnap(p: &KidnapRobotParams, tour_length_m: f64, seed: u64, t: usize) -> RobotKidnapDraw {
    let mut rng = stream_rng(seed, &format!("kidnap-robot/{t:05}"));
    let mut u = |a: f64, b: f64| if b > a { rng.random_range(a..b) } else { a };
    RobotKidnapDraw {
        trial: t,
        world: p.min_world
            + (u(0.0, (p.max_world - p.min_world + 1) as f64).floor() as usize).min(p.max_world - p.min_world),
        tour_position_m: u(0.0, tour_length_m),
        kidnap_s: u(p.kidnap_min_s, p.kidnap_max_s),
        displacement_m: u(p.min_displacement_m, p.max_displacement_m),
        direction_rad: u(-PI, PI),
        yaw_rad: u(-p.max_yaw_rad, p.max_yaw_rad),
    }
}

/// Whether every cell of `g` within `r` of `p` is free.
fn free_disc(g: &OccupancyGrid, p: Point2, r: f64) -> bool {
    let res = g.geometry().resolution_m();
    let n = (r / res).ceil() as i64;
    for dy in -n..=n {
        for dx in -n..=n {
            let (ox, oy) = (dx as f64 * res, dy as f64 * res);
            if ox * ox + oy * oy > r * r {
                continue;
            }
            let q = Point2::new(p.x + ox, p.y + oy);
            match g.geometry().world_to_cell(q).and_then(|c| g.get(c)) {
                Some(CellState::Free) => {}
                _ => return false,
            }
        }
    }
    true
}

/// The target of a kidnap from `from`: the drawn direction and distance if the disc there is
/// free in `g`, else the other directions (15° steps, nearest first), then 3/4 and 1/2 of the
/// distance (never below `min_m`). `None` if nothing is free.
pub fn kidnap_target(g: &OccupancyGrid, from: Pose2, d: &RobotKidnapDraw, min_m: f64, r: f64) -> Option<Pose2> {
    for scale in [1.0, 0.75, 0.5] {
        let dist = (d.displacement_m * scale).max(min_m);
        for j in 0..24 {
            let k = if j % 2 == 0 { j / 2 } else { -(j / 2 + 1) };
            let a = d.direction_rad + f64::from(k) * 15f64.to_radians();
            let p = Point2::new(from.x + dist * a.cos(), from.y + dist * a.sin());
            if free_disc(g, p, r) {
                return Some(Pose2::new(p.x, p.y, wrap_angle(from.yaw + d.yaw_rad)));
            }
        }
    }
    None
}

/// One trial on one map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotKidnapTrial {
    /// The draw.
    pub draw: RobotKidnapDraw,
    /// The map the robot localised on.
    #[serde(default = "first_world_map")]
    pub map: KidnapMap,
    /// The robot was moved (a free target was found and the time reached).
    pub applied: bool,
    /// The displacement applied, metres.
    pub applied_displacement_m: Option<f64>,
    /// The check said Lost after the kidnap.
    pub detected: bool,
    /// Kidnap to the first Lost, seconds.
    pub detection_delay_s: Option<f64>,
    /// Recovered within the window, by pose updating.
    pub recovered_pose_updating: bool,
    /// Recovered within the window, by the filter alone.
    pub recovered_filter: bool,
    /// Recovered by pose updating with a pose from the global search (`mapkeeper`): the last
    /// pose handed over at or before the good stretch began came from it.
    #[serde(default)]
    pub recovered_global_search: bool,
    /// Kidnap to the start of the good stretch, seconds.
    pub recovery_s: Option<f64>,
    /// The first Lost after the kidnap (the robot stops there) to the first right pose pose
    /// updating handed over (error under the success criterion), seconds; `None`: none came.
    #[serde(default)]
    pub pose_found_s: Option<f64>,
    /// The reference run's (no kidnap) final localiser error, metres: what "recovered" can
    /// reach in this world at all.
    #[serde(default)]
    pub reference_final_error_m: Option<f64>,
    /// Whether the run without kidnap kept its localiser under the success criterion at every
    /// scan tick from the kidnap's time to the end: how often the localiser alone stays right
    /// over that stretch in this world on this map, without a kidnap, a handover or a hold
    /// (`None`: no pose recorded there).
    #[serde(default)]
    pub reference_held: Option<bool>,
    /// Right poses (under the success criterion) pose updating handed over after the kidnap.
    #[serde(default)]
    pub handovers_right: usize,
    /// …of them held: the localiser's error stayed under the criterion at every scan tick from
    /// the handover to the end of the run.
    #[serde(default)]
    pub handovers_held: usize,
    /// Attempts of pose updating after the kidnap that found no pose (refused), and those of
    /// them refused as ambiguous (two distant places fitted about equally well).
    #[serde(default)]
    pub refused_attempts: u64,
    /// See `refused_attempts`.
    #[serde(default)]
    pub ambiguous_attempts: u64,
    /// Poses from pose updating after the kidnap.
    pub pose_recoveries: usize,
    /// …of them wrong (error above the criterion).
    pub wrong_pose_recoveries: usize,
    /// The localiser's final error, metres.
    pub final_error_m: Option<f64>,
    /// Lost verdicts of the run without kidnap.
    pub reference_lost: u64,
    /// …of them while its localiser was right by the success criterion (error under 0.2 m
    /// and 5° by default): a localiser that may still be off by a few degrees.
    #[serde(default)]
    pub reference_lost_right_pose: u64,
    /// …of them while its localiser was well localised (`well_localised_max_error_m`,
    /// `well_localised_max_yaw_rad`): a false alarm proper. The others came while the
    /// localiser had drifted (a Lost that stops the robot, but not a false alarm).
    #[serde(default)]
    pub reference_lost_well_localised: u64,
    /// Checked steps of the run without kidnap.
    #[serde(default)]
    pub reference_steps: u64,
    /// …of them while its localiser was well localised: the
    /// denominator of the per-step false-Lost rate.
    #[serde(default)]
    pub reference_steps_well_localised: u64,
    /// The reference's map against G_k.
    pub reference_scores: Scores,
    /// The kidnapped run's map against G_k.
    pub kidnap_scores: Scores,
}

fn first_world_map() -> KidnapMap {
    KidnapMap::W1
}

fn warehouse() -> String {
    "warehouse".into()
}

/// The whole result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapRobotResults {
    /// Producer and version.
    pub tool: String,
    /// Run seed.
    pub seed: u64,
    /// W_1: `warehouse`, `lab` or the world file (set by the caller).
    #[serde(default = "warehouse")]
    pub world: String,
    /// Wall time (set by the caller).
    pub wall_time_s: f64,
    /// The summary on the first map of `params.maps` (W_1's by default).
    pub kidnap_robot: KidnapRobotSummary,
    /// The summary on each map of `params.maps`, in that order.
    #[serde(default)]
    pub by_map: Vec<KidnapRobotSummary>,
    /// The trials.
    #[serde(skip)]
    pub trials: Vec<RobotKidnapTrial>,
    /// Parameters.
    pub params: KidnapRobotParams,
    /// The loop and worlds.
    pub recovery: RecoveryParams,
}

/// The map (and the memory that came with it) trial `d` localises on with `m`.
fn trial_map<'a>(
    trials: &'a RobotKidnapTrials<'_>,
    m: KidnapMap,
    d: &RobotKidnapDraw,
) -> Result<(&'a OccupancyGrid, Option<&'a StructureMemory>), ExperimentError> {
    let before = d.world - 1;
    match m {
        KidnapMap::W1 => Ok((trials.setup.initial_map(trials.recovery.initial_map), None)),
        KidnapMap::Truth => Ok((trials.setup.world(before)?.1, None)),
        KidnapMap::Chain => match trials.chain.get(&before) {
            Some(c) => Ok((&c.map, Some(&c.memory))),
            None => Err(ExperimentError::InvalidParam(ParamError::rule(
                "kidnap_robot.maps",
                format!("the chain's M_{before} was not run"),
            ))),
        },
    }
}

fn run_trial(
    trials: &RobotKidnapTrials<'_>,
    d: RobotKidnapDraw,
    m: KidnapMap,
) -> Result<RobotKidnapTrial, ExperimentError> {
    let (setup, recovery, p, seed) = (&trials.setup, trials.recovery, trials.p, trials.seed);
    let c = &recovery.success;
    let (map, memory) = trial_map(trials, m, &d)?;
    let mut drive = setup.drive(d.world, map, &recovery.tour, d.tour_position_m, p.route_length_m)?;
    drive.memory = memory;
    let g = drive.truth;
    let mut rp = recovery.runner.clone();
    rp.updater = trials.updater.clone();
    rp.max_sim_time_s = d.kidnap_s + p.recovery_window_s + c.hold_s;
    rp.record_trajectories = true;
    rp.record_timeline = true;
    let label = format!("kidnap-robot-{:05}", d.trial);
    let reference = drive.run(&rp, seed, &label)?;
    let reference_scores = scores(&reference.map, g, &recovery.metrics)?;
    let well_localised = |t: &TimelineSample| {
        t.error_m <= p.well_localised_max_error_m && t.yaw_error_rad <= p.well_localised_max_yaw_rad
    };
    let at_ns = (d.kidnap_s * 1e9).ceil() as u64;
    let from =
        reference.trajectories.as_ref().and_then(|t| t.truth.iter().find(|s| s.stamp_ns >= at_ns)).map(|s| s.pose);
    let target = from.and_then(|f| kidnap_target(g, f, &d, p.min_displacement_m, p.free_radius_m));
    let mut out = RobotKidnapTrial {
        draw: d,
        map: m,
        applied: false,
        applied_displacement_m: None,
        detected: false,
        detection_delay_s: None,
        recovered_pose_updating: false,
        recovered_filter: false,
        recovered_global_search: false,
        recovery_s: None,
        pose_found_s: None,
        reference_final_error_m: final_chain_error(reference.trajectories.as_ref()),
        reference_held: held_from(reference.trajectories.as_ref(), at_ns, c),
        handovers_right: 0,
        handovers_held: 0,
        refused_attempts: 0,
        ambiguous_attempts: 0,
        pose_recoveries: 0,
        wrong_pose_recoveries: 0,
        final_error_m: None,
        reference_lost: reference.updater.lost,
        reference_lost_right_pose: lost_where(&reference.timeline, |t| c.holds(t.error_m, t.yaw_error_rad)),
        reference_lost_well_localised: lost_where(&reference.timeline, well_localised),
        reference_steps: reference.timeline.len() as u64,
        reference_steps_well_localised: reference.timeline.iter().filter(|t| well_localised(t)).count() as u64,
        reference_scores,
        kidnap_scores: reference_scores,
    };
    let (Some(from), Some(to)) = (from, target) else { return Ok(out) };
    rp.record_trajectories = false;
    rp.record_timeline = false;
    rp.robot_kidnap = Some(RobotKidnap { at_s: d.kidnap_s, to });
    let run = drive.run(&rp, seed, &label)?;
    out.kidnap_scores = scores(&run.map, g, &recovery.metrics)?;
    let Some(rec) = run.kidnap.as_ref() else { return Ok(out) };
    out.applied = true;
    out.applied_displacement_m = Some(from.distance(&to));
    score_kidnap(&mut out, rec, c, p.recovery_window_s);
    Ok(out)
}

/// What the kidnapped run's record says: detection, recovery (when, by what), the handovers
/// and the final error.
fn score_kidnap(out: &mut RobotKidnapTrial, rec: &KidnapRecord, c: &SuccessCriterion, window_s: f64) {
    out.detected = rec.first_lost_s.is_some();
    out.detection_delay_s = rec.first_lost_s.map(|t| t - rec.at_s);
    // The first sample is the kidnap tick itself, scored against the pose before the move.
    let track = rec.track.get(1..).unwrap_or_default();
    let t_r = recovery_time(track, c);
    out.recovery_s = t_r.map(|t| t - rec.at_s);
    let within = out.recovery_s.is_some_and(|t| t <= window_s + 1e-9);
    let by_pose = rec.recoveries.first().is_some_and(|r| t_r.is_some_and(|t| r.t_s <= t + 1e-9));
    out.recovered_pose_updating = within && by_pose;
    out.recovered_filter = within && !by_pose;
    let last_before = t_r.and_then(|t| rec.recoveries.iter().rposition(|r| r.t_s <= t + 1e-9));
    out.recovered_global_search =
        out.recovered_pose_updating && last_before.is_some_and(|k| rec.recoveries_global.get(k) == Some(&true));
    let right = |r: &TrackSample| c.holds(r.error_m, r.yaw_error_rad);
    out.pose_found_s = match (rec.first_lost_s, rec.recoveries.iter().find(|r| right(r))) {
        (Some(lost), Some(r)) => Some((r.t_s - lost).max(0.0)),
        _ => None,
    };
    (out.handovers_right, out.handovers_held) = handovers(&rec.recoveries, track, c);
    (out.refused_attempts, out.ambiguous_attempts) = (rec.failed_recoveries, rec.ambiguous_recoveries);
    out.pose_recoveries = rec.recoveries.len();
    out.wrong_pose_recoveries = rec.recoveries.iter().filter(|s| !right(s)).count();
    out.final_error_m = track.last().map(|s| s.error_m);
}

/// The right handovers among `recoveries` (poses pose updating handed over, with their true
/// error) and those held: after which every later sample of `track` (the localiser's error at
/// each scan tick; the sample of the handover's own tick is the estimate before it) is under
/// the criterion to the end.
fn handovers(recoveries: &[TrackSample], track: &[TrackSample], c: &SuccessCriterion) -> (usize, usize) {
    let good = |s: &TrackSample| c.holds(s.error_m, s.yaw_error_rad);
    let last_bad = track.iter().rev().find(|s| !good(s)).map(|s| s.t_s);
    let right: Vec<&TrackSample> = recoveries.iter().filter(|r| good(r)).collect();
    let held = right.iter().filter(|r| last_bad.is_none_or(|t| t <= r.t_s + 1e-9)).count();
    (right.len(), held)
}

/// Lost verdicts of a timeline given at steps where `at` holds (the localiser's error then).
fn lost_where(timeline: &[TimelineSample], at: impl Fn(&TimelineSample) -> bool) -> u64 {
    timeline.iter().filter(|t| t.verdict == mapkeeper_updater::Verdict::Lost && at(t)).count() as u64
}

/// Whether the chain localiser of `t` was under the criterion `c` at every pose it gave from
/// `from_ns` on (each against the latest true pose at or before its stamp); `None` without
/// trajectories or a pose there.
fn held_from(t: Option<&mapkeeper_harness::Trajectories>, from_ns: u64, c: &SuccessCriterion) -> Option<bool> {
    let t = t?;
    let mut k = 0;
    let mut any = false;
    for s in t.chain.iter().filter(|s| s.stamp_ns >= from_ns) {
        while k + 1 < t.truth.len() && t.truth[k + 1].stamp_ns <= s.stamp_ns {
            k += 1;
        }
        let truth = t.truth.get(k)?.pose;
        any = true;
        if !c.holds(s.pose.distance(&truth), wrap_angle(s.pose.yaw - truth.yaw).abs()) {
            return Some(false);
        }
    }
    any.then_some(true)
}

/// The chain localiser's error at its last pose, against the truth at the same stamp.
fn final_chain_error(t: Option<&mapkeeper_harness::Trajectories>) -> Option<f64> {
    let t = t?;
    let last = t.chain.last()?;
    let truth = t.truth.iter().rev().find(|s| s.stamp_ns <= last.stamp_ns)?;
    Some(last.pose.distance(&truth.pose))
}

/// The trials of one run of the experiment.
struct RobotKidnapTrials<'a> {
    recovery: &'a RecoveryParams,
    p: &'a KidnapRobotParams,
    seed: u64,
    setup: Setup,
    updater: UpdaterParams,
    /// M_{k-1} (and its memory) for every k a trial drew, when `p.maps` has `chain`.
    chain: BTreeMap<usize, ChainMap>,
}

impl Trials for RobotKidnapTrials<'_> {
    type Job = (RobotKidnapDraw, KidnapMap);
    type Outcome = RobotKidnapTrial;
    type Summary = KidnapRobotResults;

    fn draw(&self) -> Vec<(RobotKidnapDraw, KidnapMap)> {
        let draws = robot_kidnap_draws(self.p, self.recovery, self.seed);
        self.p.maps.iter().flat_map(|&m| draws.iter().map(move |&d| (d, m))).collect()
    }

    fn run(
        &self,
        (d, m): (RobotKidnapDraw, KidnapMap),
        progress: &(dyn Fn() + Sync),
    ) -> Result<RobotKidnapTrial, ExperimentError> {
        let r = run_trial(self, d, m);
        progress();
        r
    }

    fn summarise(&self, trials: Vec<RobotKidnapTrial>) -> Result<KidnapRobotResults, ExperimentError> {
        let by_map: Vec<KidnapRobotSummary> = self
            .p
            .maps
            .iter()
            .map(|&m| {
                let on: Vec<RobotKidnapTrial> = trials.iter().filter(|t| t.map == m).cloned().collect();
                summarise_robot_kidnap(&self.p.preset, m, &on)
            })
            .collect();
        Ok(KidnapRobotResults {
            tool: format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION")),
            seed: self.seed,
            world: warehouse(),
            wall_time_s: 0.0,
            kidnap_robot: by_map
                .first()
                .cloned()
                .unwrap_or_else(|| summarise_robot_kidnap(&self.p.preset, KidnapMap::W1, &[])),
            by_map,
            trials,
            params: self.p.clone(),
            recovery: self.recovery.clone(),
        })
    }
}

/// Generates the worlds and runs every trial ([`run_trials`]: in parallel, collected in order).
pub fn run_kidnap_robot(
    w1: &World,
    recovery: &RecoveryParams,
    p: &KidnapRobotParams,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Result<KidnapRobotResults, ExperimentError> {
    p.validate()?;
    let mut rp = recovery.clone();
    rp.kidnap.stale_max_world = rp.kidnap.stale_max_world.max(p.max_world);
    let setup = prepare(w1, &rp, seed)?;
    let updater = UpdaterParams::preset(&p.preset)?;
    let chain = if p.maps.contains(&KidnapMap::Chain) {
        let keep: BTreeSet<usize> = robot_kidnap_draws(p, recovery, seed).iter().map(|d| d.world - 1).collect();
        let mut runner = recovery.runner.clone();
        runner.updater = updater.clone();
        setup.chain_maps(&runner, seed, &keep)?
    } else {
        BTreeMap::new()
    };
    let trials = RobotKidnapTrials { recovery, p, seed, setup, updater, chain };
    run_trials(&trials, progress)
}

/// Every trial's draw (the same on every map).
fn robot_kidnap_draws(p: &KidnapRobotParams, recovery: &RecoveryParams, seed: u64) -> Vec<RobotKidnapDraw> {
    let tour_len = recovery.tour.length_m();
    (0..p.trials).map(|t| draw_robot_kidnap(p, tour_len, seed, t)).collect()
}

#[cfg(test)]
mod tests;
