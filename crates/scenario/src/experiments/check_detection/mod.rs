//! How well the localisation check sees a bad pose (issue 12, item 5; `docs/recovery.md`,
//! "Check detection"). Each trial drives a short stretch of the tour from a seeded place in a
//! seeded world W_k (k in 2..=`max_world`) on the stale map of W_1; after `warmup_s` the pose
//! the updater is given is held wrong by a seeded offset (0..`max_error_m` in any direction
//! relative to the heading, 0..±`max_yaw_rad`) to the end of the run ([`PoseErrorHold`]), while
//! the localiser runs on. Every processed step's verdict is compared with the true error of the
//! pose the updater was given:
//!
//! - **detection rate**: trials with an injected error ≥ `detect_min_error_m` whose first
//!   Suspend or Lost after the onset comes within `detect_within_s`;
//! - **latency**: time from the onset to that first Suspend or Lost (median over detected trials);
//! - **false-alarm rate**: Suspend or Lost among the processed steps whose true error is ≤
//!   `clean_max_error_m` and ≤ `clean_max_yaw_rad` in heading (before the onset, in the trials
//!   with no injected error, and after pose updating corrected a held error);
//! - **per-step detection**: Suspend or Lost among the steps whose true error is ≥
//!   `detect_min_error_m`.
//!
//! Every preset runs the same trials (same worlds, places, offsets and simulator noise).

pub mod report;

use crate::experiments::ExperimentError;
use crate::stats::median;
use mapkeeper_closed_loop::controls::{PoseErrorHold, TimelineSample};
use mapkeeper_closed_loop::setup::params::RecoveryParams;
use mapkeeper_closed_loop::setup::{Setup, prepare};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_common::ParamError;
use mapkeeper_sim::World;
use mapkeeper_sim::seeds::stream_rng;
use mapkeeper_updater::{UpdaterParams, Verdict};
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Parameters of the experiment (`[check_detection]` of a parameter file).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CheckDetectionParams {
    /// Trials (each preset runs all of them). Default 200.
    pub trials: usize,
    /// Updater presets compared. Default `paper`, `mapkeeper`, `mapkeeper-shift`.
    pub presets: Vec<String>,
    /// Worlds are drawn from W_2 … W_`max_world`. Default 100.
    pub max_world: usize,
    /// Share of trials with no injected error (the false-alarm reference). Default 0.2.
    pub zero_error_share: f64,
    /// Largest injected position error, metres. Default 1.5.
    pub max_error_m: f64,
    /// Largest injected heading error, radians. Default 20° (0.349).
    pub max_yaw_rad: f64,
    /// Clean driving before the onset, seconds. Default 2.
    pub warmup_s: f64,
    /// Driving after the onset, seconds. Default 3.
    pub window_s: f64,
    /// A detection counts if it comes within this long of the onset, seconds. Default 2.
    pub detect_within_s: f64,
    /// Errors at or above this are "bad", metres. Default 0.3.
    pub detect_min_error_m: f64,
    /// Errors at or below this are "clean", metres. Default 0.05.
    pub clean_max_error_m: f64,
    /// …with a heading error at or below this, radians. Default 2° (0.0349).
    pub clean_max_yaw_rad: f64,
    /// Edges of the error bins of the report, metres (increasing, from 0). Default
    /// 0, 0.05, 0.15, 0.3, 0.6, 1.0 (the last bin is open).
    pub error_bins_m: Vec<f64>,
}

impl Default for CheckDetectionParams {
    fn default() -> Self {
        Self {
            trials: 200,
            presets: vec!["paper".into(), "mapkeeper".into(), "mapkeeper-shift".into()],
            max_world: 100,
            zero_error_share: 0.2,
            max_error_m: 1.5,
            max_yaw_rad: 20f64.to_radians(),
            warmup_s: 2.0,
            window_s: 3.0,
            detect_within_s: 2.0,
            detect_min_error_m: 0.3,
            clean_max_error_m: 0.05,
            clean_max_yaw_rad: 2f64.to_radians(),
            error_bins_m: vec![0.0, 0.05, 0.15, 0.3, 0.6, 1.0],
        }
    }
}

