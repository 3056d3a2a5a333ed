//! Small statistics over a run's or a sweep's values, written once: means, fractions, medians,
//! percentiles (and the median of a histogram, for timings merged across shards).

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
}
