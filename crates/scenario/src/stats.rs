//! Small statistics over a run's or a sweep's values, written once: means, fractions, medians,
//! percentiles (and the median of a histogram, for timings merged across shards).

/// `mean [lo, hi]` with `digits` decimals, or `mean (no interval)` without one.
pub fn with_ci(mean: f64, ci: Option<[f64; 2]>, digits: usize) -> String {
    match ci {
        Some([lo, hi]) => format!("{mean:+.digits$} [{lo:+.digits$}, {hi:+.digits$}]"),
        None => format!("{mean:+.digits$} (no interval)"),
    }
}

/// The mean, 0 for no values.
pub fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { 0.0 } else { s / n as f64 }
}

/// The fraction of `true`, 0 for no values.
pub fn frac(v: impl Iterator<Item = bool>) -> f64 {
    let (t, n) = v.fold((0usize, 0usize), |(t, n), b| (t + usize::from(b), n + 1));
    if n == 0 { 0.0 } else { t as f64 / n as f64 }
}

/// The median (the mean of the two middle values for an even count), `None` for no values.
/// NaNs sort last (total order).
pub fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 { v[n / 2] } else { (v[n / 2 - 1] + v[n / 2]) / 2.0 })
}

/// The `q`-quantile by the nearest-rank method (the smallest value with at least a share `q`
/// of the values at or below it), `None` for no values.
pub fn percentile(mut v: Vec<f64>, q: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let k = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    Some(v[k])
}

/// The median of the values a histogram counts (the mean of the two middle ones for an even
/// count), 0 for an empty histogram: the same as the median of the values themselves.
pub fn histogram_median(h: &[(u32, u64)]) -> f64 {
    let n: u64 = h.iter().map(|&(_, c)| c).sum();
    if n == 0 {
        return 0.0;
    }
    // The value at 0-based rank k.
    let at = |k: u64| {
        let mut seen = 0u64;
        for &(v, c) in h {
            seen += c;
            if k < seen {
                return f64::from(v);
            }
        }
        0.0
    };
    if n % 2 == 1 { at(n / 2) } else { (at(n / 2 - 1) + at(n / 2)) / 2.0 }
}

/// The 97.5 % quantile of Student's t distribution with `df` degrees of freedom (the factor of a
/// two-sided 95 % interval): tabulated for 1-30 (to 4 decimals), the Cornish-Fisher expansion
/// to the third order beyond (error below 1e-4 at 30 and falling); the normal 1.959964 for
/// `df` = ∞. `None` for 0.
pub fn t_quantile_975(df: usize) -> Option<f64> {
    const TABLE: [f64; 30] = [
        12.7062, 4.3027, 3.1824, 2.7764, 2.5706, 2.4469, 2.3646, 2.3060, 2.2622, 2.2281, 2.2010, 2.1788, 2.1604,
        2.1448, 2.1314, 2.1199, 2.1098, 2.1009, 2.0930, 2.0860, 2.0796, 2.0739, 2.0687, 2.0639, 2.0595, 2.0555, 2.0518,
        2.0484, 2.0452, 2.0423,
    ];
    match df {
        0 => None,
        1..=30 => Some(TABLE[df - 1]),
        _ => {
            let (z, v) = (1.959_963_984_540_054_f64, df as f64);
            let (z3, z5, z7) = (z.powi(3), z.powi(5), z.powi(7));
            Some(
                z + (z3 + z) / (4.0 * v)
                    + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * v * v)
                    + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * v * v * v),
            )
        }
    }
}

/// A mean difference over paired units (seeds) with its 95 % interval.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct PairedDiff {
    /// Mean of the units' differences (0 for no unit).
    pub mean: f64,
    /// Two-sided 95 % Student-t interval of the mean, `[lo, hi]`; `None` with fewer than two
    /// units (no spread to estimate).
    pub ci95: Option<[f64; 2]>,
    /// Number of units.
    pub n: usize,
}

/// The mean of `diffs` (one difference per unit, e.g. per seed: updated − static) and its paired
/// 95 % interval, mean ± t(0.975, n−1) · s/√n with s the sample standard deviation. The units
/// are assumed independent: seeds are; the worlds of one seed are not (each map comes from the
/// previous one), which is why callers average within a seed first.
pub fn paired_diff(diffs: &[f64]) -> PairedDiff {
    let n = diffs.len();
    let m = mean(diffs.iter().copied());
    let ci95 = t_quantile_975(n.saturating_sub(1)).map(|t| {
        let var = diffs.iter().map(|d| (d - m) * (d - m)).sum::<f64>() / (n - 1) as f64;
        let half = t * (var / n as f64).sqrt();
        [m - half, m + half]
    });
    PairedDiff { mean: m, ci95, n }
}

