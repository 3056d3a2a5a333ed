//! Real kidnaps from real logs (issue 52, item 4): a log spliced at a drawn cut ([`splice`](super::splice))
//! is replayed, over a window around the cut, by the chain localiser and the updater with the
//! paper's reaction to Lost (`update_log` with [`PoseInput::Localise`]), on each map given
//! (the stale map, G) for each localiser and updater preset; each trial is paired with the
//! same window unspliced, from the same start with the same seed, on which any Lost is a false
//! Lost.
//!
//! **Outcomes** of a trial ([`KidnapTrial`]; the judging is [`classify_recovery`] and
//! [`wrong_poses`]): *recovered* when the localiser's estimate is within `recovered_max_error_m`
//! and `recovered_max_yaw_deg` of the reference (strictly: 0.2 m, 5°) from some step at most
//! `recovery_window_s` (10 s) after the cut to the end of the window; the time to recover is
//! from the cut (`t_a`, the last scan before it) to the first step of that last good stretch,
//! in seconds and in scans (the first scan after the cut is scan 1: on the Intel and ACES logs
//! 10 s is only three or four scans). *Wrong pose accepted*: a pose that pose updating handed
//! over (to the localiser, by the Lost policy) lying `wrong_min_error_m` (0.3 m) or
//! `wrong_min_yaw_deg` (5°) or more off the reference at its step. *False Lost*: a Lost episode
//! on the unspliced run. A summary per (map, localiser, preset) gives the rates
//! ([`KidnapSummary`]); the targets of the issue (≥ 90 % recovered, ≤ 1 % wrong, ≤ 2 % false
//! Lost) are reported, not asserted.
//!
//! A cut moves the robot at least `cuts.min_jump_m` (0.5 m, checked positive), so an estimate
//! that simply carries on with the odometry cannot count as recovered.

use super::splice::{CutDraw, CutParams, draw_cuts};
use crate::experiments::ExperimentError;
use crate::experiments::reference::Dataset;
use crate::stats::{frac, median, percentile};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_common::{ParamError, stream_seed};
use mapkeeper_grid::{OccupancyGrid, Pose2, angle_diff};
use mapkeeper_harness::jobs::update::{PoseInput, UpdateRun, update_log};
use mapkeeper_harness::{DEFAULT_SYNC_WINDOW_NS, LogSource, NoClock, OdometryAt, ReplayOptions};
use mapkeeper_localiser::FilterParams;
use mapkeeper_sensor::{SensorLog, StampedPose, interpolate};
use mapkeeper_updater::UpdaterParams;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Parameters (`[real_kidnap]` of a parameter file).
///
/// ```
/// use mapkeeper_scenario::experiments::real_scans::kidnap::RealKidnapParams;
/// let mut p = RealKidnapParams::default();
/// p.localisers.push("amcl".into());
/// assert!(p.validate().is_ok());
/// p.presets = vec!["nope".into()];
/// assert_eq!(p.validate().unwrap_err().name, "presets");
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RealKidnapParams {
    /// How the cuts and their windows are drawn ([`CutParams`]; default 20 cuts of 0.5-5 m).
    pub cuts: CutParams,
    /// Localiser seeds per cut: each (cut, seed) pair is a trial. Default 1.
    pub seeds_per_cut: usize,
    /// The updater presets, each run on every trial. Default `paper`, `authors`, `mapkeeper`.
    pub presets: Vec<String>,
    /// The localiser presets, each run on every trial. Default `mapkeeper-real` (`amcl` is the
    /// other choice for logs).
    pub localisers: Vec<String>,
    /// Recovered: the estimate strictly within this of the reference, metres. Default 0.2.
    pub recovered_max_error_m: f64,
    /// …and strictly within this in heading, degrees. Default 5.
    pub recovered_max_yaw_deg: f64,
    /// …from some step at most this long after the cut to the end of the window, seconds.
    /// Default 10.
    pub recovery_window_s: f64,
    /// A pose handed over by pose updating is wrong at this distance from the reference or
    /// more, metres. Default 0.3.
    pub wrong_min_error_m: f64,
    /// …or at this heading error or more, degrees. Default 5.
    pub wrong_min_yaw_deg: f64,
}

