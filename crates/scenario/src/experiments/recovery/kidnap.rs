//! The kidnap stress suite: seeded kidnappings of the chain localiser's estimate, each paired
//! with the same run without the kidnap.

use crate::experiments::ExperimentError;
use crate::stats::percentile;
use crate::stats::{frac, mean, median};
use mapkeeper_closed_loop::controls::{Kidnap, TrackSample};
use mapkeeper_closed_loop::setup::params::{KidnapParams, RecoveryParams};
use mapkeeper_closed_loop::setup::{Setup, recovery_time};
use mapkeeper_closed_loop::trials::{Trials, run_trials};
use mapkeeper_grid::metrics::map_metrics;
use mapkeeper_sim::seeds::stream_rng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// Which map the chain localiser and the updater start from in a kidnap trial.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum MapCase {
    /// M_1 in W_k (k ≥ 2): the world has changed since the map was made (Fig. 30).
    Stale,
    /// G_k in W_k: the map is the current world (Fig. 29).
    Best,
}

impl MapCase {
    /// `stale` or `best`.
    pub fn name(self) -> &'static str {
        match self {
            MapCase::Stale => "stale",
            MapCase::Best => "best",
        }
    }
}

/// The random draws of one trial (shared by both map cases).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialDraw {
    /// i of W_i.
    pub world: usize,
    /// Where on the tour the trial starts, metres.
    pub tour_position_m: f64,
    /// Kidnap time, seconds.
    pub kidnap_s: f64,
    /// Displacement, metres.
    pub displacement_m: f64,
    /// Its direction in the map frame, radians.
    pub direction_rad: f64,
    /// Yaw displacement, radians.
    pub yaw_rad: f64,
}

/// The draws of trial `trial` (stream `kidnap/<trial>` of the run seed).
pub fn draw_trial(params: &RecoveryParams, seed: u64, trial: usize) -> TrialDraw {
    let k = &params.kidnap;
    let mut rng = stream_rng(seed, &format!("kidnap/{trial}"));
    let mut uniform = |a: f64, b: f64| if b > a { rng.random_range(a..b) } else { a };
    let world = 2 + (uniform(0.0, (k.stale_max_world - 1) as f64).floor() as usize).min(k.stale_max_world - 2);
    TrialDraw {
        world,
        tour_position_m: uniform(0.0, params.tour.length_m()),
        kidnap_s: uniform(k.kidnap_min_s, k.kidnap_max_s),
        displacement_m: uniform(k.min_displacement_m, k.max_displacement_m),
        direction_rad: uniform(-std::f64::consts::PI, std::f64::consts::PI),
        yaw_rad: uniform(-k.max_yaw_rad, k.max_yaw_rad),
    }
}

/// One kidnap trial in one map case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapTrial {
    /// The map case.
    pub case: MapCase,
    /// Trial index.
    pub trial: usize,
    /// The draws.
    pub draw: TrialDraw,
    /// The kidnap happened (the run reached its time).
    pub applied: bool,
    /// Lost verdicts before the kidnap.
    pub lost_before: u64,
    /// The check said Lost at or after the kidnap.
    pub detected: bool,
    /// Delay from the kidnap to the first Lost, seconds.
    pub detection_delay_s: Option<f64>,
    /// The error came under the criterion for good within the window.
    pub recovered: bool,
    /// Time from the kidnap to that, seconds (also when later than the window).
    pub recovery_s: Option<f64>,
    /// Poses returned by pose updating after the kidnap.
    pub recoveries: usize,
    /// Of those, poses with an error above the criterion.
    pub wrong_recoveries: usize,
    /// Pose recoveries refused.
    pub failed_recoveries: u64,
    /// The chain localiser's final error, metres.
    pub final_error_m: Option<f64>,
    /// Its final yaw error, radians.
    pub final_yaw_error_rad: Option<f64>,
    /// Lost verdicts in the same run without kidnap.
    pub reference_lost: u64,
    /// The chain localiser's error at its last sensor update in the run without kidnap, metres
    /// (how well it localises there at all).
    pub reference_final_error_m: Option<f64>,
    /// OPDF of the final map against G_k.
    pub opdf_kidnap: f64,
    /// OPDF of the final map of the run without kidnap against G_k.
    pub opdf_reference: f64,
    /// `opdf_reference − opdf_kidnap`, percentage points (> 0: the kidnap damaged the map).
    pub map_damage_opdf: f64,
    /// OPDF between the two final maps.
    pub opdf_vs_reference: f64,
    /// Cells that differ between the two final maps.
    pub cells_differing: u64,
}