/// What the units of a validation's 95 % intervals are.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntervalUnits {
    /// The seeds: each seed's chain of worlds is one unit (two seeds or more; also the value
    /// when there is no interval at all).
    #[default]
    Seeds,
    /// Batches of consecutive worlds of the one seed ([`WORLD_BATCHES`] of them): how precisely
    /// this chain's worlds pin its mean, not how much another chain's mean would differ.
    WorldBatches,
}

/// How many batches of consecutive worlds make one seed's interval (batch means: 9 degrees of
/// freedom).
pub const WORLD_BATCHES: usize = 10;

/// The fewest worlds in a batch: one seed needs at least `WORLD_BATCHES × MIN_WORLDS_PER_BATCH`
/// world rows for an interval.
pub const MIN_WORLDS_PER_BATCH: usize = 2;

/// The half-width of the 95 % batch-means interval of the mean of `series`, values in order
/// that depend on the ones before them (the worlds of one seed: each map is made from the
/// previous one). The series is cut into [`WORLD_BATCHES`] runs of consecutive values (sizes
/// differing by one at most), and the half-width is t(0.975, B−1) · s_B/√B with s_B the
/// standard deviation of their means, taken as independent. They are only less dependent than
/// single worlds (neighbouring batch means of the validation correlate at about 0.3-0.4:
/// `docs/evaluation.md`, "Intervals"), which narrows the interval; a trend over the series (the
/// gain growing with the worlds) widens it. `None` below `WORLD_BATCHES × MIN_WORLDS_PER_BATCH` values or
/// with a value that is not finite.
pub fn batch_means_half_width(series: &[f64]) -> Option<f64> {
    let (n, b) = (series.len(), WORLD_BATCHES);
    if n < b * MIN_WORLDS_PER_BATCH || !series.iter().all(|x| x.is_finite()) {
        return None;
    }
    let means: Vec<f64> = (0..b).map(|k| mean(series[k * n / b..(k + 1) * n / b].iter().copied())).collect();
    let m = mean(means.iter().copied());
    let var = means.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (b - 1) as f64;
    Some(t_quantile_975(b - 1)? * (var / b as f64).sqrt())
}

/// The units of a chain's intervals from how many per-world values each seed has
/// (`values_per_seed`, the seeds with worlds): batches of the worlds of a single seed of at least
/// `WORLD_BATCHES × MIN_WORLDS_PER_BATCH` values, the seeds otherwise. The one rule behind
/// [`chain_diff`], the validation summary's `interval_units` and the presets' comparison.
pub fn chain_units(values_per_seed: &[usize]) -> IntervalUnits {
    match values_per_seed {
        [n] if *n >= WORLD_BATCHES * MIN_WORLDS_PER_BATCH => IntervalUnits::WorldBatches,
        _ => IntervalUnits::Seeds,
    }
}

