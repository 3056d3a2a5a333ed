//! The summary over seeds (`summary.json`): map quality static against updated, the best
//! achievable and the fresh map, localisation, the updater's work and the heaviest change.

use super::params::{GroundTruth, ValidationParams};
use super::record::{GroundTruthScores, SeedRecord, SeedRun, ValidationRecord, WorldRow, merge_histograms, tool_name};
use crate::experiments::scores::Scores;
use crate::experiments::validation::erosion::{
    ChangeClassSummary, ChangeClasses, ClassScores, ClassSummary, RETENTION_TARGET_PCT, Retention, RetentionSummary,
};
use crate::stats::histogram_median;
use crate::stats::{IntervalUnits, PairedDiff, chain_diff, chain_units, frac, mean};
use mapkeeper_closed_loop::controls::LostCounts;
use mapkeeper_closed_loop::pose_oracle::GivenPoseStats;
use mapkeeper_closed_loop::runner::{LocStats, UpdaterCounts};
use serde::{Deserialize, Serialize};

/// Static-vs-updated figures of one map metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MetricSummary {
    /// Mean of M_1/G_i over all worlds and seeds, percent.
    pub static_mean: f64,
    /// Mean of M_i/G_i, percent.
    pub updated_mean: f64,
    /// Share of world rows where M_i/G_i > M_1/G_i.
    pub updated_better_fraction: f64,
    /// Mean M_i/G_i over the last world of each seed (W_N), percent.
    pub updated_last: f64,
    /// Mean M_1/G_i over the last world of each seed, percent.
    pub static_last: f64,
    /// Mean over seeds of each seed's mean of M_i/G_i − M_1/G_i over its worlds, percentage
    /// points (equal to `updated_mean − static_mean` when every seed has as many worlds).
    #[serde(default)]
    pub diff_mean: f64,
    /// 95 % interval of `diff_mean` (Student t), `[lo, hi]`: paired with the seeds as units (the
    /// worlds of a seed are not independent), or with one seed over batches of its consecutive
    /// worlds (the summary's `interval_units`); `null` with one seed of fewer than 20 updated worlds.
    #[serde(default)]
    pub diff_ci95: Option<[f64; 2]>,
}

/// Map-quality section of the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MapQuality {
    /// Cross-correlation.
    pub cc: MetricSummary,
    /// Map score.
    pub ms: MetricSummary,
    /// OPDF.
    pub opdf: MetricSummary,
}

/// The best achievable map against one metric: how much of the possible improvement M_i made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BestSummary {
    /// Mean of M*_i/G_i over all worlds and seeds, percent.
    pub best_mean: f64,
    /// (mean M_i/G_i − mean M_1/G_i) / (mean M*_i/G_i − mean M_1/G_i): the share of the
    /// achievable improvement M_i reaches (1 = all of it, 0 = none, negative = worse than M_1);
    /// `null` when M*_i is no better than M_1 (nothing to achieve).
    pub achieved_fraction: Option<f64>,
}

/// [`BestSummary`] per metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct BestAchievable {
    /// Cross-correlation.
    pub cc: BestSummary,
    /// Map score.
    pub ms: BestSummary,
    /// OPDF.
    pub opdf: BestSummary,
}

/// The map quality against one ground truth variant, with the best achievable map.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GroundTruthQuality {
    /// M_1 and M_i against it.
    pub map_quality: MapQuality,
    /// M*_i against it.
    pub best_achievable: BestAchievable,
    /// Means over all worlds and seeds of the fresh map F_i against it.
    pub fresh_map: Scores,
}

/// Both ground truth variants side by side.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ByGroundTruth {
    /// The exact raster over the whole grid.
    pub exact: GroundTruthQuality,
    /// What the exploration route observes, over the interior.
    pub observed: GroundTruthQuality,
}

