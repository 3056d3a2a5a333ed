//! The localisation-check demo, the Table 1 analog and the lost robot.

use super::{Setup, frac, mean, mean_scores, median, recovery_time, scores, tour_from, with_start};
use crate::experiments::ExperimentError;
use crate::experiments::run_events::{Kidnap, TimelineSample, TrackSample, VerdictCounts};
use crate::experiments::runner::{NoClock, RunInputs, WorldRun, run_world};
use crate::experiments::setup::Scores;
use crate::experiments::trials::run_each;
use mapkeeper_grid::metrics::map_metrics;
use mapkeeper_sim::seeds::stream_rng;
use mapkeeper_updater::{UpdaterParams, Verdict};
use rand::RngExt;
use serde::{Deserialize, Serialize};

use super::RecoveryParams;

/// Run-length segment of the verdict timeline.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct VerdictSegment {
    /// The verdict.
    pub verdict: Verdict,
    /// Time of its first step, seconds.
    pub from_s: f64,
    /// Time of its last step, seconds.
    pub to_s: f64,
    /// Processed steps.
    pub steps: u32,
}

/// The demo's outcome (`summary.json` `demo`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DemoSummary {
    /// i of W_i.
    pub world: usize,
    /// Initial error, metres.
    pub start_error_m: f64,
    /// Simulated time, seconds.
    pub duration_s: f64,
    /// Verdicts over the run.
    pub verdicts: VerdictCounts,
    /// First Suspend, seconds.
    pub first_suspend_s: Option<f64>,
    /// First Lost, seconds.
    pub first_lost_s: Option<f64>,
    /// First Update, seconds.
    pub first_update_s: Option<f64>,
    /// The chain localiser's position error at the first Update, metres.
    pub error_at_first_update_m: Option<f64>,
    /// Share of Update among the steps from the first Update on.
    pub update_share_after_first_update: f64,
    /// The chain localiser's error at the end, metres.
    pub final_error_m: Option<f64>,
    /// Cells changed in M_2 by the end.
    pub cells_changed: u64,
    /// The expected behaviour: updates suspended (Suspend before any Update), then resumed
    /// (Update, and at least 90 % of the steps after the first Update are Update).
    pub suspended_then_updated: bool,
    /// The verdicts as run-length segments.
    pub segments: Vec<VerdictSegment>,
}

fn segments(tl: &[TimelineSample]) -> Vec<VerdictSegment> {
    let mut out: Vec<VerdictSegment> = Vec::new();
    for s in tl {
        match out.last_mut() {
            Some(seg) if seg.verdict == s.verdict => {
                seg.to_s = s.t_s;
                seg.steps += 1;
            }
            _ => out.push(VerdictSegment { verdict: s.verdict, from_s: s.t_s, to_s: s.t_s, steps: 1 }),
        }
    }
    out
}

fn counts(tl: &[TimelineSample]) -> VerdictCounts {
    let mut c = VerdictCounts::default();
    for s in tl {
        match s.verdict {
            Verdict::Update => c.update += 1,
            Verdict::Suspend => c.suspend += 1,
            Verdict::Lost => c.lost += 1,
        }
    }
    c
}

/// The demo: the summary and the full timeline of processed steps.
pub fn run_demo(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
) -> Result<(DemoSummary, Vec<TimelineSample>), ExperimentError> {
    let d = &params.demo;
    let (world, _) = setup.world(d.world)?;
    let (start, route) = tour_from(&params.tour, d.tour_position_m, params.tour.length_m());
    let world = with_start(world, start);
    let map = setup.initial_map(params.initial_map);
    // To the right of the heading.
    let (s, c) = start.yaw.sin_cos();
    let mut rp = params.runner.clone();
    rp.max_sim_time_s = d.duration_s;
    rp.record_timeline = true;
    rp.kidnap = Some(Kidnap {
        at_s: 0.0,
        dx_m: d.start_error_m * s,
        dy_m: -d.start_error_m * c,
        dyaw_rad: 0.0,
        sigma_xy_m: d.init_sigma_xy_m,
        sigma_yaw_rad: d.init_sigma_yaw_rad,
    });
    let inputs = RunInputs { world: &world, route: &route, prev_map: map, baseline_map: map, prev_memory: None };
    let run = run_world(&inputs, &rp, seed, "demo", &NoClock)?;
    let tl = run.timeline;
    let first = |v: Verdict| tl.iter().find(|s| s.verdict == v);
    let first_update = first(Verdict::Update);
    let after: Vec<&TimelineSample> =
        first_update.map(|f| tl.iter().filter(|s| s.t_s >= f.t_s).collect()).unwrap_or_default();
    let share = if after.is_empty() {
        0.0
    } else {
        after.iter().filter(|s| s.verdict == Verdict::Update).count() as f64 / after.len() as f64
    };
    let suspend_before = match (first(Verdict::Suspend), first_update) {
        (Some(s), Some(u)) => s.t_s < u.t_s,
        _ => false,
    };
    let summary = DemoSummary {
        world: d.world,
        start_error_m: d.start_error_m,
        duration_s: d.duration_s,
        verdicts: counts(&tl),
        first_suspend_s: first(Verdict::Suspend).map(|s| s.t_s),
        first_lost_s: first(Verdict::Lost).map(|s| s.t_s),
        first_update_s: first_update.map(|s| s.t_s),
        error_at_first_update_m: first_update.map(|s| s.error_m),
        update_share_after_first_update: share,
        final_error_m: run.kidnap.as_ref().and_then(|k| k.track.last()).map(|s| s.error_m),
        cells_changed: run.cells_changed,
        suspended_then_updated: suspend_before
            && tl.first().is_some_and(|s| s.verdict != Verdict::Update)
            && share >= 0.9,
        segments: segments(&tl),
    };
    Ok((summary, tl))
}