impl Default for RealKidnapParams {
    fn default() -> Self {
        Self {
            cuts: CutParams::default(),
            seeds_per_cut: 1,
            presets: vec!["paper".into(), "authors".into(), "mapkeeper".into()],
            localisers: vec!["mapkeeper-real".into()],
            recovered_max_error_m: 0.2,
            recovered_max_yaw_deg: 5.0,
            recovery_window_s: 10.0,
            wrong_min_error_m: 0.3,
            wrong_min_yaw_deg: 5.0,
        }
    }
}

impl RealKidnapParams {
    /// Checks every field (the cuts' as `cuts.…`): known presets and localisers, at least one of
    /// each and one seed, positive finite tolerances and window.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.cuts.validate().map_err(|e| e.within("cuts"))?;
        if self.seeds_per_cut == 0 {
            return Err(ParamError::new("seeds_per_cut", 0, "must be ≥ 1"));
        }
        if self.presets.is_empty() {
            return Err(ParamError::rule("presets", "must name at least one updater preset"));
        }
        for p in &self.presets {
            if let Err(e) = UpdaterParams::preset(p) {
                return Err(ParamError::new("presets", p, format!("must name updater presets ({e})")));
            }
        }
        if self.localisers.is_empty() {
            return Err(ParamError::rule("localisers", "must name at least one localiser preset"));
        }
        for l in &self.localisers {
            if let Err(e) = FilterParams::preset(l) {
                return Err(ParamError::new("localisers", l, format!("must name localiser presets ({e})")));
            }
        }
        for (name, v) in [
            ("recovered_max_error_m", self.recovered_max_error_m),
            ("recovered_max_yaw_deg", self.recovered_max_yaw_deg),
            ("recovery_window_s", self.recovery_window_s),
            ("wrong_min_error_m", self.wrong_min_error_m),
            ("wrong_min_yaw_deg", self.wrong_min_yaw_deg),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ParamError::new(name, v, "must be finite and > 0"));
            }
        }
        Ok(())
    }

    /// Whether `pose` is right by the recovery criterion against `reference`.
    fn right(&self, pose: &Pose2, reference: &Pose2) -> bool {
        pose.distance(reference) < self.recovered_max_error_m
            && angle_diff(pose.yaw, reference.yaw).abs().to_degrees() < self.recovered_max_yaw_deg
    }

    /// Whether a handed-over `pose` is wrong against `reference`.
    fn wrong(&self, pose: &Pose2, reference: &Pose2) -> bool {
        pose.distance(reference) >= self.wrong_min_error_m
            || angle_diff(pose.yaw, reference.yaw).abs().to_degrees() >= self.wrong_min_yaw_deg
    }
}

/// What the estimate did after the cut, against the reference ([`classify_recovery`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Recovery {
    /// The estimate was right from a step within the recovery window to the window's end.
    pub recovered: bool,
    /// From the cut to the first step of the last good stretch (right to the end), seconds;
    /// `None` if the estimate is not right at the last step (or no step follows the cut). May
    /// exceed the recovery window (then not recovered).
    pub recover_s: Option<f64>,
    /// The same in scans: 1 is the first scan after the cut.
    pub recover_scans: Option<usize>,
    /// Steps with an estimate after the cut.
    pub steps_after: usize,
    /// The estimate's error at the first step after the cut, metres.
    pub first_error_m: Option<f64>,
    /// The estimate's error at the last step, metres.
    pub final_error_m: Option<f64>,
    /// …and its heading error there, degrees.
    pub final_yaw_error_deg: Option<f64>,
}