impl CheckDetectionParams {
    /// The short setting of `--quick`: 6 trials up to W_4, a 1.5 s window.
    pub fn quick() -> Self {
        Self { trials: 6, max_world: 4, window_s: 1.5, ..Self::default() }
    }
}

impl CheckDetectionParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        if self.presets.is_empty() {
            return Err(ExperimentError::from(ParamError::rule(
                "check_detection.presets",
                "needs at least one preset",
            )));
        }
        for p in &self.presets {
            UpdaterParams::preset(p)
                .map_err(|e| ExperimentError::from(ParamError::rule("check_detection.presets", e.to_string())))?;
        }
        if !(2..=1000).contains(&self.max_world) {
            return Err(ExperimentError::from(ParamError::new(
                "check_detection.max_world",
                self.max_world,
                "must lie in 2..=1000",
            )));
        }
        if !(0.0..=1.0).contains(&self.zero_error_share) {
            return Err(ExperimentError::from(ParamError::new(
                "check_detection.zero_error_share",
                self.zero_error_share,
                "must lie in [0, 1]",
            )));
        }
        for (name, v) in [
            ("check_detection.max_error_m", self.max_error_m),
            ("check_detection.max_yaw_rad", self.max_yaw_rad),
            ("check_detection.warmup_s", self.warmup_s),
            ("check_detection.detect_min_error_m", self.detect_min_error_m),
            ("check_detection.clean_max_error_m", self.clean_max_error_m),
            ("check_detection.clean_max_yaw_rad", self.clean_max_yaw_rad),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ExperimentError::from(ParamError::new(name, v, "must be finite and ≥ 0")));
            }
        }
        for (name, v) in
            [("check_detection.window_s", self.window_s), ("check_detection.detect_within_s", self.detect_within_s)]
        {
            if !(v.is_finite() && v > 0.0) {
                return Err(ExperimentError::from(ParamError::new(name, v, "must be finite and > 0")));
            }
        }
        if self.clean_max_error_m >= self.detect_min_error_m {
            return Err(ExperimentError::from(ParamError::rule(
                "check_detection.clean_max_error_m",
                "must be below detect_min_error_m",
            )));
        }
        let b = &self.error_bins_m;
        if b.first() != Some(&0.0) || b.windows(2).any(|w| w[1] <= w[0]) || b.iter().any(|v| !v.is_finite()) {
            return Err(ExperimentError::from(ParamError::rule(
                "check_detection.error_bins_m",
                format!("must be finite, increasing, from 0, got {b:?}"),
            )));
        }
        Ok(())
    }
}

/// One trial's draw (the same for every preset).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectionDraw {
    /// Trial index.
    pub trial: usize,
    /// k of W_k.
    pub world: usize,
    /// Where on the tour the drive starts, metres.
    pub tour_position_m: f64,
    /// Injected position error, metres.
    pub error_m: f64,
    /// Its direction relative to the robot's heading at the start, radians (0: ahead, along the
    /// aisle; ±π/2: across).
    pub direction_rel_rad: f64,
    /// Injected heading error, radians.
    pub yaw_error_rad: f64,
}

/// The trial's draw, from a stream named after the seed and the trial.
pub fn draw_detection(p: &CheckDetectionParams, tour_length_m: f64, seed: u64, trial: usize) -> DetectionDraw {
    let mut rng = stream_rng(seed, &format!("check-detection/{trial:05}"));
    let world = rng.random_range(2..=p.max_world);
    let tour_position_m = rng.random_range(0.0..tour_length_m.max(1e-9));
    let zero = rng.random::<f64>() < p.zero_error_share;
    let mag = rng.random::<f64>();
    let dir = rng.random_range(-PI..PI);
    let yaw = rng.random_range(-1.0..=1.0);
    let (error_m, yaw_error_rad) = if zero { (0.0, 0.0) } else { (mag * p.max_error_m, yaw * p.max_yaw_rad) };
    DetectionDraw { trial, world, tour_position_m, error_m, direction_rel_rad: dir, yaw_error_rad }
}