/// One localiser's figures over all worlds and seeds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LocSummary {
    /// Mean over worlds of the per-world mean position error, metres.
    pub mean_error_m: f64,
    /// Largest position error seen, metres.
    pub max_error_m: f64,
    /// Mean of the per-world max error, metres.
    pub mean_max_error_m: f64,
    /// Root mean square over worlds of the per-world RMSE, metres.
    pub rmse_m: f64,
    /// Mean covariance trace.
    pub mean_trace: f64,
    /// Mean λmax.
    pub mean_lambda_max: f64,
}

/// Localisation section of the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Localisation {
    /// Baseline localiser on M_1.
    pub static_map: LocSummary,
    /// Chain localiser on M_{i-1}.
    pub updated_map: LocSummary,
    /// Share of world rows where the chain's mean error is below the baseline's.
    pub updated_better_fraction: f64,
    /// Share of world rows where the chain's mean covariance trace is below the baseline's.
    pub updated_lower_trace_fraction: f64,
    /// Mean over seeds of each seed's mean (over worlds) of the chain's mean position error
    /// minus the baseline's, metres (negative: the chain on M_{i-1} is better).
    #[serde(default)]
    pub error_diff_mean_m: f64,
    /// 95 % interval of `error_diff_mean_m`, `[lo, hi]`, in the units of `diff_ci95`'s.
    #[serde(default)]
    pub error_diff_ci95_m: Option<[f64; 2]>,
}

/// Updater section of the summary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UpdaterSummary {
    /// Median updater time per processed scan over all worlds and seeds, microseconds (0 when
    /// not measured).
    pub median_scan_us: f64,
    /// Largest updater change state seen (the sparse cell buffers, growing with the touched
    /// cells), bytes.
    pub max_state_bytes: u64,
    /// Largest map-sized cache of the updater (both grids, clearance field, interior mask,
    /// score grid; growing with the map's area), bytes.
    #[serde(default)]
    pub max_cache_bytes: u64,
    /// Processed scans.
    pub processed_scans: u64,
    /// Valid beams processed.
    pub beams: u64,
    /// Verdicts Update.
    pub update: u64,
    /// Verdicts Suspend.
    pub suspend: u64,
    /// Verdicts Lost.
    pub lost: u64,
    /// Successful pose recoveries.
    pub recovered: u64,
    /// Cell state changes applied.
    pub cell_changes: u64,
    /// Registration before writing over all worlds and seeds (zeros when it is off).
    #[serde(default)]
    pub registration: mapkeeper_updater::RegistrationStats,
    /// "Changed" votes of the memory's healing rule over all worlds and seeds.
    #[serde(default)]
    pub heal_votes: u64,
}

/// `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Producer and version.
    pub tool: String,
    /// The seeds, in order.
    pub seeds: Vec<u64>,
    /// N.
    pub worlds: usize,
    /// The updater preset.
    pub preset: String,
    /// The localiser preset both localisers were made from (its parameters: `params.runner.filter`).
    #[serde(default = "default_localiser")]
    pub localiser: String,
    /// Wall time of the whole run, seconds (0 when not measured).
    pub wall_time_s: f64,
    /// The units of every 95 % interval of this summary: `seeds`, or with one seed
    /// `world-batches` (docs/evaluation.md, "Intervals").
    #[serde(default)]
    pub interval_units: IntervalUnits,
    /// M_1/G_1, mean over seeds.
    pub initial_map: Scores,
    /// The ground truth of `initial_map` and `map_quality` (`exact` or `observed`).
    pub ground_truth: GroundTruth,
    /// Map quality against that ground truth.
    pub map_quality: MapQuality,
    /// Map quality against both ground truth variants, each with the best achievable map.
    pub by_ground_truth: ByGroundTruth,
    /// Localisation.
    pub localisation: Localisation,
    /// Updater.
    pub updater: UpdaterSummary,
    /// Contacts of the robot over all worlds and seeds.
    pub collisions: u64,
    /// Worlds whose route was completed, of all world rows.
    pub routes_completed: usize,
    /// World rows.
    pub rows: usize,
    /// Simulated time over all worlds and seeds, seconds.
    pub sim_time_s: f64,
    /// The reaction to Lost, summed over all worlds and seeds.
    #[serde(default)]
    pub lost_handling: LostCounts,
    /// The check under heavy change (only with `params.update_every` > 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heavy_change: Option<HeavyChange>,
    /// Structure retention of M_i, M*_i and F_i against the exact G_i: at W_2, at W_N, the
    /// mean, and the target at W_N. Absent when no row has it (records written before it was
    /// measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retention: Option<RetentionSummary>,
    /// The shares of added, removed and moved cells that M_i, M*_i and F_i got right (absent as
    /// `retention`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change_classes: Option<ChangeClassSummary>,
    /// The error of the poses the updater was given, pooled over all worlds and seeds (only
    /// with a pose source other than the chain localiser, `params.runner.updater_poses`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub updater_pose_error: Option<GivenPoseStats>,
    /// The parameters.
    pub params: ValidationParams,
}