/// Judges the estimates after `cut_ns` (the stamp of the last scan before the cut) against the
/// reference track (interpolated at each estimate): see the module doc. Both tracks
/// time-ordered; estimates the reference cannot place are skipped.
pub fn classify_recovery(
    estimates: &[StampedPose],
    reference: &[StampedPose],
    cut_ns: u64,
    p: &RealKidnapParams,
) -> Recovery {
    let after: Vec<(u64, Pose2, Pose2)> = estimates
        .iter()
        .filter(|e| e.stamp_ns > cut_ns)
        .filter_map(|e| interpolate(reference, e.stamp_ns).map(|r| (e.stamp_ns, e.pose, r)))
        .collect();
    let good_from = after.iter().rposition(|(_, e, r)| !p.right(e, r)).map_or(0, |k| k + 1);
    let start = (good_from < after.len()).then_some(good_from);
    let recover_s = start.map(|k| (after[k].0 - cut_ns) as f64 * 1e-9);
    let error = |k: usize| after.get(k).map(|(_, e, r)| e.distance(r));
    Recovery {
        recovered: recover_s.is_some_and(|s| s <= p.recovery_window_s + 1e-9),
        recover_s,
        recover_scans: start.map(|k| k + 1),
        steps_after: after.len(),
        first_error_m: error(0),
        final_error_m: after.len().checked_sub(1).and_then(error),
        final_yaw_error_deg: after.last().map(|(_, e, r)| angle_diff(e.yaw, r.yaw).abs().to_degrees()),
    }
}

/// The poses handed over by pose updating that are wrong against the reference at their
/// stamps (see the module doc).
pub fn wrong_poses(recovered: &[StampedPose], reference: &[StampedPose], p: &RealKidnapParams) -> usize {
    recovered.iter().filter(|r| interpolate(reference, r.stamp_ns).is_some_and(|t| p.wrong(&r.pose, &t))).count()
}

/// How a trial ended: recovered, or the first reason it did not.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum KidnapEnd {
    /// Recovered within the recovery window.
    Recovered,
    /// Right to the end, but only from later than the recovery window.
    Late,
    /// Pose updating handed over a wrong pose after the cut.
    WrongPose,
    /// No Lost after the cut: the check never saw the kidnap (what it said instead:
    /// [`KidnapTrial::steps_after_cut`]).
    NeverLost,
    /// Lost after the cut, but pose updating handed over no pose (its refusals:
    /// [`KidnapTrial::refusals`]).
    Refused,
    /// Pose updating handed over right poses only, and the estimate did not hold them.
    NotHeld,
}

impl KidnapEnd {
    /// Its name in tables (as serialised): `recovered`, `late`, `wrong-pose`, `never-lost`,
    /// `refused`, `not-held`.
    pub fn name(self) -> &'static str {
        match self {
            KidnapEnd::Recovered => "recovered",
            KidnapEnd::Late => "late",
            KidnapEnd::WrongPose => "wrong-pose",
            KidnapEnd::NeverLost => "never-lost",
            KidnapEnd::Refused => "refused",
            KidnapEnd::NotHeld => "not-held",
        }
    }

    /// The end of a trial whose estimate did `recovery`, that said Lost after the cut or not
    /// (`detected`) and was handed `poses_after` poses after the cut, `wrong_after` of them wrong.
    pub fn of(recovery: &Recovery, detected: bool, poses_after: usize, wrong_after: usize) -> Self {
        if recovery.recovered {
            KidnapEnd::Recovered
        } else if recovery.recover_s.is_some() {
            KidnapEnd::Late
        } else if wrong_after > 0 {
            KidnapEnd::WrongPose
        } else if !detected {
            KidnapEnd::NeverLost
        } else if poses_after == 0 {
            KidnapEnd::Refused
        } else {
            KidnapEnd::NotHeld
        }
    }
}

/// The steps of a run's `steps.csv` after `cut_ns`, counted by outcome (`processed/lost`,
/// `processed/update`, `no_valid_beams`, …).
fn outcomes_after(steps_csv: &str, cut_ns: u64) -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    for row in steps_csv.lines().skip(1) {
        let cols: Vec<&str> = row.splitn(4, ',').collect();
        let stamp_ns = cols.first().and_then(|t| {
            let (s, ns) = t.split_once('.')?;
            // `seconds` writes nine decimals; fewer are read as the decimal fraction they are.
            let ns = format!("{ns:0<9}");
            Some(s.parse::<u64>().ok()? * 1_000_000_000 + ns.get(..9)?.parse::<u64>().ok()?)
        });
        if stamp_ns.is_none_or(|t| t <= cut_ns) {
            continue;
        }
        let key = match (cols.get(1), cols.get(2)) {
            (Some(o), Some(v)) if !v.is_empty() => format!("{o}/{v}"),
            (Some(o), _) => o.to_string(),
            _ => "unknown".into(),
        };
        *out.entry(key).or_insert(0) += 1;
    }
    out
}