/// One trial under one preset.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectionTrial {
    /// The draw.
    pub draw: DetectionDraw,
    /// The updater preset.
    pub preset: String,
    /// The onset (the first tick at or after `warmup_s`), seconds; `None` if the run ended before.
    pub onset_s: Option<f64>,
    /// Time from the onset to the first Suspend or Lost, seconds.
    pub latency_s: Option<f64>,
    /// That verdict.
    pub first_alarm: Option<Verdict>,
    /// Detected: the first alarm came within `detect_within_s`.
    pub detected: bool,
    /// Processed steps with a true error ≤ `clean_max_error_m` and ≤ `clean_max_yaw_rad`.
    pub clean_steps: u32,
    /// …of them Suspend or Lost.
    pub clean_alarms: u32,
    /// Processed steps with a true error ≥ `detect_min_error_m`.
    pub bad_steps: u32,
    /// …of them Suspend or Lost.
    pub bad_alarms: u32,
    /// Processed steps after the onset.
    pub steps_after_onset: u32,
}

fn alarm(v: Verdict) -> bool {
    v != Verdict::Update
}

fn score_trial(
    draw: DetectionDraw,
    preset: &str,
    onset_s: Option<f64>,
    tl: &[TimelineSample],
    p: &CheckDetectionParams,
) -> DetectionTrial {
    let after: Vec<&TimelineSample> = onset_s.map(|o| tl.iter().filter(|s| s.t_s >= o).collect()).unwrap_or_default();
    let first = after.iter().find(|s| alarm(s.verdict));
    let latency_s = match (first, onset_s) {
        (Some(s), Some(o)) => Some(s.t_s - o),
        _ => None,
    };
    let count = |f: &dyn Fn(&TimelineSample) -> bool| tl.iter().filter(|s| f(s)).count() as u32;
    let clean = |s: &TimelineSample| s.error_m <= p.clean_max_error_m && s.yaw_error_rad <= p.clean_max_yaw_rad;
    DetectionTrial {
        draw,
        preset: preset.to_string(),
        onset_s,
        latency_s,
        first_alarm: first.map(|s| s.verdict),
        detected: latency_s.is_some_and(|l| l <= p.detect_within_s + 1e-9),
        clean_steps: count(&clean),
        clean_alarms: count(&|s| clean(s) && alarm(s.verdict)),
        bad_steps: count(&|s| s.error_m >= p.detect_min_error_m),
        bad_alarms: count(&|s| s.error_m >= p.detect_min_error_m && alarm(s.verdict)),
        steps_after_onset: after.len() as u32,
    }
}

/// A rate with its counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Rate {
    /// Events.
    pub hits: u64,
    /// Cases.
    pub of: u64,
    /// hits / of (0 with no case).
    pub rate: f64,
    /// Wilson 95 % interval of the rate, [lo, hi].
    pub ci95: [f64; 2],
}

impl Rate {
    /// `hits` of `of`, with the Wilson score interval.
    pub fn new(hits: u64, of: u64) -> Self {
        if of == 0 {
            return Self::default();
        }
        let (n, p, z) = (of as f64, hits as f64 / of as f64, 1.96f64);
        let d = 1.0 + z * z / n;
        let c = (p + z * z / (2.0 * n)) / d;
        let h = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / d;
        Self { hits, of, rate: p, ci95: [(c - h).max(0.0), (c + h).min(1.0)] }
    }
}

/// The detection rate within one bin.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BinRate {
    /// The bin, e.g. "0.30-0.60 m" or "W_2-W_25".
    pub bin: String,
    /// Trials in it whose first alarm came within `detect_within_s`.
    pub detected: Rate,
    /// Suspend or Lost among its clean steps.
    pub false_alarms: Rate,
}

/// One preset's result (`summary.json` `check_detection.<preset>`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PresetDetection {
    /// Trials with an injected error ≥ `detect_min_error_m` detected within `detect_within_s`
    /// (the headline).
    pub detection_rate: f64,
    /// Suspend or Lost among the clean steps (the headline).
    pub false_alarm_rate: f64,
    /// Median latency of the detected trials, seconds.
    pub median_latency_s: Option<f64>,
    /// The detection rate with its counts and interval.
    pub detection: Rate,
    /// The false-alarm rate with its counts and interval.
    pub false_alarms: Rate,
    /// Trials with no injected error that saw any Suspend or Lost.
    pub false_alarm_trials: Rate,
    /// Suspend or Lost among the steps with a true error ≥ `detect_min_error_m`.
    pub per_step_detection: Rate,
    /// Detection of bad errors displaced mostly along the heading (within ±30° of it or of its
    /// reverse).
    pub along_heading: Rate,
    /// …and mostly across it (within ±30° of the perpendicular).
    pub across_heading: Rate,
    /// By injected error (all trials in the bin; the rate is "any alarm within the window").
    pub by_error: Vec<BinRate>,
    /// By world (bad-error trials; clean steps of all trials of the bin).
    pub by_world: Vec<BinRate>,
}

