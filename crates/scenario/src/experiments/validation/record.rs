//! What a validation run records: one row per world ([`WorldRow`]), a seed's run and record,
//! the saved worlds, the scan-time histogram and `runs.json` ([`ValidationRecord`]), from which
//! every other output is recomputed.

use super::params::{Shard, ValidationParams};
use crate::experiments::scores::Scores;
use crate::experiments::validation::erosion::{ChangeClasses, Retention};
use mapkeeper_closed_loop::controls::LostCounts;
use mapkeeper_closed_loop::pose_oracle::GivenPoseStats;
use mapkeeper_closed_loop::runner::{LocStats, Trajectories, UpdaterCounts};
use mapkeeper_closed_loop::worlds::generator::Edit;
use mapkeeper_grid::OccupancyGrid;
use serde::{Deserialize, Serialize};

/// M_1, M_i and the best achievable map M*_i scored against one variant of G_i.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GroundTruthScores {
    /// M_1 / G_i.
    pub static_map: Scores,
    /// M_i / G_i.
    pub updated_map: Scores,
    /// M*_i / G_i: the best achievable map (M*_1 = M_1; M*_i is M*_{i-1} with every cell the
    /// route observes in W_i set to its state in W_i).
    pub best_map: Scores,
    /// F_i / G_i: a fresh map of W_i's run alone (the log-odds mapper of M_1, fed the run's
    /// scans at the chain localiser's estimates, no prior).
    pub fresh_map: Scores,
}

/// One world of one seed: a row of `worlds.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorldRow {
    /// The run seed.
    pub seed: u64,
    /// i in W_i.
    pub world: usize,
    /// Edits that made W_i from W_{i-1}.
    pub edits: usize,
    /// Movable items in W_i.
    pub movable_items: usize,
    /// M_1 / G_i (G_i the run's ground truth, `params.ground_truth`).
    pub static_map: Scores,
    /// M_i / G_i.
    pub updated_map: Scores,
    /// M*_i / G_i, the best achievable map ([`GroundTruthScores::best_map`]).
    pub best_map: Scores,
    /// F_i / G_i, the fresh map of this run ([`GroundTruthScores::fresh_map`]).
    pub fresh_map: Scores,
    /// The same four against the other ground truth variant.
    pub other_ground_truth: GroundTruthScores,
    /// The baseline localiser on M_1.
    pub loc_static: LocStats,
    /// The chain localiser on M_{i-1}.
    pub loc_updated: LocStats,
    /// The updater's verdicts and work.
    pub updater: UpdaterCounts,
    /// Cells that differ between M_{i-1} and M_i.
    pub cells_changed: u64,
    /// Contacts of the robot that began in this world.
    pub collisions: u64,
    /// Simulated time, seconds.
    pub sim_time_s: f64,
    /// Distance driven, metres.
    pub distance_m: f64,
    /// Whether the route was completed.
    pub route_done: bool,
    /// Median updater time per processed scan, microseconds (0 without a clock).
    pub median_scan_us: f64,
    /// The reaction to Lost (episodes, attempts, recoveries, give-ups, time stopped).
    #[serde(default)]
    pub lost: LostCounts,
    /// Structure retention of M_i, M*_i and F_i against the exact G_i, whatever the run's
    /// ground truth (`None` in records written before it was measured; not written then).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub retention: Option<Retention>,
    /// The cells that changed between M_1 and the exact G_i where the route looks, by class,
    /// and the share M_i, M*_i and F_i got right (`None` as for `retention`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub change_classes: Option<ChangeClasses>,
    /// The error of the poses the updater was given, with a pose source other than the chain
    /// localiser (`runner.updater_poses`; absent with the localiser, whose error is
    /// `loc_updated`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub updater_pose_error: Option<GivenPoseStats>,
}

/// Maps and trajectories of a saved world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SavedWorld {
    /// i in W_i.
    pub world: usize,
    /// M_i.
    pub map: OccupancyGrid,
    /// G_i.
    pub ground_truth: OccupancyGrid,
    /// True, chain and baseline trajectories.
    pub trajectories: Option<Trajectories>,
}

/// Everything one seed produced (serialisable for the checkpoints of `validate --resume`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeedRun {
    /// The run seed.
    pub seed: u64,
    /// M_1.
    pub initial_map: OccupancyGrid,
    /// G_1.
    pub initial_ground_truth: OccupancyGrid,
    /// M_1 / G_1.
    pub initial_scores: Scores,
    /// One row per world i = 2 … N.
    pub rows: Vec<WorldRow>,
    /// The edits per world (index 0 = W_1, empty).
    pub edits: Vec<Vec<Edit>>,
    /// Saved worlds, in world order.
    pub saved: Vec<SavedWorld>,
    /// Updater time per processed scan over all worlds, microseconds (empty without a clock).
    pub scan_times_us: Vec<u32>,
}

impl SeedRun {
    /// Whether this run lacks the updater's times it would have had with a clock: the updater
    /// processed steps, and none was timed (a run in which it processed none has nothing to
    /// time either way).
    pub fn lacks_times(&self) -> bool {
        self.scan_times_us.is_empty() && self.rows.iter().any(|r| r.updater.processed > 0)
    }

    /// The run as an untimed run (`--no-timing`) would have it: every time removed (the scan
    /// times and the world rows' medians), nothing else changed. A timed checkpoint resumed
    /// with `--no-timing` then writes what an untimed run writes.
    pub fn drop_timing(&mut self) {
        self.scan_times_us.clear();
        for row in &mut self.rows {
            row.median_scan_us = 0.0;
        }
    }