/// One trial: one cut, one localiser seed, one map, localiser and updater preset, the spliced
/// window and its paired unspliced window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapTrial {
    /// The cut's index in [`RealKidnapResults::cuts`].
    pub cut: usize,
    /// The localiser's seed (the same for the spliced and the unspliced run).
    pub seed: u64,
    /// The map's name.
    pub map: String,
    /// The localiser preset.
    pub localiser: String,
    /// The updater preset.
    pub preset: String,
    /// How far the robot was moved, metres.
    pub jump_m: f64,
    /// How far it was turned, degrees (absolute).
    pub turn_deg: f64,
    /// The estimate after the cut.
    pub recovery: Recovery,
    /// How the trial ended.
    pub end: KidnapEnd,
    /// The spliced run's steps after the cut by the updater's outcome and verdict
    /// (`processed/lost`, `no_valid_beams`: the estimate put the lidar off the map's free
    /// cells, so the check had no beam to judge, …).
    pub steps_after_cut: BTreeMap<String, usize>,
    /// A Lost episode opened after the cut.
    pub detected: bool,
    /// From the cut to the first Lost after it, seconds.
    pub lost_delay_s: Option<f64>,
    /// Lost episodes of the spliced run (before the cut too).
    pub lost_episodes: u64,
    /// …of them opened at or before the cut (the unspliced run has them too).
    pub lost_before_cut: u64,
    /// Poses pose updating handed over in the spliced run.
    pub pose_recoveries: usize,
    /// …of them wrong.
    pub wrong_poses: usize,
    /// A handed-over pose came after the cut, at or before the step the good stretch began:
    /// the recovery is owed to pose updating (else to the filter).
    pub recovered_by_pose_updating: bool,
    /// Refusals of pose updating in the spliced run, by reason (`poor_fit`, `ambiguous`, …).
    pub refusals: BTreeMap<String, usize>,
    /// Steps of the spliced run.
    pub steps: usize,
    /// Lost episodes of the unspliced run: false Lost.
    pub unspliced_lost_episodes: u64,
    /// The unspliced run's estimate error at its first Lost, metres (a Lost of a lost robot is
    /// no false alarm, though it is counted).
    pub unspliced_first_lost_error_m: Option<f64>,
    /// Wrong poses handed over in the unspliced run.
    pub unspliced_wrong_poses: usize,
    /// The unspliced run's largest estimate error, metres (how well the localiser holds the
    /// window at all).
    pub unspliced_max_error_m: f64,
    /// Steps of the unspliced run.
    pub unspliced_steps: usize,
}

/// One (map, localiser, preset) over its trials.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapSummary {
    /// The map.
    pub map: String,
    /// The localiser preset.
    pub localiser: String,
    /// The updater preset.
    pub preset: String,
    /// Trials.
    pub trials: usize,
    /// Share recovered (target ≥ 0.9).
    pub recovered_rate: f64,
    /// Share recovered with a pose from pose updating.
    pub recovered_by_pose_updating_rate: f64,
    /// Share with a Lost after the cut.
    pub detected_rate: f64,
    /// Share with at least one wrong pose accepted in the spliced run (target ≤ 0.01).
    pub wrong_rate: f64,
    /// Poses handed over in the spliced runs.
    pub pose_recoveries: usize,
    /// …of them wrong.
    pub wrong_poses: usize,
    /// Share of unspliced runs with a Lost (target ≤ 0.02).
    pub false_lost_rate: f64,
    /// Share of unspliced runs with a wrong pose accepted.
    pub unspliced_wrong_rate: f64,
    /// Share of unspliced runs whose estimate was ever `wrong_min_error_m` or more off.
    pub unspliced_off_rate: f64,
    /// Time to recover of the recovered trials, median, seconds.
    pub median_recover_s: Option<f64>,
    /// …90th percentile, seconds.
    pub p90_recover_s: Option<f64>,
    /// …median, scans.
    pub median_recover_scans: Option<f64>,
    /// …90th percentile, scans.
    pub p90_recover_scans: Option<f64>,
    /// Refusals of pose updating over the spliced runs, by reason.
    pub refusals: BTreeMap<String, usize>,
    /// Trials by how they ended ([`KidnapEnd::name`]).
    pub ends: BTreeMap<String, usize>,
    /// The issue's three targets all met.
    pub targets_met: bool,
}