/// `summary.json` of the experiment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckDetectionSummary {
    /// Producer and version.
    pub tool: String,
    /// The run seed.
    pub seed: u64,
    /// Trials (per preset).
    pub trials: usize,
    /// Wall time, seconds (set by the caller; 0 when not measured).
    pub wall_time_s: f64,
    /// Per preset, in the order of `params.check_detection.presets`.
    pub check_detection: std::collections::BTreeMap<String, PresetDetection>,
    /// The parameters of the experiment.
    pub params: CheckDetectionParams,
    /// The closed loop and worlds.
    pub recovery: RecoveryParams,
}

/// Everything the experiment produced.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckDetectionResults {
    /// The summary.
    pub summary: CheckDetectionSummary,
    /// Every trial of every preset, preset-major.
    pub trials: Vec<DetectionTrial>,
}

fn bin_label(lo: f64, hi: Option<f64>) -> String {
    match hi {
        Some(hi) => format!("{lo:.2}-{hi:.2} m"),
        None => format!("≥ {lo:.2} m"),
    }
}

fn summarise(trials: &[&DetectionTrial], p: &CheckDetectionParams) -> PresetDetection {
    let bad: Vec<&&DetectionTrial> = trials.iter().filter(|t| t.draw.error_m >= p.detect_min_error_m).collect();
    let detected = bad.iter().filter(|t| t.detected).count() as u64;
    let sum = |f: &dyn Fn(&DetectionTrial) -> u32, v: &[&DetectionTrial]| v.iter().map(|t| u64::from(f(t))).sum();
    let false_alarms = Rate::new(sum(&|t| t.clean_alarms, trials), sum(&|t| t.clean_steps, trials));
    let zero: Vec<&&DetectionTrial> = trials.iter().filter(|t| t.draw.error_m == 0.0).collect();
    let rel = |t: &DetectionTrial| {
        let a = t.draw.direction_rel_rad.rem_euclid(PI);
        a.min(PI - a)
    };
    let sector = |along: bool| {
        let v: Vec<_> = bad.iter().filter(|t| if along { rel(t) <= PI / 6.0 } else { rel(t) >= PI / 3.0 }).collect();
        Rate::new(v.iter().filter(|t| t.detected).count() as u64, v.len() as u64)
    };
    let edges = &p.error_bins_m;
    let by_error = (0..edges.len())
        .map(|k| {
            let (lo, hi) = (edges[k], edges.get(k + 1).copied());
            let v: Vec<&DetectionTrial> = trials
                .iter()
                .copied()
                .filter(|t| t.draw.error_m >= lo && hi.is_none_or(|h| t.draw.error_m < h))
                .collect();
            BinRate {
                bin: bin_label(lo, hi),
                detected: Rate::new(v.iter().filter(|t| t.detected).count() as u64, v.len() as u64),
                false_alarms: Rate::new(sum(&|t| t.clean_alarms, &v), sum(&|t| t.clean_steps, &v)),
            }
        })
        .collect();
    let quarter = (p.max_world - 1).div_ceil(4).max(1);
    let by_world = (0..4)
        .filter_map(|q| {
            let lo = 2 + q * quarter;
            let hi = (lo + quarter - 1).min(p.max_world);
            (lo <= hi).then_some((lo, hi))
        })
        .map(|(lo, hi)| {
            let all: Vec<&DetectionTrial> =
                trials.iter().copied().filter(|t| (lo..=hi).contains(&t.draw.world)).collect();
            let b: Vec<&&DetectionTrial> = all.iter().filter(|t| t.draw.error_m >= p.detect_min_error_m).collect();
            BinRate {
                bin: format!("W_{lo}-W_{hi}"),
                detected: Rate::new(b.iter().filter(|t| t.detected).count() as u64, b.len() as u64),
                false_alarms: Rate::new(sum(&|t| t.clean_alarms, &all), sum(&|t| t.clean_steps, &all)),
            }
        })
        .collect();
    let detection = Rate::new(detected, bad.len() as u64);
    PresetDetection {
        detection_rate: detection.rate,
        false_alarm_rate: false_alarms.rate,
        median_latency_s: median(bad.iter().filter(|t| t.detected).filter_map(|t| t.latency_s).collect()),
        detection,
        false_alarms,
        false_alarm_trials: Rate::new(
            zero.iter().filter(|t| t.clean_alarms > 0 || t.first_alarm.is_some()).count() as u64,
            zero.len() as u64,
        ),
        per_step_detection: Rate::new(sum(&|t| t.bad_alarms, trials), sum(&|t| t.bad_steps, trials)),
        along_heading: sector(true),
        across_heading: sector(false),
        by_error,
        by_world,
    }
}