    /// The machine-readable part of this run (everything but maps and trajectories): what
    /// `runs.json` holds and the summary is computed from.
    pub fn record(&self) -> SeedRecord {
        SeedRecord {
            seed: self.seed,
            initial_scores: self.initial_scores,
            rows: self.rows.clone(),
            edits: self.edits.clone(),
            scan_time_histogram_us: scan_time_histogram(&self.scan_times_us),
        }
    }
}

/// One seed in `runs.json`: the per-world rows at full precision, M_1/G_1, the generator's
/// edits and the updater's time per processed scan as a histogram, from which the summary is
/// recomputed exactly.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeedRecord {
    /// The run seed.
    pub seed: u64,
    /// M_1 / G_1.
    pub initial_scores: Scores,
    /// One row per world i = 2 … N, in world order.
    pub rows: Vec<WorldRow>,
    /// The edits per world (index 0 = W_1, empty).
    pub edits: Vec<Vec<Edit>>,
    /// Updater time per processed scan: `[microseconds, count]` pairs, microseconds strictly
    /// increasing, counts ≥ 1 (empty without a clock).
    pub scan_time_histogram_us: Vec<(u32, u64)>,
}

/// The exact histogram of integer scan times: `(value, count)`, values increasing.
pub fn scan_time_histogram(times_us: &[u32]) -> Vec<(u32, u64)> {
    let mut sorted = times_us.to_vec();
    sorted.sort_unstable();
    let mut h: Vec<(u32, u64)> = Vec::new();
    for t in sorted {
        match h.last_mut() {
            Some((v, c)) if *v == t => *c += 1,
            _ => h.push((t, 1)),
        }
    }
    h
}

/// Merges histograms (each with increasing values) into one.
pub(super) fn merge_histograms<'a>(hs: impl Iterator<Item = &'a [(u32, u64)]>) -> Vec<(u32, u64)> {
    let mut all: Vec<(u32, u64)> = hs.flat_map(|h| h.iter().copied()).collect();
    all.sort_unstable_by_key(|&(v, _)| v);
    let mut out: Vec<(u32, u64)> = Vec::with_capacity(all.len());
    for (v, c) in all {
        match out.last_mut() {
            Some((w, d)) if *w == v => *d += c,
            _ => out.push((v, c)),
        }
    }
    out
}

/// Value of `runs.json`'s `format` field.
pub const RUNS_FORMAT: &str = "mapkeeper-validation-runs";
/// Version of the `runs.json` layout (3: `params.runner.parallel_baseline` left the parameters
/// for [`mapkeeper_closed_loop::RunOptions`], how a run is executed).
pub const RUNS_FORMAT_VERSION: u32 = 3;

/// `runs.json`: the machine-readable record of a validation folder, from which `summary.json`,
/// `worlds.csv`, `edits.json`, `report.md` and the plots are recomputed exactly (what
/// `mapkeeper merge` combines).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationRecord {
    /// Always [`RUNS_FORMAT`].
    pub format: String,
    /// [`RUNS_FORMAT_VERSION`].
    pub format_version: u32,
    /// Producer and version.
    pub tool: String,
    /// Whether the updater was timed (false with `--no-timing`: all times 0).
    pub timing: bool,
    /// Wall time, seconds (the sum over merged folders; 0 when not measured).
    pub wall_time_s: f64,
    /// The shard this folder holds, `None` for a whole run or a merge.
    pub shard: Option<Shard>,
    /// The parameters.
    pub params: ValidationParams,
    /// One record per seed, in seed order.
    pub seeds: Vec<SeedRecord>,
}

impl ValidationRecord {
    /// The record of `runs` (in seed order) made with `params`.
    pub fn new(
        params: &ValidationParams,
        runs: &[SeedRun],
        timing: bool,
        wall_time_s: f64,
        shard: Option<Shard>,
    ) -> Self {
        ValidationRecord {
            format: RUNS_FORMAT.into(),
            format_version: RUNS_FORMAT_VERSION,
            tool: tool_name(),
            timing,
            wall_time_s,
            shard,
            params: params.clone(),
            seeds: runs.iter().map(SeedRun::record).collect(),
        }
    }
}

pub(super) fn tool_name() -> String {
    format!("mapkeeper-scenario {}", env!("CARGO_PKG_VERSION"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::{histogram_median, median};

    #[test]
    fn histogram_median_is_the_median_of_the_values_and_merges_exactly() {
        // A deterministic scramble of small integers with repeats.
        let times: Vec<u32> = (0..101u32).map(|k| (k * 37 + 11) % 23 + 100).collect();
        for n in [0, 1, 2, 3, 10, 51, 100, 101] {
            let v = times[..n].to_vec();
            let h = scan_time_histogram(&v);
            assert!(h.windows(2).all(|w| w[0].0 < w[1].0), "values increase");
            assert_eq!(h.iter().map(|&(_, c)| c).sum::<u64>(), n as u64);
            assert_eq!(
                histogram_median(&h),
                median(v.iter().map(|&t| f64::from(t)).collect()).unwrap_or(0.0),
                "n = {n}"
            );
        }
        let (a, b) = times.split_at(40);
        let merged = merge_histograms([scan_time_histogram(a), scan_time_histogram(b)].iter().map(Vec::as_slice));
        assert_eq!(merged, scan_time_histogram(&times));
        assert_eq!(histogram_median(&[(7, 2), (9, 2)]), 8.0);
    }
}