/// The experiment on one log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RealKidnapResults {
    /// The log's name.
    pub log: String,
    /// The run seed (cuts, localiser seeds).
    pub seed: u64,
    /// The maps' names, in the order given.
    pub maps: Vec<String>,
    /// The parameters.
    pub params: RealKidnapParams,
    /// The cuts drawn.
    pub cuts: Vec<CutDraw>,
    /// One per (map, localiser, preset), in that nesting order.
    pub summaries: Vec<KidnapSummary>,
    /// Every trial, in job order (not in `summary.json`).
    #[serde(skip)]
    pub trials: Vec<KidnapTrial>,
}

/// One job: which cut, seed, map, localiser and preset (indices).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KidnapJob {
    /// The cut.
    pub cut: usize,
    /// The seed's index (0..`seeds_per_cut`).
    pub seed: usize,
    /// The map.
    pub map: usize,
    /// The localiser.
    pub localiser: usize,
    /// The preset.
    pub preset: usize,
}

struct RealKidnapTrials<'a> {
    dataset: &'a Dataset,
    maps: &'a [(&'a str, &'a OccupancyGrid)],
    p: &'a RealKidnapParams,
    seed: u64,
    cuts: Vec<CutDraw>,
    reference: Vec<StampedPose>,
}

/// The localiser seed of seed `j` of cut `k` (shared by every map and preset: paired).
pub fn trial_seed(seed: u64, cut: usize, j: usize) -> u64 {
    stream_seed(seed, &format!("real-kidnap/cut/{cut:04}/seed/{j}"))
}

/// A reference track of a log's truth records, time-ordered.
fn reference_of(log: &SensorLog) -> Vec<StampedPose> {
    let mut t: Vec<StampedPose> =
        log.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
    t.sort_by_key(|p| p.stamp_ns);
    t
}

/// Refusals by the reason's kind, from `recoveries.csv` rows (`…,refused,,,,kind: detail`).
fn refusals(recoveries_csv: &str) -> BTreeMap<String, usize> {
    let mut out = BTreeMap::new();
    for row in recoveries_csv.lines().skip(1) {
        let cols: Vec<&str> = row.splitn(7, ',').collect();
        if cols.get(2) == Some(&"refused") {
            let kind = cols.get(6).and_then(|r| r.split(':').next()).unwrap_or("unknown");
            *out.entry(kind.to_string()).or_insert(0) += 1;
        }
    }
    out
}