fn default_localiser() -> String {
    "mapkeeper".into()
}

/// Per seed, the mean over its worlds of `f(row)`; their mean and 95 % interval, over the seeds
/// or, with one seed, over batches of its worlds ([`chain_diff`]; the units are
/// [`interval_units`]'s).
fn per_seed_diff(runs: &[SeedRecord], f: impl Fn(&WorldRow) -> f64) -> PairedDiff {
    let per_seed: Vec<Vec<f64>> =
        runs.iter().filter(|r| !r.rows.is_empty()).map(|r| r.rows.iter().map(&f).collect()).collect();
    chain_diff(&per_seed).0
}

/// The units of the intervals of a summary of `runs` ([`chain_units`] of the seeds with worlds).
pub fn interval_units(runs: &[SeedRecord]) -> IntervalUnits {
    let worlds: Vec<usize> = runs.iter().map(|r| r.rows.len()).filter(|&n| n > 0).collect();
    chain_units(&worlds)
}

/// The three scores of a row against the run's own ground truth (`other` false) or the other one.
fn row_scores(w: &WorldRow, other: bool) -> GroundTruthScores {
    if other {
        w.other_ground_truth
    } else {
        GroundTruthScores {
            static_map: w.static_map,
            updated_map: w.updated_map,
            best_map: w.best_map,
            fresh_map: w.fresh_map,
        }
    }
}

fn metric_summary(runs: &[SeedRecord], other: bool, f: impl Fn(&Scores) -> f64) -> MetricSummary {
    let rows = || runs.iter().flat_map(|r| r.rows.iter()).map(|w| row_scores(w, other));
    let last = || runs.iter().filter_map(|r| r.rows.last()).map(|w| row_scores(w, other));
    let diff = per_seed_diff(runs, |w| {
        let g = row_scores(w, other);
        f(&g.updated_map) - f(&g.static_map)
    });
    MetricSummary {
        diff_mean: diff.mean,
        diff_ci95: diff.ci95,
        static_mean: mean(rows().map(|w| f(&w.static_map))),
        updated_mean: mean(rows().map(|w| f(&w.updated_map))),
        updated_better_fraction: frac(rows().map(|w| f(&w.updated_map) > f(&w.static_map))),
        updated_last: mean(last().map(|w| f(&w.updated_map))),
        static_last: mean(last().map(|w| f(&w.static_map))),
    }
}

fn map_quality(runs: &[SeedRecord], other: bool) -> MapQuality {
    MapQuality {
        cc: metric_summary(runs, other, |s| s.cc),
        ms: metric_summary(runs, other, |s| s.ms),
        opdf: metric_summary(runs, other, |s| s.opdf),
    }
}

fn best_summary(runs: &[SeedRecord], other: bool, q: &MetricSummary, f: impl Fn(&Scores) -> f64) -> BestSummary {
    let best_mean = mean(runs.iter().flat_map(|r| r.rows.iter()).map(|w| f(&row_scores(w, other).best_map)));
    let possible = best_mean - q.static_mean;
    let achieved_fraction = (possible > 1e-9).then(|| (q.updated_mean - q.static_mean) / possible);
    BestSummary { best_mean, achieved_fraction }
}