/// One bin of displacements.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BinSummary {
    /// Lower edge, metres (inclusive).
    pub from_m: f64,
    /// Upper edge, metres (exclusive, but inclusive for the last bin).
    pub to_m: f64,
    /// Trials.
    pub trials: usize,
    /// Share detected.
    pub detected_rate: f64,
    /// Share recovered.
    pub recovered_rate: f64,
    /// Median recovery time of the recovered, seconds.
    pub median_recovery_s: Option<f64>,
}

/// `summary.json` `kidnap` (stale map) and `kidnap_best_case`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct KidnapSummary {
    /// `stale` (M_1 in W_k) or `best` (G_k in W_k).
    pub map: MapCase,
    /// Trials.
    pub trials: usize,
    /// Share of trials with Lost at or after the kidnap.
    pub detected_rate: f64,
    /// Share recovered (error < criterion within the window, and held to the end).
    pub recovered_rate: f64,
    /// Trials with displacement ≤ 1.5 m.
    pub trials_le_1_5m: usize,
    /// Share of those recovered.
    pub recovered_rate_le_1_5m: f64,
    /// Share of the runs without kidnap that said Lost at least once.
    pub false_lost_rate: f64,
    /// Median recovery time of the recovered trials, seconds.
    pub median_recovery_s: Option<f64>,
    /// 90th percentile of the recovery time of the recovered trials, seconds.
    pub p90_recovery_s: Option<f64>,
    /// Mean of `opdf_reference − opdf_kidnap` over the trials, percentage points.
    pub map_damage_opdf: f64,
    /// Largest damage of a trial, percentage points.
    pub map_damage_opdf_max: f64,
    /// Trials whose damage exceeds 1 point.
    pub damaged_trials: usize,
    /// Mean OPDF between the final maps with and without kidnap.
    pub opdf_vs_reference: f64,
    /// Poses returned by pose updating, over all trials.
    pub pose_recoveries: usize,
    /// Of those, poses whose error was above the criterion (a wrong pose accepted).
    pub wrong_pose_recoveries: usize,
    /// Per displacement bin.
    pub by_bin: Vec<BinSummary>,
}

/// Summary of the trials of one case.
pub fn summarise_kidnap(case: MapCase, trials: &[KidnapTrial], params: &KidnapParams) -> KidnapSummary {
    let t: Vec<&KidnapTrial> = trials.iter().filter(|t| t.case == case).collect();
    let le: Vec<&&KidnapTrial> = t.iter().filter(|t| t.draw.displacement_m <= 1.5).collect();
    let times = |v: &[&KidnapTrial]| v.iter().filter(|t| t.recovered).filter_map(|t| t.recovery_s).collect::<Vec<_>>();
    let edges = &params.bin_edges_m;
    let by_bin = edges
        .windows(2)
        .enumerate()
        .map(|(i, w)| {
            let last = i + 2 == edges.len();
            let inb: Vec<&KidnapTrial> = t
                .iter()
                .copied()
                .filter(|x| {
                    let d = x.draw.displacement_m;
                    d >= w[0] && (d < w[1] || (last && d <= w[1]))
                })
                .collect();
            BinSummary {
                from_m: w[0],
                to_m: w[1],
                trials: inb.len(),
                detected_rate: frac(inb.iter().map(|x| x.detected)),
                recovered_rate: frac(inb.iter().map(|x| x.recovered)),
                median_recovery_s: median(times(&inb)),
            }
        })
        .collect();
    KidnapSummary {
        map: case,
        trials: t.len(),
        detected_rate: frac(t.iter().map(|x| x.detected)),
        recovered_rate: frac(t.iter().map(|x| x.recovered)),
        trials_le_1_5m: le.len(),
        recovered_rate_le_1_5m: frac(le.iter().map(|x| x.recovered)),
        false_lost_rate: frac(t.iter().map(|x| x.reference_lost > 0)),
        median_recovery_s: median(times(&t)),
        p90_recovery_s: percentile(times(&t), 0.9),
        map_damage_opdf: mean(t.iter().map(|x| x.map_damage_opdf)),
        map_damage_opdf_max: t.iter().map(|x| x.map_damage_opdf).fold(0.0, f64::max),
        damaged_trials: t.iter().filter(|x| x.map_damage_opdf > 1.0).count(),
        opdf_vs_reference: mean(t.iter().map(|x| x.opdf_vs_reference)),
        pose_recoveries: t.iter().map(|x| x.recoveries).sum(),
        wrong_pose_recoveries: t.iter().map(|x| x.wrong_recoveries).sum(),
        by_bin,
    }
}