/// One Table 1 run (one error direction, both updaters).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1Run {
    /// Run index.
    pub run: usize,
    /// Direction of the start error, radians (map frame).
    pub direction_rad: f64,
    /// M_2/G_2 with `always-update`.
    pub always_update: Scores,
    /// M_2/G_2 with the localisation check (`paper`).
    pub check: Scores,
    /// Verdicts of the `paper` run.
    pub check_verdicts: VerdictCounts,
    /// Cells changed by `always-update`.
    pub always_update_cells_changed: u64,
    /// Cells changed with the check.
    pub check_cells_changed: u64,
}

/// Fractions per metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MetricFractions {
    /// CC.
    pub cc: f64,
    /// MS.
    pub ms: f64,
    /// OPDF.
    pub opdf: f64,
}

/// `summary.json` `table1`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Table1Summary {
    /// i of W_i.
    pub world: usize,
    /// Initial error, metres.
    pub start_error_m: f64,
    /// Runs.
    pub runs: usize,
    /// Mean M_2/G_2 with `always-update`.
    pub always_update: Scores,
    /// Mean M_2/G_2 with the localisation check.
    pub check: Scores,
    /// The initial map against G_2 (nothing updated).
    pub static_map: Scores,
    /// Share of runs where the check's map scores higher.
    pub check_better_fraction: MetricFractions,
    /// The check's mean is higher on all three metrics (the paper's Table 1 direction).
    pub direction_reproduced: bool,
    /// The paper's Table 1, always-update ("old").
    pub paper_always_update: Scores,
    /// The paper's Table 1, with the check ("new").
    pub paper_check: Scores,
}

/// A start error of `error_m` at `t = 0` in a direction drawn from `stream`.
fn start_kidnap(seed: u64, stream: &str, error_m: f64, sigma_xy_m: f64, sigma_yaw_rad: f64) -> (f64, Kidnap) {
    let mut rng = stream_rng(seed, stream);
    let dir = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
    let k = Kidnap {
        at_s: 0.0,
        dx_m: error_m * dir.cos(),
        dy_m: error_m * dir.sin(),
        dyaw_rad: 0.0,
        sigma_xy_m,
        sigma_yaw_rad,
    };
    (dir, k)
}