fn ground_truth_quality(runs: &[SeedRecord], other: bool) -> GroundTruthQuality {
    let q = map_quality(runs, other);
    let best_achievable = BestAchievable {
        cc: best_summary(runs, other, &q.cc, |s| s.cc),
        ms: best_summary(runs, other, &q.ms, |s| s.ms),
        opdf: best_summary(runs, other, &q.opdf, |s| s.opdf),
    };
    let fresh = |f: fn(&Scores) -> f64| {
        mean(runs.iter().flat_map(|r| r.rows.iter()).map(|w| f(&row_scores(w, other).fresh_map)))
    };
    let fresh_map = Scores { cc: fresh(|s| s.cc), ms: fresh(|s| s.ms), opdf: fresh(|s| s.opdf) };
    GroundTruthQuality { map_quality: q, best_achievable, fresh_map }
}

fn loc_summary(runs: &[SeedRecord], f: impl Fn(&WorldRow) -> &LocStats) -> LocSummary {
    let rows = || runs.iter().flat_map(|r| r.rows.iter()).map(&f);
    LocSummary {
        mean_error_m: mean(rows().map(|s| s.mean_error_m)),
        max_error_m: rows().map(|s| s.max_error_m).fold(0.0, f64::max),
        mean_max_error_m: mean(rows().map(|s| s.max_error_m)),
        rmse_m: mean(rows().map(|s| s.rmse_m * s.rmse_m)).sqrt(),
        mean_trace: mean(rows().map(|s| s.mean_trace)),
        mean_lambda_max: mean(rows().map(|s| s.mean_lambda_max)),
    }
}

/// The summary over seeds (in the given order). `wall_time_s` is supplied by the caller.
pub fn summarise(params: &ValidationParams, runs: &[SeedRun], wall_time_s: f64) -> Summary {
    let records: Vec<SeedRecord> = runs.iter().map(SeedRun::record).collect();
    summarise_records(params, &records, wall_time_s)
}

/// [`summarise`] from the seeds' records (e.g. read back from `runs.json` files): the same
/// summary, bit for bit.
pub fn summarise_records(params: &ValidationParams, runs: &[SeedRecord], wall_time_s: f64) -> Summary {
    let rows = || runs.iter().flat_map(|r| r.rows.iter());
    let times = merge_histograms(runs.iter().map(|r| r.scan_time_histogram_us.as_slice()));
    let sum_u = |f: fn(&UpdaterCounts) -> u64| rows().map(|w| f(&w.updater)).sum::<u64>();
    let loc_diff = per_seed_diff(runs, |w| w.loc_updated.mean_error_m - w.loc_static.mean_error_m);
    Summary {
        tool: tool_name(),
        seeds: runs.iter().map(|r| r.seed).collect(),
        worlds: params.worlds,
        preset: params.preset.clone(),
        localiser: params.runner.localiser.clone(),
        wall_time_s,
        interval_units: interval_units(runs),
        initial_map: Scores {
            cc: mean(runs.iter().map(|r| r.initial_scores.cc)),
            ms: mean(runs.iter().map(|r| r.initial_scores.ms)),
            opdf: mean(runs.iter().map(|r| r.initial_scores.opdf)),
        },
        ground_truth: params.ground_truth,
        map_quality: map_quality(runs, false),
        by_ground_truth: match params.ground_truth {
            GroundTruth::Exact => {
                ByGroundTruth { exact: ground_truth_quality(runs, false), observed: ground_truth_quality(runs, true) }
            }
            GroundTruth::Observed => {
                ByGroundTruth { exact: ground_truth_quality(runs, true), observed: ground_truth_quality(runs, false) }
            }
        },
        localisation: Localisation {
            static_map: loc_summary(runs, |w| &w.loc_static),
            updated_map: loc_summary(runs, |w| &w.loc_updated),
            updated_better_fraction: frac(rows().map(|w| w.loc_updated.mean_error_m < w.loc_static.mean_error_m)),
            updated_lower_trace_fraction: frac(rows().map(|w| w.loc_updated.mean_trace < w.loc_static.mean_trace)),
            error_diff_mean_m: loc_diff.mean,
            error_diff_ci95_m: loc_diff.ci95,
        },
        updater: UpdaterSummary {
            median_scan_us: histogram_median(&times),
            max_state_bytes: rows().map(|w| w.updater.max_state_bytes).max().unwrap_or(0),
            max_cache_bytes: rows().map(|w| w.updater.cache_bytes).max().unwrap_or(0),
            processed_scans: sum_u(|u| u.processed),
            beams: sum_u(|u| u.beams),
            update: sum_u(|u| u.update),
            suspend: sum_u(|u| u.suspend),
            lost: sum_u(|u| u.lost),
            recovered: sum_u(|u| u.recovered),
            cell_changes: sum_u(|u| u.cell_changes),
            registration: rows().fold(Default::default(), |mut a, w| {
                a.add(&w.updater.registration);
                a
            }),
            heal_votes: sum_u(|u| u.heal_votes),
        },
        collisions: rows().map(|w| w.collisions).sum(),
        routes_completed: rows().filter(|w| w.route_done).count(),
        rows: rows().count(),
        sim_time_s: rows().map(|w| w.sim_time_s).sum(),
        lost_handling: rows().fold(LostCounts::default(), |a, w| a.add(&w.lost)),
        heavy_change: (params.update_every > 1).then(|| heavy_change(params.update_every, runs)),
        retention: retention_summary(runs),
        change_classes: change_class_summary(runs),
        updater_pose_error: (!params.runner.updater_poses.is_localiser())
            .then(|| GivenPoseStats::pool(rows().filter_map(|w| w.updater_pose_error.as_ref()))),
        params: params.clone(),
    }
}