/// One trial in one map case: the run with the kidnap and the same run without it.
pub fn run_kidnap_trial(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
    trial: usize,
    case: MapCase,
) -> Result<KidnapTrial, ExperimentError> {
    let k = &params.kidnap;
    let c = &params.success;
    let draw = draw_trial(params, seed, trial);
    let (_, g) = setup.world(draw.world)?;
    let map = match case {
        MapCase::Stale => setup.initial_map(k.stale_map),
        MapCase::Best => g,
    };
    let drive = setup.drive(draw.world, map, &params.tour, draw.tour_position_m, k.route_length_m)?;
    let mut rp = params.runner.clone();
    rp.max_sim_time_s = draw.kidnap_s + k.recovery_window_s + c.hold_s;
    let label = format!("kidnap-{trial:04}");
    let reference = drive.run(&rp, seed, &label)?;
    rp.kidnap = Some(Kidnap {
        at_s: draw.kidnap_s,
        dx_m: draw.displacement_m * draw.direction_rad.cos(),
        dy_m: draw.displacement_m * draw.direction_rad.sin(),
        dyaw_rad: draw.yaw_rad,
        sigma_xy_m: k.sigma_xy_m,
        sigma_yaw_rad: k.sigma_yaw_rad,
    });
    let run = drive.run(&rp, seed, &label)?;
    let opdf_kidnap = map_metrics(&run.map, g, &params.metrics)?.opdf;
    let opdf_reference = map_metrics(&reference.map, g, &params.metrics)?.opdf;
    let opdf_vs_reference = map_metrics(&run.map, &reference.map, &params.metrics)?.opdf;
    let cells_differing = run.map.cells().iter().zip(reference.map.cells()).filter(|(a, b)| a != b).count() as u64;
    let rec = run.kidnap.as_ref();
    let track = rec.map(|r| r.track.as_slice()).unwrap_or_default();
    let at = rec.map_or(draw.kidnap_s, |r| r.at_s);
    let recovery_s = recovery_time(track, c).map(|t| t - at);
    let is_wrong = |s: &&TrackSample| !c.holds(s.error_m, s.yaw_error_rad);
    Ok(KidnapTrial {
        case,
        trial,
        draw,
        applied: rec.is_some(),
        lost_before: rec.map_or(run.updater.lost, |r| r.lost_before),
        detected: rec.is_some_and(|r| r.first_lost_s.is_some()),
        detection_delay_s: rec.and_then(|r| r.first_lost_s.map(|t| t - r.at_s)),
        recovered: recovery_s.is_some_and(|t| t <= k.recovery_window_s + 1e-9),
        recovery_s,
        recoveries: rec.map_or(0, |r| r.recoveries.len()),
        wrong_recoveries: rec.map_or(0, |r| r.recoveries.iter().filter(is_wrong).count()),
        failed_recoveries: rec.map_or(0, |r| r.failed_recoveries),
        final_error_m: track.last().map(|s| s.error_m),
        final_yaw_error_rad: track.last().map(|s| s.yaw_error_rad),
        reference_lost: reference.updater.lost,
        reference_final_error_m: reference.chain_errors.last().map(|e| e.error_m),
        opdf_kidnap,
        opdf_reference,
        map_damage_opdf: opdf_reference - opdf_kidnap,
        opdf_vs_reference,
        cells_differing,
    })
}

/// The kidnap suite as [`Trials`]: one job per (map case, trial), each a pair of runs
/// ([`run_kidnap_trial`]); the outcomes are the trials, stale ones first.
struct KidnapSuite<'a> {
    setup: &'a Setup,
    params: &'a RecoveryParams,
    seed: u64,
}

impl Trials for KidnapSuite<'_> {
    type Job = (MapCase, usize);
    type Outcome = KidnapTrial;
    type Summary = Vec<KidnapTrial>;

    fn draw(&self) -> Vec<(MapCase, usize)> {
        let mut cases = vec![MapCase::Stale];
        if self.params.kidnap.best_case {
            cases.push(MapCase::Best);
        }
        cases.iter().flat_map(|&c| (0..self.params.kidnap.trials).map(move |t| (c, t))).collect()
    }

    fn run(&self, (case, t): (MapCase, usize), progress: &(dyn Fn() + Sync)) -> Result<KidnapTrial, ExperimentError> {
        let r = run_kidnap_trial(self.setup, self.params, self.seed, t, case);
        progress();
        r
    }

    fn summarise(&self, trials: Vec<KidnapTrial>) -> Result<Vec<KidnapTrial>, ExperimentError> {
        Ok(trials)
    }
}

/// The kidnap suite: every trial in the stale case (and the best case if asked), in parallel,
/// in order (stale trials first). `progress()` is called after each trial and case.
pub fn run_kidnap_suite(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
    progress: &(dyn Fn() + Sync),
) -> Result<Vec<KidnapTrial>, ExperimentError> {
    run_trials(&KidnapSuite { setup, params, seed }, progress)
}