/// The Table 1 analog: per run and the summary.
pub fn run_table1(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
) -> Result<(Table1Summary, Vec<Table1Run>), ExperimentError> {
    let t = &params.table1;
    let (world, g) = setup.world(t.world)?;
    let (start, route) = tour_from(&params.tour, t.tour_position_m, t.route_length_m);
    let world = with_start(world, start);
    let map = setup.initial_map(params.initial_map);
    let presets = [UpdaterParams::always_update(), UpdaterParams::paper()];
    let jobs: Vec<(usize, usize)> = (0..t.runs).flat_map(|r| [(r, 0), (r, 1)]).collect();
    let results: Vec<(f64, WorldRun)> = run_each(jobs, |(r, k)| {
        let label = format!("table1-{r:03}");
        let (dir, kid) =
            start_kidnap(seed, &format!("{label}/error"), t.start_error_m, t.init_sigma_xy_m, t.init_sigma_yaw_rad);
        let mut rp = params.runner.clone();
        rp.updater = presets[k].clone();
        rp.kidnap = Some(kid);
        rp.record_timeline = true;
        let inputs = RunInputs { world: &world, route: &route, prev_map: map, baseline_map: map, prev_memory: None };
        run_world(&inputs, &rp, seed, &label, &NoClock).map(|run| (dir, run))
    })?;
    let mut runs = Vec::with_capacity(t.runs);
    for (r, pair) in results.chunks(2).enumerate() {
        let [(dir, au), (_, ck)] = pair else { continue };
        runs.push(Table1Run {
            run: r,
            direction_rad: *dir,
            always_update: scores(&au.map, g, &params.metrics)?,
            check: scores(&ck.map, g, &params.metrics)?,
            check_verdicts: counts(&ck.timeline),
            always_update_cells_changed: au.cells_changed,
            check_cells_changed: ck.cells_changed,
        });
    }
    let always_update = mean_scores(runs.iter().map(|r| &r.always_update));
    let check = mean_scores(runs.iter().map(|r| &r.check));
    let summary = Table1Summary {
        world: t.world,
        start_error_m: t.start_error_m,
        runs: runs.len(),
        always_update,
        check,
        static_map: scores(map, g, &params.metrics)?,
        check_better_fraction: MetricFractions {
            cc: frac(runs.iter().map(|r| r.check.cc > r.always_update.cc)),
            ms: frac(runs.iter().map(|r| r.check.ms > r.always_update.ms)),
            opdf: frac(runs.iter().map(|r| r.check.opdf > r.always_update.opdf)),
        },
        direction_reproduced: !runs.is_empty()
            && check.cc > always_update.cc
            && check.ms > always_update.ms
            && check.opdf > always_update.opdf,
        paper_always_update: Scores { cc: 66.86, ms: 55.11, opdf: 90.40 },
        paper_check: Scores { cc: 70.03, ms: 61.24, opdf: 95.87 },
    };
    Ok((summary, runs))
}

/// One lost-robot run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostRun {
    /// Run index.
    pub run: usize,
    /// Direction of the start error, radians.
    pub direction_rad: f64,
    /// The check said Lost.
    pub detected: bool,
    /// First Lost, seconds.
    pub first_lost_s: Option<f64>,
    /// Poses returned by pose updating.
    pub recoveries: usize,
    /// Pose recoveries refused.
    pub failed_recoveries: u64,
    /// Largest position error of a returned pose, metres.
    pub worst_recovery_error_m: Option<f64>,
    /// The chain localiser's error came under the criterion for good, at this time, seconds.
    pub recovered_s: Option<f64>,
    /// The chain localiser's final error, metres.
    pub final_error_m: Option<f64>,
    /// M_2/G_2 of this run.
    pub with_error: Scores,
    /// M_2/G_2 of the same run without the start error.
    pub without_error: Scores,
    /// M_2/G_2 of this run with `always-update` (no check, no pose updating).
    pub always_update_with_error: Scores,
    /// OPDF between M_2 of this run and M_2 without the error.
    pub opdf_vs_without_error: f64,
    /// Cells that differ between the two maps.
    pub cells_differing: u64,
    /// CC, MS and OPDF within the tolerance of the run without error.
    pub not_corrupted: bool,
}

/// `summary.json` `lost_robot`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostSummary {
    /// i of W_i.
    pub world: usize,
    /// Initial error, metres.
    pub start_error_m: f64,
    /// Runs.
    pub runs: usize,
    /// Runs in which the check said Lost.
    pub detected: usize,
    /// Runs recovered (error under the criterion for good, by pose updating or the localiser).
    pub recovered: usize,
    /// Runs recovered with at least one pose from pose updating.
    pub recovered_by_pose_updating: usize,
    /// Median recovery time, seconds.
    pub median_recovery_s: Option<f64>,
    /// Poses returned by pose updating that were wrong (error above the criterion).
    pub wrong_recoveries: usize,
    /// Mean M_2/G_2 with the error.
    pub with_error: Scores,
    /// Mean M_2/G_2 without it.
    pub without_error: Scores,
    /// Mean M_2/G_2 with the error and `always-update`.
    pub always_update_with_error: Scores,
    /// Mean OPDF between the maps with and without the error.
    pub opdf_vs_without_error: f64,
    /// Every run's map is within the tolerance of the run without error.
    pub not_corrupted: bool,
}