impl Summary {
    /// This summary as versions before `interval_units` made it: with one seed, no interval
    /// (the same summary with several seeds, or with too few worlds for batches).
    pub fn without_one_seed_intervals(mut self) -> Summary {
        if self.interval_units == IntervalUnits::WorldBatches {
            let b = &mut self.by_ground_truth;
            for q in [&mut self.map_quality, &mut b.exact.map_quality, &mut b.observed.map_quality] {
                for m in [&mut q.cc, &mut q.ms, &mut q.opdf] {
                    m.diff_ci95 = None;
                }
            }
            self.localisation.error_diff_ci95_m = None;
            self.interval_units = IntervalUnits::Seeds;
        }
        self
    }
}

/// How the localisation check behaves when k worlds of change meet it at once
/// ([`ValidationParams::update_every`]), over the worlds whose map was updated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeavyChange {
    /// k.
    pub update_every: usize,
    /// World rows whose map was updated (over all seeds).
    pub update_worlds: usize,
    /// Suspend among their processed steps.
    pub suspend_share: f64,
    /// Lost among them.
    pub lost_share: f64,
    /// Mean position error of the chain localiser in those worlds, metres (how well localised
    /// the robot was while the check said so).
    pub mean_error_m: f64,
    /// Update worlds where fewer than half the processed steps said Update ("stuck").
    pub stuck_worlds: usize,
    /// Longest run of consecutive stuck update worlds in one seed.
    pub longest_stuck_run: usize,
    /// Mean cells changed per update world.
    pub mean_cells_changed: f64,
}

fn heavy_change(k: usize, runs: &[SeedRecord]) -> HeavyChange {
    let updated = |w: &&WorldRow| (w.world - 2).is_multiple_of(k);
    let rows: Vec<&WorldRow> = runs.iter().flat_map(|r| r.rows.iter()).filter(updated).collect();
    let processed: u64 = rows.iter().map(|w| w.updater.processed).sum();
    let share = |n: u64| if processed == 0 { 0.0 } else { n as f64 / processed as f64 };
    let stuck = |w: &WorldRow| w.updater.processed == 0 || 2 * w.updater.update < w.updater.processed;
    let longest = runs
        .iter()
        .map(|r| {
            let (mut best, mut cur) = (0, 0);
            for w in r.rows.iter().filter(updated) {
                cur = if stuck(w) { cur + 1 } else { 0 };
                best = best.max(cur);
            }
            best
        })
        .max()
        .unwrap_or(0);
    HeavyChange {
        update_every: k,
        update_worlds: rows.len(),
        suspend_share: share(rows.iter().map(|w| w.updater.suspend).sum()),
        lost_share: share(rows.iter().map(|w| w.updater.lost).sum()),
        mean_error_m: mean(rows.iter().map(|w| w.loc_updated.mean_error_m)),
        stuck_worlds: rows.iter().filter(|w| stuck(w)).count(),
        longest_stuck_run: longest,
        mean_cells_changed: mean(rows.iter().map(|w| w.cells_changed as f64)),
    }
}