impl RealKidnapTrials<'_> {
    fn run_one(&self, log: SensorLog, job: &KidnapJob, init: Pose2) -> Result<UpdateRun, ExperimentError> {
        let options = ReplayOptions {
            odometry_at: OdometryAt::Interpolated,
            sync_window_ns: DEFAULT_SYNC_WINDOW_NS,
            ..ReplayOptions::default()
        };
        let (_, map) = self.maps[job.map];
        let input = PoseInput::Localise {
            params: Box::new(FilterParams::preset(&self.p.localisers[job.localiser])?),
            seed: trial_seed(self.seed, job.cut, job.seed),
            init: Some(init),
        };
        let source = LogSource::new(log, self.dataset.name.clone(), options);
        let up = UpdaterParams::preset(&self.p.presets[job.preset])?;
        update_log(source, map.clone(), up, input, &NoClock, &mut [])
            .map_err(|e| ExperimentError::Invalid(format!("{}: cut {}: {e}", self.dataset.name, job.cut)))
    }

    fn trial(&self, job: KidnapJob) -> Result<KidnapTrial, ExperimentError> {
        let d = &self.cuts[job.cut];
        let name = &self.dataset.name;
        let spliced = d
            .spliced(&self.dataset.log)
            .map_err(|e| ExperimentError::Invalid(format!("{name}: cut {}: {e}", d.index)))?;
        let unspliced = d.unspliced(&self.dataset.log);
        let init = interpolate(&self.reference, d.window_start_ns).ok_or_else(|| {
            ExperimentError::Invalid(format!("{name}: no reference pose at cut {}'s window", d.index))
        })?;
        let reference = reference_of(&spliced);
        let cut_ns = d.cut.start_ns;
        let run = self.run_one(spliced, &job, init)?;
        let paired = self.run_one(unspliced.clone(), &job, init)?;
        let recovery = classify_recovery(&run.poses, &reference, cut_ns, self.p);
        let good_from_ns = recovery.recover_s.map(|s| cut_ns + (s * 1e9).round() as u64);
        let first_lost_after = run.lost_episodes.iter().find(|e| e.start_ns > cut_ns);
        let handed_after: Vec<StampedPose> =
            run.recovered_poses.iter().filter(|r| r.stamp_ns > cut_ns).copied().collect();
        let end = KidnapEnd::of(
            &recovery,
            first_lost_after.is_some(),
            handed_after.len(),
            wrong_poses(&handed_after, &reference, self.p),
        );
        let unspliced_ref = reference_of(&unspliced);
        let error_at = |poses: &[StampedPose], reference: &[StampedPose], t: u64| {
            let e = poses.iter().rfind(|p| p.stamp_ns <= t)?;
            interpolate(reference, e.stamp_ns).map(|r| r.distance(&e.pose))
        };
        Ok(KidnapTrial {
            cut: d.index,
            seed: trial_seed(self.seed, job.cut, job.seed),
            map: self.maps[job.map].0.to_string(),
            localiser: self.p.localisers[job.localiser].clone(),
            preset: self.p.presets[job.preset].clone(),
            jump_m: d.jump_m,
            turn_deg: d.turn_rad.abs().to_degrees(),
            detected: first_lost_after.is_some(),
            lost_delay_s: first_lost_after.map(|e| (e.start_ns - cut_ns) as f64 * 1e-9),
            lost_episodes: run.lost.episodes,
            lost_before_cut: run.lost_episodes.iter().filter(|e| e.start_ns <= cut_ns).count() as u64,
            pose_recoveries: run.recovered_poses.len(),
            wrong_poses: wrong_poses(&run.recovered_poses, &reference, self.p),
            recovered_by_pose_updating: recovery.recovered
                && run
                    .recovered_poses
                    .iter()
                    .any(|r| r.stamp_ns > cut_ns && good_from_ns.is_some_and(|g| r.stamp_ns <= g)),
            refusals: refusals(&run.recoveries_csv),
            end,
            steps_after_cut: outcomes_after(&run.steps_csv, cut_ns),
            steps: run.poses.len(),
            unspliced_lost_episodes: paired.lost.episodes,
            unspliced_first_lost_error_m: paired
                .lost_episodes
                .first()
                .and_then(|e| error_at(&paired.poses, &unspliced_ref, e.start_ns)),
            unspliced_wrong_poses: wrong_poses(&paired.recovered_poses, &unspliced_ref, self.p),
            unspliced_max_error_m: paired
                .poses
                .iter()
                .filter_map(|e| interpolate(&unspliced_ref, e.stamp_ns).map(|r| r.distance(&e.pose)))
                .fold(0.0, f64::max),
            unspliced_steps: paired.poses.len(),
            recovery,
        })
    }
}

impl Trials for RealKidnapTrials<'_> {
    type Job = KidnapJob;
    type Outcome = KidnapTrial;
    type Summary = RealKidnapResults;

    fn draw(&self) -> Vec<KidnapJob> {
        let mut jobs = Vec::new();
        for cut in 0..self.cuts.len() {
            for seed in 0..self.p.seeds_per_cut {
                for map in 0..self.maps.len() {
                    for localiser in 0..self.p.localisers.len() {
                        for preset in 0..self.p.presets.len() {
                            jobs.push(KidnapJob { cut, seed, map, localiser, preset });
                        }
                    }
                }
            }
        }
        jobs
    }

    fn run(&self, job: KidnapJob, progress: &(dyn Fn() + Sync)) -> Result<KidnapTrial, ExperimentError> {
        let r = self.trial(job);
        progress();
        r
    }

    fn summarise(&self, trials: Vec<KidnapTrial>) -> Result<RealKidnapResults, ExperimentError> {
        let mut summaries = Vec::new();
        for (map, _) in self.maps {
            for localiser in &self.p.localisers {
                for preset in &self.p.presets {
                    let of: Vec<&KidnapTrial> = trials
                        .iter()
                        .filter(|t| t.map == *map && t.localiser == *localiser && t.preset == *preset)
                        .collect();
                    summaries.push(summarise(map, localiser, preset, &of, self.p));
                }
            }
        }
        Ok(RealKidnapResults {
            log: self.dataset.name.clone(),
            seed: self.seed,
            maps: self.maps.iter().map(|(n, _)| n.to_string()).collect(),
            params: self.p.clone(),
            cuts: self.cuts.clone(),
            summaries,
            trials,
        })
    }
}

