//! The chains of one log over the edit seeds, per preset and pose source ([`ChainSummary`]):
//! means, paired intervals over the edit seeds (each seed's stale map is one unit), and the
//! issue's targets as verdicts ([`Verdicts`]).

use super::chain::{ChainResult, MapScores, PoseSourceConfig};
use crate::stats::{PairedDiff, mean, paired_diff};
use serde::Serialize;

/// Smallest share of the structure kept for the retention target, percent.
pub const TARGET_RETENTION: f64 = 99.0;
/// Smallest share of every edit class's observed cells restored by pass K, percent.
pub const TARGET_RESTORED: f64 = 80.0;
/// Smallest share of the same chain's gain at the reference poses that the localiser's poses
/// must reach.
pub const TARGET_GAIN_RATIO: f64 = 0.9;

/// One value per metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct PerMetric<T> {
    /// Cross-correlation.
    pub cc: T,
    /// Map score.
    pub ms: T,
    /// OPDF.
    pub opdf: T,
}

impl<T> PerMetric<T> {
    fn from_fn(f: impl Fn(fn(&MapScores) -> f64) -> T) -> Self {
        Self { cc: f(|s| s.cc), ms: f(|s| s.ms), opdf: f(|s| s.opdf) }
    }

    /// The three values, in the order CC, MS, OPDF.
    pub fn all(&self) -> [&T; 3] {
        [&self.cc, &self.ms, &self.opdf]
    }
}

/// Mean share of each class restored at pass K, percent (`None`: no seed had cells of it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RestoredMean {
    /// Structure M_1 lacked.
    pub added: Option<f64>,
    /// Boxes M_1 had and the place lacks.
    pub removed: Option<f64>,
    /// Both places of moved items.
    pub moved: Option<f64>,
}

/// The targets for this row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Verdicts {
    /// Pass K better than M_1 on CC, MS and OPDF, every interval above 0.
    pub better_than_m1: bool,
    /// The gain over M_1 at least [`TARGET_GAIN_RATIO`] of the reference poses' on every metric
    /// (`None` for the reference poses themselves, or without them).
    pub gain_as_reference: Option<bool>,
    /// Pass K at least as good as pass 3 on every metric in every seed.
    pub no_decay: bool,
    /// Retention at least [`TARGET_RETENTION`] in every seed.
    pub retention: bool,
    /// Every class at least [`TARGET_RESTORED`] restored (mean over seeds).
    pub restored: bool,
}

/// One log's chains of one preset and pose source, over the edit seeds.
#[derive(Clone, Debug, Serialize)]
pub struct ChainSummary {
    /// The preset.
    pub preset: String,
    /// The pose source.
    pub poses: String,
    /// Edit seeds (units of the intervals).
    pub seeds: usize,
    /// Mean of M_1's scores.
    pub m1: PerMetric<f64>,
    /// Mean of pass 2's.
    pub pass2: PerMetric<f64>,
    /// Mean of pass K's.
    pub last: PerMetric<f64>,
    /// Mean of pass K's fresh map F_K.
    pub fresh: PerMetric<f64>,
    /// Pass K − M_1, paired over seeds.
    pub gain: PerMetric<PairedDiff>,
    /// Pass K − pass 3, paired over seeds.
    pub since_pass3: PerMetric<PairedDiff>,
    /// Pass K − F_K, paired over seeds.
    pub over_fresh: PerMetric<PairedDiff>,
    /// The mean gain over the mean gain of the same preset at the reference poses (`None` for
    /// the reference poses, or without them).
    pub gain_ratio: Option<PerMetric<f64>>,
    /// Seeds in which pass K is worse than pass 3 on some metric.
    pub decayed_seeds: usize,
    /// Mean retention at pass K, percent.
    pub retention: f64,
    /// Lowest retention at pass K over the seeds, percent.
    pub retention_min: f64,
    /// Mean share of each class restored at pass K.
    pub restored: RestoredMean,
    /// Mean over passes and seeds of the poses' RMSE against the reference, metres (`None` for
    /// the reference poses).
    pub pose_rmse_m: Option<f64>,
    /// Largest pose error over passes and seeds, metres.
    pub pose_max_m: Option<f64>,
    /// Lost episodes over all passes and seeds.
    pub lost_episodes: u64,
    /// The targets.
    pub verdicts: Verdicts,
}

/// The summaries of `chains` (one log's), one per preset and pose source that ran, in the order
/// of `presets` and `sources`.
pub fn summarise(chains: &[ChainResult], presets: &[String], sources: &[PoseSourceConfig]) -> Vec<ChainSummary> {
    let mut out = Vec::new();
    for preset in presets {
        let reference: Vec<&ChainResult> =
            chains.iter().filter(|c| &c.preset == preset && c.poses == PoseSourceConfig::Reference.name()).collect();
        for source in sources {
            let rows: Vec<&ChainResult> =
                chains.iter().filter(|c| &c.preset == preset && c.poses == source.name()).collect();
            if rows.is_empty() {
                continue;
            }
            let is_reference = *source == PoseSourceConfig::Reference;
            out.push(summarise_rows(preset, source.name(), &rows, (!is_reference).then_some(reference.as_slice())));
        }
    }
    out
}