/// The mean, `None` for no values.
fn mean_of_some(v: impl Iterator<Item = f64>) -> Option<f64> {
    let v: Vec<f64> = v.collect();
    (!v.is_empty()).then(|| mean(v.into_iter()))
}

/// [`RetentionSummary`] of `runs` (in seed order); `None` when no row has the figures.
pub fn retention_summary(runs: &[SeedRecord]) -> Option<RetentionSummary> {
    let rows: Vec<&Retention> = runs.iter().flat_map(|r| &r.rows).filter_map(|w| w.retention.as_ref()).collect();
    if rows.is_empty() {
        return None;
    }
    let per_seed = |last: bool| -> Vec<f64> {
        runs.iter()
            .filter_map(|r| if last { r.rows.last() } else { r.rows.first() })
            .filter_map(|w| w.retention.map(|x| x.updated_map))
            .collect()
    };
    let last = per_seed(true);
    let updated_last = mean(last.iter().copied());
    Some(RetentionSummary {
        rows: rows.len(),
        structure_cells_mean: mean(rows.iter().map(|x| x.structure_cells as f64)),
        updated_w2: mean(per_seed(false).into_iter()),
        updated_last,
        updated_last_min: last.iter().copied().reduce(f64::min).unwrap_or(updated_last),
        updated_mean: mean(rows.iter().map(|x| x.updated_map)),
        best_mean: mean(rows.iter().map(|x| x.best_map)),
        fresh_mean: mean(rows.iter().map(|x| x.fresh_map)),
        target_last: RETENTION_TARGET_PCT,
        target_met: updated_last >= RETENTION_TARGET_PCT,
    })
}

fn class_summary(runs: &[SeedRecord], pick: fn(&ChangeClasses) -> ClassScores) -> ClassSummary {
    let rows: Vec<ClassScores> =
        runs.iter().flat_map(|r| &r.rows).filter_map(|w| w.change_classes.as_ref()).map(pick).collect();
    ClassSummary {
        rows: rows.iter().filter(|c| c.cells > 0).count(),
        cells_mean: mean(rows.iter().map(|c| c.cells as f64)),
        updated_mean: mean_of_some(rows.iter().filter_map(|c| c.updated_map)),
        best_mean: mean_of_some(rows.iter().filter_map(|c| c.best_map)),
        fresh_mean: mean_of_some(rows.iter().filter_map(|c| c.fresh_map)),
        updated_last: mean_of_some(
            runs.iter().filter_map(|r| r.rows.last()?.change_classes.as_ref().map(pick)?.updated_map),
        ),
    }
}

/// [`ChangeClassSummary`] of `runs` (in seed order); `None` when no row has the figures.
pub fn change_class_summary(runs: &[SeedRecord]) -> Option<ChangeClassSummary> {
    let rows = runs.iter().flat_map(|r| &r.rows).filter(|w| w.change_classes.is_some()).count();
    (rows > 0).then(|| ChangeClassSummary {
        rows,
        added: class_summary(runs, |c| c.added),
        removed: class_summary(runs, |c| c.removed),
        moved: class_summary(runs, |c| c.moved),
        initial_errors: class_summary(runs, |c| c.initial_errors),
    })
}

impl ValidationRecord {
    /// The summary of this record.
    pub fn summary(&self) -> Summary {
        summarise_records(&self.params, &self.seeds, self.wall_time_s)
    }
}