/// The summary of one (map, localiser, preset)'s trials.
pub fn summarise(map: &str, localiser: &str, preset: &str, t: &[&KidnapTrial], p: &RealKidnapParams) -> KidnapSummary {
    let recovered: Vec<&&KidnapTrial> = t.iter().filter(|t| t.recovery.recovered).collect();
    let secs: Vec<f64> = recovered.iter().filter_map(|t| t.recovery.recover_s).collect();
    let scans: Vec<f64> = recovered.iter().filter_map(|t| t.recovery.recover_scans.map(|s| s as f64)).collect();
    let mut refusals = BTreeMap::new();
    for (k, n) in t.iter().flat_map(|t| &t.refusals) {
        *refusals.entry(k.clone()).or_insert(0) += n;
    }
    let recovered_rate = frac(t.iter().map(|t| t.recovery.recovered));
    let wrong_rate = frac(t.iter().map(|t| t.wrong_poses > 0));
    let false_lost_rate = frac(t.iter().map(|t| t.unspliced_lost_episodes > 0));
    KidnapSummary {
        map: map.to_string(),
        localiser: localiser.to_string(),
        preset: preset.to_string(),
        trials: t.len(),
        recovered_rate,
        recovered_by_pose_updating_rate: frac(t.iter().map(|t| t.recovered_by_pose_updating)),
        detected_rate: frac(t.iter().map(|t| t.detected)),
        wrong_rate,
        pose_recoveries: t.iter().map(|t| t.pose_recoveries).sum(),
        wrong_poses: t.iter().map(|t| t.wrong_poses).sum(),
        false_lost_rate,
        unspliced_wrong_rate: frac(t.iter().map(|t| t.unspliced_wrong_poses > 0)),
        unspliced_off_rate: frac(t.iter().map(|t| t.unspliced_max_error_m >= p.wrong_min_error_m)),
        median_recover_s: median(secs.clone()),
        p90_recover_s: percentile(secs, 0.9),
        median_recover_scans: median(scans.clone()),
        p90_recover_scans: percentile(scans, 0.9),
        refusals,
        ends: t.iter().fold(BTreeMap::new(), |mut m, t| {
            *m.entry(t.end.name().to_string()).or_insert(0) += 1;
            m
        }),
        targets_met: !t.is_empty() && recovered_rate >= 0.9 && wrong_rate <= 0.01 && false_lost_rate <= 0.02,
    }
}

/// Runs the experiment on one log with reference poses: draws the cuts (seeded by `seed`),
/// then every (cut, seed, map, localiser, preset) trial through [`run_trials`] (in parallel on
/// the caller's rayon pool; the same results whatever the thread count); `progress` after each
/// trial. `maps` are named (`("stale", &m1), ("truth", &g)`), all of the log's place.
pub fn run_real_kidnap(
    dataset: &Dataset,
    maps: &[(&str, &OccupancyGrid)],
    p: &RealKidnapParams,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Result<RealKidnapResults, ExperimentError> {
    p.validate().map_err(|e| ExperimentError::from(e.within("real_kidnap")))?;
    if maps.is_empty() {
        return Err(ExperimentError::Invalid(format!("real kidnap on {}: no map given", dataset.name)));
    }
    let cuts = draw_cuts(&dataset.log, &dataset.name, &p.cuts, seed)?;
    let reference = reference_of(&dataset.log);
    run_trials(&RealKidnapTrials { dataset, maps, p, seed, cuts, reference }, progress)
}

#[cfg(test)]
mod tests;