/// The lost robot: per run and the summary.
pub fn run_lost_robot(
    setup: &Setup,
    params: &RecoveryParams,
    seed: u64,
) -> Result<(LostSummary, Vec<LostRun>), ExperimentError> {
    let l = &params.lost;
    let c = &params.success;
    let (world, g) = setup.world(l.world)?;
    let (start, route) = tour_from(&params.tour, l.tour_position_m, l.route_length_m);
    let world = with_start(world, start);
    let map = setup.initial_map(params.initial_map);
    let jobs: Vec<(usize, usize)> = (0..l.runs).flat_map(|r| [(r, 0), (r, 1), (r, 2)]).collect();
    let results: Vec<(f64, WorldRun)> = run_each(jobs, |(r, k)| {
        let label = format!("lost-{r:03}");
        let (dir, kid) =
            start_kidnap(seed, &format!("{label}/error"), l.start_error_m, l.init_sigma_xy_m, l.init_sigma_yaw_rad);
        let mut rp = params.runner.clone();
        rp.record_timeline = true;
        match k {
            0 => rp.kidnap = Some(kid),
            1 => rp.kidnap = Some(Kidnap { dx_m: 0.0, dy_m: 0.0, ..kid }),
            _ => {
                rp.kidnap = Some(kid);
                rp.updater = UpdaterParams::always_update();
            }
        }
        let inputs = RunInputs { world: &world, route: &route, prev_map: map, baseline_map: map, prev_memory: None };
        run_world(&inputs, &rp, seed, &label, &NoClock).map(|run| (dir, run))
    })?;
    let mut runs = Vec::with_capacity(l.runs);
    for (r, triple) in results.chunks(3).enumerate() {
        let [(dir, err), (_, reference), (_, au)] = triple else { continue };
        let track = err.kidnap.as_ref().map(|k| k.track.as_slice()).unwrap_or_default();
        let recs = err.kidnap.as_ref().map(|k| k.recoveries.as_slice()).unwrap_or_default();
        let with_error = scores(&err.map, g, &params.metrics)?;
        let without_error = scores(&reference.map, g, &params.metrics)?;
        let tol = l.corruption_tolerance_pct;
        runs.push(LostRun {
            run: r,
            direction_rad: *dir,
            detected: err.updater.lost > 0,
            first_lost_s: err.kidnap.as_ref().and_then(|k| k.first_lost_s),
            recoveries: recs.len(),
            failed_recoveries: err.kidnap.as_ref().map_or(0, |k| k.failed_recoveries),
            worst_recovery_error_m: recs.iter().map(|s| s.error_m).reduce(f64::max),
            recovered_s: recovery_time(track, c),
            final_error_m: track.last().map(|s| s.error_m),
            with_error,
            without_error,
            always_update_with_error: scores(&au.map, g, &params.metrics)?,
            opdf_vs_without_error: map_metrics(&err.map, &reference.map, &params.metrics)?.opdf,
            cells_differing: err.map.cells().iter().zip(reference.map.cells()).filter(|(a, b)| a != b).count() as u64,
            not_corrupted: with_error.cc >= without_error.cc - tol
                && with_error.ms >= without_error.ms - tol
                && with_error.opdf >= without_error.opdf - tol,
        });
    }
    let is_wrong = |s: &TrackSample| s.error_m >= c.max_error_m || s.yaw_error_rad >= c.max_yaw_error_rad;
    let wrong_recoveries = results
        .chunks(3)
        .filter_map(|t| t.first())
        .filter_map(|(_, r)| r.kidnap.as_ref())
        .map(|k| k.recoveries.iter().filter(|s| is_wrong(s)).count())
        .sum();
    let summary = LostSummary {
        world: l.world,
        start_error_m: l.start_error_m,
        runs: runs.len(),
        detected: runs.iter().filter(|r| r.detected).count(),
        recovered: runs.iter().filter(|r| r.recovered_s.is_some()).count(),
        recovered_by_pose_updating: runs.iter().filter(|r| r.recovered_s.is_some() && r.recoveries > 0).count(),
        median_recovery_s: median(runs.iter().filter_map(|r| r.recovered_s).collect()),
        wrong_recoveries,
        with_error: mean_scores(runs.iter().map(|r| &r.with_error)),
        without_error: mean_scores(runs.iter().map(|r| &r.without_error)),
        always_update_with_error: mean_scores(runs.iter().map(|r| &r.always_update_with_error)),
        opdf_vs_without_error: mean(runs.iter().map(|r| r.opdf_vs_without_error)),
        not_corrupted: !runs.is_empty() && runs.iter().all(|r| r.not_corrupted),
    };
    Ok((summary, runs))
}
