//! A pass / fail gate for a team's CI: a validation's results against a stored baseline
//! (`mapkeeper check`, `docs/evaluation.md`, "A gate for CI").
//!
//! [`Baseline::of`] measures a validation folder (one preset, or a sweep's folder of presets)
//! and gives each metric a tolerance from its spread over the seeds; [`Baseline::check`]
//! compares another run of the same setting against it and lists every metric that moved beyond
//! its tolerance in the bad direction (a regression) or the good one (an improvement, which
//! passes). The metrics, per preset, each a mean over the seeds of the per-seed mean over worlds:
//!
//! | metric | what | better |
//! |---|---|---|
//! | `cc_gain`, `ms_gain`, `opdf_gain` | M_i − M_1 against G_i, points | higher |
//! | `cc_better`, `ms_better`, `opdf_better` | share of worlds where M_i beats M_1 | higher |
//! | `retention_last` | structure retention at the last world, % | higher |
//! | `error_updated_m` | the chain localiser's mean position error on M_{i-1}, metres | lower |
//! | `lost_share` | Lost verdicts per processed scan | lower |
//!
//! The tolerance of a metric is `max(floor, t(0.975, n − 1) · s · √(2/n))` over its n per-seed
//! values with standard deviation s: the half-width of the 95 % interval of a difference of two
//! n-seed means, so run-to-run noise on other seeds stays inside it. With one seed, the same
//! from the batch means of its worlds for the metrics that are means over worlds (B = 10 batches
//! of consecutive worlds, `t(0.975, B − 1) · s_B · √(2/B)`: what noise within the one chain
//! moves its mean by; [`crate::stats::batch_means_half_width`]), the floor for the others and
//! for seeds that agree exactly (per metric, in [`floor`]). A run with the same seeds and
//! code is bit-identical, so any move at all is a change of the code; the tolerance says which
//! moves matter. The file is JSON with sorted keys, the same bytes for the same results.

use crate::experiments::validation::merge::load_result_dir;
use crate::experiments::validation::{ValidationRecord, WorldRow};
use crate::results::ResultsError;
use crate::stats::{batch_means_half_width, frac, mean, paired_diff};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The file format name of a baseline.
pub const BASELINE_FORMAT: &str = "mapkeeper-baseline";
/// Its version.
pub const BASELINE_VERSION: u32 = 1;

/// Which way a metric is better.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Better {
    /// Larger values are better.
    Higher,
    /// Smaller values are better.
    Lower,
}

/// One metric of a baseline.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Metric {
    /// Its value (mean over the seeds).
    pub value: f64,
    /// How far a run may move in the bad direction before it is a regression (≥ 0).
    pub tolerance: f64,
    /// Which way is better.
    pub better: Better,
}

/// What a baseline was measured on: a run compares only with the same setting.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Setting {
    /// Worlds per seed.
    pub worlds: usize,
    /// The seeds.
    pub seeds: Vec<u64>,
    /// The ground truth of the metrics (`exact` or `observed`).
    pub ground_truth: String,
}

/// A stored baseline: per preset, per metric, the value and its tolerance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Baseline {
    /// Always [`BASELINE_FORMAT`].
    pub format: String,
    /// [`BASELINE_VERSION`].
    pub version: u32,
    /// The setting it was measured on.
    pub setting: Setting,
    /// Preset → metric name → metric.
    pub presets: BTreeMap<String, BTreeMap<String, Metric>>,
}

/// One metric that moved beyond its tolerance.
#[derive(Clone, Debug, PartialEq)]
pub struct Moved {
    /// The preset.
    pub preset: String,
    /// The metric's name.
    pub metric: String,
    /// The baseline's value.
    pub baseline: f64,
    /// The run's value.
    pub now: f64,
    /// The tolerance.
    pub tolerance: f64,
}

impl std::fmt::Display for Moved {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} {}: {:.4} → {:.4} ({:+.4}, tolerance {:.4})",
            self.preset,
            self.metric,
            self.baseline,
            self.now,
            self.now - self.baseline,
            self.tolerance
        )
    }
}

/// The outcome of [`Baseline::check`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Verdict {
    /// Metrics worse than the baseline by more than their tolerance: the gate fails.
    pub regressions: Vec<Moved>,
    /// Metrics better by more than their tolerance (the gate passes; a new baseline may be due).
    pub improvements: Vec<Moved>,
    /// Metrics checked.
    pub checked: usize,
}