/// The mean over seeds of each seed's mean of its per-world values (`per_seed`, one series per
/// seed with worlds, in world order), with its 95 % interval and the interval's units
/// ([`chain_units`]): with two seeds or more, [`paired_diff`] over the seeds' means; with one,
/// [`batch_means_half_width`] of its worlds around the same mean (no interval if a value is not
/// finite).
pub fn chain_diff(per_seed: &[Vec<f64>]) -> (PairedDiff, IntervalUnits) {
    let means: Vec<f64> = per_seed.iter().map(|v| mean(v.iter().copied())).collect();
    let d = paired_diff(&means);
    let units = chain_units(&per_seed.iter().map(Vec::len).collect::<Vec<_>>());
    match (units, per_seed) {
        (IntervalUnits::WorldBatches, [one]) => {
            let ci95 = batch_means_half_width(one).map(|h| [d.mean - h, d.mean + h]);
            (PairedDiff { ci95, ..d }, units)
        }
        _ => (d, units),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn means_fractions_medians_and_percentiles() {
        assert_eq!(mean([1.0, 2.0, 6.0].into_iter()), 3.0);
        assert_eq!(mean(std::iter::empty()), 0.0);
        assert_eq!(frac([true, false, true, true].into_iter()), 0.75);
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), Some(2.5));
        assert_eq!(median(Vec::new()), None);
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        assert_eq!(percentile(v.clone(), 0.9), Some(9.0));
        assert_eq!(percentile(v.clone(), 0.0), Some(1.0));
        assert_eq!(percentile(v, 1.0), Some(10.0));
    }

    #[test]
    fn histogram_median_is_the_median_of_the_values() {
        for n in 0..12u32 {
            let v: Vec<u32> = (0..n).map(|i| (i * 7919) % 13).collect();
            let mut h: Vec<(u32, u64)> = Vec::new();
            let mut sorted = v.clone();
            sorted.sort_unstable();
            for x in sorted {
                match h.last_mut() {
                    Some((y, c)) if *y == x => *c += 1,
                    _ => h.push((x, 1)),
                }
            }
            let want = median(v.iter().map(|&x| f64::from(x)).collect()).unwrap_or(0.0);
            assert_eq!(histogram_median(&h), want, "n = {n}");
        }
        assert_eq!(histogram_median(&[(7, 2), (9, 2)]), 8.0);
    }

    #[test]
    fn t_quantiles_and_paired_intervals() {
        assert_eq!(t_quantile_975(0), None);
        assert_eq!(t_quantile_975(1), Some(12.7062));
        // The expansion meets the table at 30 and the known values beyond (R: qt(0.975, df)).
        let cf30 = {
            let (z, v) = (1.959_963_984_540_054_f64, 30.0);
            z + (z.powi(3) + z) / (4.0 * v)
                + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * v * v)
                + (3.0 * z.powi(7) + 19.0 * z.powi(5) + 17.0 * z.powi(3) - 15.0 * z) / (384.0 * v * v * v)
        };
        assert!((cf30 - 2.0423).abs() < 1e-4, "{cf30}");
        for (df, want) in [(31, 2.0395), (40, 2.0211), (60, 2.0003), (120, 1.9799), (1000, 1.9623)] {
            let got = t_quantile_975(df).unwrap();
            assert!((got - want).abs() < 1e-4, "df {df}: {got} vs {want}");
        }
        let d = paired_diff(&[1.0, 2.0, 3.0]);
        assert_eq!(d.mean, 2.0);
        // s = 1, half-width t(2) / √3.
        let half = 4.3027 / 3f64.sqrt();
        let [lo, hi] = d.ci95.unwrap();
        assert!((lo - (2.0 - half)).abs() < 1e-12 && (hi - (2.0 + half)).abs() < 1e-12);
        assert_eq!(paired_diff(&[5.0]), PairedDiff { mean: 5.0, ci95: None, n: 1 });
        assert_eq!(paired_diff(&[]).ci95, None);
        assert_eq!(paired_diff(&[0.5, 0.5]).ci95, Some([0.5, 0.5]), "no spread, no width");
    }

    #[test]
    fn one_seed_gets_a_batch_means_interval_and_several_seeds_the_paired_one() {
        // 20 values in 10 batches of 2: the batch means are 0, 1, …, 9 (s² = 55/6).
        let series: Vec<f64> = (0..20).map(|i| f64::from(i / 2) + if i % 2 == 0 { -0.5 } else { 0.5 }).collect();
        let half = batch_means_half_width(&series).unwrap();
        let want = 2.2622 * (55.0 / 6.0 / 10.0f64).sqrt();
        assert!((half - want).abs() < 1e-12, "{half} vs {want}");
        // Batches of unequal size (99 worlds: 9 and 10), and a constant series has no width.
        assert_eq!(batch_means_half_width(&[3.0; 99]), Some(0.0));
        // Too short, or not finite: no interval.
        assert_eq!(batch_means_half_width(&series[..19]), None);
        let mut bad = series.clone();
        bad[7] = f64::NAN;
        assert_eq!(batch_means_half_width(&bad), None);

        let (d, units) = chain_diff(std::slice::from_ref(&series));
        assert_eq!(units, IntervalUnits::WorldBatches);
        assert_eq!(d.mean, mean(series.iter().copied()));
        assert_eq!(d.n, 1);
        let [lo, hi] = d.ci95.unwrap();
        assert!((hi - lo - 2.0 * half).abs() < 1e-12 && ((lo + hi) / 2.0 - d.mean).abs() < 1e-12);
        // A value that is not finite: the units stay batches, with no interval.
        let (d, units) = chain_diff(std::slice::from_ref(&bad));
        assert_eq!((d.ci95, units), (None, IntervalUnits::WorldBatches));
        assert_eq!(
            (chain_units(&[20]), chain_units(&[19]), chain_units(&[50, 50])),
            (IntervalUnits::WorldBatches, IntervalUnits::Seeds, IntervalUnits::Seeds)
        );
        // Too few worlds for batches: no interval, as before.
        let (d, units) = chain_diff(&[series[..10].to_vec()]);
        assert_eq!((d.ci95, units), (None, IntervalUnits::Seeds));
        // Two seeds or more: the seeds are the units, each seed's mean one value, bit for bit
        // the paired interval of those means.
        let two = [series.clone(), series.iter().map(|x| x + 1.0).collect::<Vec<_>>()];
        let (d, units) = chain_diff(&two);
        assert_eq!(units, IntervalUnits::Seeds);
        assert_eq!(d, paired_diff(&[mean(two[0].iter().copied()), mean(two[1].iter().copied())]));
    }
}