fn pass_scores(c: &ChainResult, k: usize) -> MapScores {
    c.per_pass.iter().find(|p| p.pass == k).map_or(c.m1, |p| p.scores)
}

fn summarise_rows(
    preset: &str,
    poses: &str,
    rows: &[&ChainResult],
    reference: Option<&[&ChainResult]>,
) -> ChainSummary {
    let means = |f: &dyn Fn(&ChainResult) -> MapScores| PerMetric::from_fn(|m| mean(rows.iter().map(|c| m(&f(c)))));
    let diffs = |a: &dyn Fn(&ChainResult) -> MapScores, b: &dyn Fn(&ChainResult) -> MapScores| {
        PerMetric::from_fn(|m| paired_diff(&rows.iter().map(|c| m(&a(c)) - m(&b(c))).collect::<Vec<_>>()))
    };
    let last = |c: &ChainResult| c.last;
    let fresh = |c: &ChainResult| c.per_pass.last().map_or(c.m1, |p| p.fresh);
    let gain = diffs(&last, &|c: &ChainResult| c.m1);
    let since_pass3 = diffs(&last, &|c: &ChainResult| pass_scores(c, 3));
    let gain_ratio = reference.filter(|r| !r.is_empty()).map(|r| {
        PerMetric::from_fn(|m| {
            let g = mean(rows.iter().map(|c| m(&c.last) - m(&c.m1)));
            let gr = mean(r.iter().map(|c| m(&c.last) - m(&c.m1)));
            if gr.abs() < 1e-12 { f64::NAN } else { g / gr }
        })
    });
    let decayed_seeds = rows
        .iter()
        .filter(|c| {
            let (k, p3) = (c.last, pass_scores(c, 3));
            k.cc < p3.cc || k.ms < p3.ms || k.opdf < p3.opdf
        })
        .count();
    let retentions: Vec<f64> = rows.iter().map(|c| c.per_pass.last().map_or(100.0, |p| p.retention)).collect();
    let class_mean = |f: &dyn Fn(&ChainResult) -> Option<f64>| {
        let v: Vec<f64> = rows.iter().filter_map(|c| f(c)).collect();
        (!v.is_empty()).then(|| mean(v.into_iter()))
    };
    let restored = RestoredMean {
        added: class_mean(&|c| c.per_pass.last().and_then(|p| p.restored.added)),
        removed: class_mean(&|c| c.per_pass.last().and_then(|p| p.restored.removed)),
        moved: class_mean(&|c| c.per_pass.last().and_then(|p| p.restored.moved)),
    };
    let errors: Vec<(f64, f64)> = rows
        .iter()
        .flat_map(|c| c.per_pass.iter().filter_map(|p| p.pose_error.as_ref().map(|e| (e.rmse_m, e.max_m))))
        .collect();
    let retention_min = retentions.iter().copied().fold(f64::INFINITY, f64::min);
    let above_zero = |d: &PairedDiff| d.ci95.map_or(d.mean > 0.0, |[lo, _]| lo > 0.0);
    let verdicts = Verdicts {
        better_than_m1: gain.all().iter().all(|d| above_zero(d)),
        gain_as_reference: gain_ratio.map(|r| r.all().iter().all(|&&x| x >= TARGET_GAIN_RATIO)),
        no_decay: decayed_seeds == 0,
        retention: retention_min >= TARGET_RETENTION,
        restored: [restored.added, restored.removed, restored.moved]
            .iter()
            .all(|s| s.is_none_or(|v| v >= TARGET_RESTORED)),
    };
    ChainSummary {
        preset: preset.to_string(),
        poses: poses.to_string(),
        seeds: rows.len(),
        m1: means(&|c| c.m1),
        pass2: means(&|c| pass_scores(c, 2)),
        last: means(&last),
        fresh: means(&fresh),
        gain,
        since_pass3,
        over_fresh: diffs(&last, &fresh),
        gain_ratio,
        decayed_seeds,
        retention: mean(retentions.iter().copied()),
        retention_min: if retentions.is_empty() { 100.0 } else { retention_min },
        restored,
        pose_rmse_m: (!errors.is_empty()).then(|| mean(errors.iter().map(|e| e.0))),
        pose_max_m: (!errors.is_empty()).then(|| errors.iter().map(|e| e.1).fold(0.0, f64::max)),
        lost_episodes: rows.iter().flat_map(|c| c.per_pass.iter().map(|p| p.lost_episodes)).sum(),
        verdicts,
    }
}

#[cfg(test)]
mod tests;