/// The smallest tolerance of a metric: what a change must exceed to matter even when the seeds
/// agree exactly.
pub fn floor(metric: &str) -> f64 {
    match metric {
        "cc_gain" | "ms_gain" | "opdf_gain" => 0.25,
        "cc_better" | "ms_better" | "opdf_better" => 0.02,
        "retention_last" => 0.5,
        "error_updated_m" => 0.005,
        _ => 0.002,
    }
}

/// The metric of per-seed values `xs` (module docs); with one seed, the half-width comes from
/// the batch means of its per-world values `one_seed_series` when the metric is a mean over
/// worlds and there are enough of them.
fn metric(name: &str, xs: &[f64], one_seed_series: Option<&[f64]>, better: Better) -> Metric {
    // The half-width of the mean's 95 % interval, t · s/√n, times √2: that of a difference of two
    // such means.
    let d = paired_diff(xs);
    let half = match (d.ci95, one_seed_series) {
        (Some([lo, hi]), _) => (hi - lo) / 2.0,
        (None, Some(series)) if xs.len() == 1 => batch_means_half_width(series).unwrap_or(0.0),
        _ => 0.0,
    };
    Metric { value: d.mean, tolerance: (half * std::f64::consts::SQRT_2).max(floor(name)), better }
}

/// The metric values of one seed's rows, each with its per-world values when it is their mean
/// (for the one-seed tolerance).
fn seed_values(rows: &[WorldRow]) -> Vec<(&'static str, f64, Better, Option<Vec<f64>>)> {
    let avg = |f: &dyn Fn(&WorldRow) -> f64| (mean(rows.iter().map(f)), Some(rows.iter().map(f).collect()));
    let share = |f: &dyn Fn(&WorldRow) -> bool| {
        (frac(rows.iter().map(f)), Some(rows.iter().map(|r| if f(r) { 1.0 } else { 0.0 }).collect()))
    };
    let processed = rows.iter().map(|r| r.updater.processed).sum::<u64>().max(1) as f64;
    let lost = rows.iter().map(|r| r.updater.lost).sum::<u64>() as f64;
    let retention = rows.last().and_then(|r| r.retention.as_ref()).map_or(f64::NAN, |r| r.updated_map);
    let with = |name, (value, series), better| (name, value, better, series);
    vec![
        with("cc_gain", avg(&|r| r.updated_map.cc - r.static_map.cc), Better::Higher),
        with("ms_gain", avg(&|r| r.updated_map.ms - r.static_map.ms), Better::Higher),
        with("opdf_gain", avg(&|r| r.updated_map.opdf - r.static_map.opdf), Better::Higher),
        with("cc_better", share(&|r| r.updated_map.cc > r.static_map.cc), Better::Higher),
        with("ms_better", share(&|r| r.updated_map.ms > r.static_map.ms), Better::Higher),
        with("opdf_better", share(&|r| r.updated_map.opdf > r.static_map.opdf), Better::Higher),
        ("retention_last", retention, Better::Higher, None),
        with("error_updated_m", avg(&|r| r.loc_updated.mean_error_m), Better::Lower),
        ("lost_share", lost / processed, Better::Lower, None),
    ]
}

/// The metrics of one preset's record (those that are defined: retention needs exact ground
/// truth).
fn preset_metrics(record: &ValidationRecord) -> BTreeMap<String, Metric> {
    let per_seed: Vec<_> = record.seeds.iter().map(|s| seed_values(&s.rows)).collect();
    let mut out = BTreeMap::new();
    for (k, &(name, _, better, _)) in per_seed.first().map(Vec::as_slice).unwrap_or_default().iter().enumerate() {
        let xs: Vec<f64> = per_seed.iter().map(|v| v[k].1).collect();
        let one_seed_series = per_seed.first().and_then(|v| v[k].3.as_deref());
        if xs.iter().all(|x| x.is_finite()) {
            out.insert(name.to_string(), metric(name, &xs, one_seed_series, better));
        }
    }
    out
}

/// The validation records of a results folder: itself (one preset), or each subfolder that
/// holds a `runs.json` (a sweep), by preset name.
fn records(dir: &Path) -> Result<Vec<ValidationRecord>, ResultsError> {
    if dir.join("runs.json").is_file() {
        return Ok(vec![load_result_dir(dir)?]);
    }
    let entries = std::fs::read_dir(dir).map_err(|e| ResultsError::Io { path: dir.to_path_buf(), source: e })?;
    let mut subs: Vec<_> =
        entries.filter_map(Result::ok).map(|e| e.path()).filter(|p| p.join("runs.json").is_file()).collect();
    subs.sort();
    if subs.is_empty() {
        return Err(ResultsError::Invalid(format!(
            "{}: neither a validation's output folder (runs.json) nor a sweep's (PRESET/runs.json)",
            dir.display()
        )));
    }
    subs.iter().map(|p| load_result_dir(p)).collect()
}