/// The trials of one run of the experiment: every draw under every preset.
struct DetectionTrials<'a> {
    recovery: &'a RecoveryParams,
    p: &'a CheckDetectionParams,
    seed: u64,
    setup: Setup,
    draws: Vec<DetectionDraw>,
    presets: Vec<UpdaterParams>,
}

impl Trials for DetectionTrials<'_> {
    /// (preset index, trial index).
    type Job = (usize, usize);
    type Outcome = DetectionTrial;
    type Summary = CheckDetectionResults;

    fn draw(&self) -> Vec<(usize, usize)> {
        (0..self.presets.len()).flat_map(|k| (0..self.draws.len()).map(move |t| (k, t))).collect()
    }

    fn run(&self, (k, t): (usize, usize), progress: &(dyn Fn() + Sync)) -> Result<DetectionTrial, ExperimentError> {
        let (recovery, p, d) = (self.recovery, self.p, self.draws[t]);
        let speed = recovery.runner.sim.robot.max_speed_mps.max(0.1);
        let map = self.setup.initial_map(recovery.initial_map);
        let length = speed * (p.warmup_s + p.window_s) + 2.0;
        let drive = self.setup.drive(d.world, map, &recovery.tour, d.tour_position_m, length)?;
        let dir = drive.start.yaw + d.direction_rel_rad;
        let mut rp = recovery.runner.clone();
        rp.updater = self.presets[k].clone();
        rp.record_timeline = true;
        rp.max_sim_time_s = p.warmup_s + p.window_s;
        rp.pose_error = Some(PoseErrorHold {
            at_s: p.warmup_s,
            hold_s: f64::INFINITY,
            dx_m: d.error_m * dir.cos(),
            dy_m: d.error_m * dir.sin(),
            dyaw_rad: d.yaw_error_rad,
        });
        let run = drive.run(&rp, self.seed, &format!("check-detection-{t:05}"))?;
        progress();
        Ok(score_trial(d, &p.presets[k], run.pose_error.map(|r| r.began_s), &run.timeline, p))
    }

    fn summarise(&self, trials: Vec<DetectionTrial>) -> Result<CheckDetectionResults, ExperimentError> {
        let p = self.p;
        let check_detection = p
            .presets
            .iter()
            .map(|name| {
                let mine: Vec<&DetectionTrial> = trials.iter().filter(|t| &t.preset == name).collect();
                (name.clone(), summarise(&mine, p))
            })
            .collect();
        let summary = CheckDetectionSummary {
            tool: format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION")),
            seed: self.seed,
            trials: p.trials,
            wall_time_s: 0.0,
            check_detection,
            params: p.clone(),
            recovery: self.recovery.clone(),
        };
        Ok(CheckDetectionResults { summary, trials })
    }
}