impl Baseline {
    /// Measures the validation folder `dir` (module docs).
    pub fn of(dir: &Path) -> Result<Baseline, ResultsError> {
        let recs = records(dir)?;
        let setting = |r: &ValidationRecord| Setting {
            worlds: r.params.worlds,
            seeds: r.seeds.iter().map(|s| s.seed).collect(),
            ground_truth: serde_json::to_value(r.params.ground_truth)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default(),
        };
        let first = setting(&recs[0]);
        if let Some(other) = recs.iter().find(|r| setting(r) != first) {
            return Err(ResultsError::Invalid(format!(
                "{}: the presets were run in different settings ({} has {:?}, {} has {first:?})",
                dir.display(),
                other.params.preset,
                setting(other),
                recs[0].params.preset
            )));
        }
        let presets = recs.iter().map(|r| (r.params.preset.clone(), preset_metrics(r))).collect();
        Ok(Baseline { format: BASELINE_FORMAT.into(), version: BASELINE_VERSION, setting: first, presets })
    }

    /// Reads a baseline file; errors name the file and the problem.
    pub fn load(path: &Path) -> Result<Baseline, ResultsError> {
        let text =
            std::fs::read_to_string(path).map_err(|e| ResultsError::Io { path: path.to_path_buf(), source: e })?;
        let b: Baseline = serde_json::from_str(&text)
            .map_err(|e| ResultsError::Invalid(format!("{}: not a baseline file: {e}", path.display())))?;
        if b.format != BASELINE_FORMAT || b.version != BASELINE_VERSION {
            return Err(ResultsError::Invalid(format!(
                "{}: format '{}' version {}, this build reads '{BASELINE_FORMAT}' version {BASELINE_VERSION}",
                path.display(),
                b.format,
                b.version
            )));
        }
        if let Some((p, m, _)) = b.metrics().find(|(_, _, m)| !(m.value.is_finite() && m.tolerance >= 0.0)) {
            return Err(ResultsError::Invalid(format!(
                "{}: presets.{p}.{m}: value and tolerance must be finite, the tolerance ≥ 0",
                path.display()
            )));
        }
        Ok(b)
    }

    /// The JSON text (sorted keys, one field a line; the same bytes for the same baseline).
    pub fn to_json(&self) -> Result<String, ResultsError> {
        let value = serde_json::to_value(self)
            .map_err(|e| ResultsError::Serialise { what: "baseline".into(), message: e.to_string() })?;
        let text = serde_json::to_string_pretty(&value)
            .map_err(|e| ResultsError::Serialise { what: "baseline".into(), message: e.to_string() })?;
        Ok(text + "\n")
    }

    fn metrics(&self) -> impl Iterator<Item = (&String, &String, &Metric)> {
        self.presets.iter().flat_map(|(p, ms)| ms.iter().map(move |(name, m)| (p, name, m)))
    }