/// Generates the worlds, then runs every trial under every preset ([`run_trials`]: in
/// parallel, collected in order). `progress` is called once per finished run.
pub fn run_check_detection(
    w1: &World,
    recovery: &RecoveryParams,
    p: &CheckDetectionParams,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Result<CheckDetectionResults, ExperimentError> {
    p.validate()?;
    let mut rp_all = recovery.clone();
    rp_all.kidnap.stale_max_world = rp_all.kidnap.stale_max_world.max(p.max_world);
    let tour_len = recovery.tour.length_m();
    let trials = DetectionTrials {
        recovery,
        p,
        seed,
        setup: prepare(w1, &rp_all, seed)?,
        draws: (0..p.trials).map(|t| draw_detection(p, tour_len, seed, t)).collect(),
        presets: p.presets.iter().map(|n| UpdaterParams::preset(n)).collect::<Result<_, _>>()?,
    };
    run_trials(&trials, progress)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_interval_brackets_the_rate() {
        let r = Rate::new(19, 20);
        assert!((r.rate - 0.95).abs() < 1e-12);
        assert!(r.ci95[0] < 0.95 && r.ci95[1] > 0.95 && r.ci95[0] > 0.7 && r.ci95[1] <= 1.0);
        assert_eq!(Rate::new(0, 0), Rate::default());
        let z = Rate::new(0, 50);
        assert_eq!(z.ci95[0], 0.0);
        assert!(z.ci95[1] > 0.0 && z.ci95[1] < 0.1);
    }

    #[test]
    fn draws_are_seeded_and_in_range() {
        let p = CheckDetectionParams::default();
        let mut zeros = 0;
        for t in 0..200 {
            let d = draw_detection(&p, 100.0, 5, t);
            assert_eq!(d, draw_detection(&p, 100.0, 5, t));
            assert!((2..=100).contains(&d.world) && (0.0..100.0).contains(&d.tour_position_m));
            assert!(d.error_m <= 1.5 && d.yaw_error_rad.abs() <= p.max_yaw_rad + 1e-12);
            zeros += usize::from(d.error_m == 0.0);
        }
        assert!((20..=60).contains(&zeros), "{zeros}");
        assert_ne!(draw_detection(&p, 100.0, 5, 0), draw_detection(&p, 100.0, 6, 0));
    }

    fn sample(t: f64, v: Verdict, e: f64) -> TimelineSample {
        TimelineSample { t_s: t, verdict: v, n_valid: 100, n_dc: 0, error_m: e, yaw_error_rad: 0.0, recovered: None }
    }

    #[test]
    fn a_trial_is_scored_against_the_true_error_of_each_step() {
        let p = CheckDetectionParams::default();
        let d = DetectionDraw {
            trial: 0,
            world: 2,
            tour_position_m: 0.0,
            error_m: 0.5,
            direction_rel_rad: 0.0,
            yaw_error_rad: 0.0,
        };
        let tl = [
            sample(1.0, Verdict::Update, 0.02),
            sample(1.5, Verdict::Suspend, 0.03),
            sample(2.0, Verdict::Update, 0.5),
            sample(3.5, Verdict::Lost, 0.5),
            sample(4.5, Verdict::Suspend, 0.5),
        ];
        let t = score_trial(d, "paper", Some(2.0), &tl, &p);
        assert_eq!(t.latency_s, Some(1.5));
        assert_eq!(t.first_alarm, Some(Verdict::Lost));
        assert!(t.detected);
        assert_eq!((t.clean_steps, t.clean_alarms, t.bad_steps, t.bad_alarms), (2, 1, 3, 2));
        let late = score_trial(d, "paper", Some(1.0), &tl[2..], &p);
        assert_eq!(late.latency_s, Some(2.5));
        assert!(!late.detected);
        let none = score_trial(d, "paper", None, &tl, &p);
        assert!(!none.detected && none.latency_s.is_none());
    }

    #[test]
    fn bad_params_are_refused() {
        let ok = CheckDetectionParams::default();
        assert!(ok.validate().is_ok());
        for f in [
            |p: &mut CheckDetectionParams| p.presets = vec!["nope".into()],
            |p: &mut CheckDetectionParams| p.max_world = 1,
            |p: &mut CheckDetectionParams| p.window_s = 0.0,
            |p: &mut CheckDetectionParams| p.clean_max_error_m = 0.5,
            |p: &mut CheckDetectionParams| p.error_bins_m = vec![0.1, 0.2],
            |p: &mut CheckDetectionParams| p.zero_error_share = f64::NAN,
        ] {
            let mut p = ok.clone();
            f(&mut p);
            assert!(p.validate().is_err(), "{p:?}");
        }
    }
}