    /// Compares `run` (measured by [`Baseline::of`]) with this baseline. An error when the
    /// settings differ or a preset or metric of the baseline is missing from the run.
    pub fn check(&self, run: &Baseline) -> Result<Verdict, String> {
        if run.setting != self.setting {
            return Err(format!(
                "the results were run in another setting than the baseline's: {:?} against {:?} (run the baseline's \
                 setting, or write a new baseline with --write-baseline)",
                run.setting, self.setting
            ));
        }
        let mut v = Verdict::default();
        for (preset, name, base) in self.metrics() {
            let now = run
                .presets
                .get(preset)
                .ok_or_else(|| format!("preset {preset} of the baseline is not in the results"))?
                .get(name)
                .ok_or_else(|| format!("{preset} {name}: in the baseline, not in the results"))?;
            let worse = match base.better {
                Better::Higher => base.value - now.value,
                Better::Lower => now.value - base.value,
            };
            let moved = Moved {
                preset: preset.clone(),
                metric: name.clone(),
                baseline: base.value,
                now: now.value,
                tolerance: base.tolerance,
            };
            if worse > base.tolerance {
                v.regressions.push(moved);
            } else if -worse > base.tolerance {
                v.improvements.push(moved);
            }
            v.checked += 1;
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tolerance_is_the_spread_of_a_difference_of_means_or_the_floor() {
        // Four seeds: t(0.975, 3) · s · √(2/4), t = 3.1824.
        let xs = [9.0, 10.0, 11.0, 10.0];
        let s = (xs.iter().map(|x| (x - 10.0f64).powi(2)).sum::<f64>() / 3.0).sqrt();
        let m = metric("cc_gain", &xs, None, Better::Higher);
        assert!((m.value - 10.0).abs() < 1e-12);
        assert!((m.tolerance - 3.1824 * s * 0.5f64.sqrt()).abs() < 1e-9, "{m:?}");
        assert_eq!(metric("cc_gain", &[3.0, 3.0, 3.0], None, Better::Higher).tolerance, 0.25);
        assert_eq!(metric("lost_share", &[0.1], None, Better::Lower).tolerance, 0.002);
        // Several seeds: the per-world values play no part.
        assert_eq!(metric("cc_gain", &xs, Some(&[0.0, 100.0]), Better::Higher), m);
    }

    #[test]
    fn one_seed_takes_its_tolerance_from_the_batch_means_of_its_worlds() {
        // 40 worlds, batch means 0, 2, 4, …, 18 (s_B² = 4 · 55/6): t(0.975, 9) · s_B · √(2/10).
        let series: Vec<f64> = (0..40).map(|i| f64::from(2 * (i / 4))).collect();
        let value = mean(series.iter().copied());
        let m = metric("cc_gain", &[value], Some(&series), Better::Higher);
        let want = 2.2622 * (4.0 * 55.0 / 6.0f64).sqrt() * 0.2f64.sqrt();
        assert!((m.tolerance - want).abs() < 1e-9, "{m:?} vs {want}");
        assert_eq!(m.value, value);
        // A quiet chain, or too few worlds for batches: the floor.
        assert_eq!(metric("cc_gain", &[1.0], Some(&[1.0; 40]), Better::Higher).tolerance, 0.25);
        assert_eq!(metric("cc_gain", &[value], Some(&series[..19]), Better::Higher).tolerance, 0.25);
    }

    fn baseline(cc: f64, err: f64) -> Baseline {
        let m = |value, tolerance, better| Metric { value, tolerance, better };
        let metrics = BTreeMap::from([
            ("cc_gain".to_string(), m(cc, 0.5, Better::Higher)),
            ("error_updated_m".to_string(), m(err, 0.01, Better::Lower)),
        ]);
        Baseline {
            format: BASELINE_FORMAT.into(),
            version: BASELINE_VERSION,
            setting: Setting { worlds: 10, seeds: vec![11, 12], ground_truth: "exact".into() },
            presets: BTreeMap::from([("mapkeeper".to_string(), metrics)]),
        }
    }

    #[test]
    fn a_move_beyond_the_tolerance_in_the_bad_direction_fails_and_in_the_good_one_passes() {
        let base = baseline(10.0, 0.05);
        assert_eq!(base.check(&base).unwrap(), Verdict { checked: 2, ..Verdict::default() });
        // Within tolerance either way.
        assert!(base.check(&baseline(9.6, 0.059)).unwrap().regressions.is_empty());
        // CC gain down by 0.6 > 0.5; the error up by 0.02 > 0.01 (lower is better).
        let v = base.check(&baseline(9.4, 0.07)).unwrap();
        let names: Vec<_> = v.regressions.iter().map(|m| m.metric.as_str()).collect();
        assert_eq!(names, ["cc_gain", "error_updated_m"]);
        assert!(
            v.regressions[0].to_string().starts_with("mapkeeper cc_gain: 10.0000 → 9.4000 (-0.6000"),
            "{}",
            v.regressions[0]
        );
        // Better beyond the tolerance: passes, reported as an improvement.
        let v = base.check(&baseline(11.0, 0.03)).unwrap();
        assert!(v.regressions.is_empty() && v.improvements.len() == 2);
        // Another setting is refused.
        let mut other = baseline(10.0, 0.05);
        other.setting.seeds = vec![11];
        assert!(base.check(&other).unwrap_err().contains("another setting"));
        // The JSON is stable and reads back.
        let text = base.to_json().unwrap();
        assert_eq!(serde_json::from_str::<Baseline>(&text).unwrap(), base);
        assert_eq!(text, baseline(10.0, 0.05).to_json().unwrap());
    }
}
