//! O(N) low-variance (systematic) resampling (Thrun et al. table 4.4; Kitagawa 1996).

/// Draws `n` indices from the normalised `weights` with one uniform offset `u0 ∈ [0, 1)`: the
/// pointers `(u0 + j) / n`, `j = 0..n`, are matched against the cumulative weights in one pass,
/// so the cost is O(len + n) and particle `i` is copied `⌊n·wᵢ⌋` or `⌈n·wᵢ⌉` times. Indices are
/// written to `out` (cleared first) in increasing order.
///
/// Weights must be finite, non-negative and sum to (about) 1; rounding in the running sum is
/// absorbed by the last particle with non-zero weight.
///
/// ```
/// use mapkeeper_localiser::systematic_resample;
/// let mut out = Vec::new();
/// systematic_resample(&[0.5, 0.25, 0.0, 0.25], 4, 0.3, &mut out);
/// assert_eq!(out, vec![0, 0, 1, 3]);
/// ```
pub fn systematic_resample(weights: &[f64], n: usize, u0: f64, out: &mut Vec<usize>) {
    out.clear();
    let Some(last_nonzero) = weights.iter().rposition(|&w| w > 0.0) else {
        return;
    };
    let step = 1.0 / n as f64;
    let mut pointer = u0.clamp(0.0, 1.0) * step;
    let mut i = 0usize;
    let mut cumulative = weights[0];
    for _ in 0..n {
        while pointer > cumulative && i < last_nonzero {
            i += 1;
            cumulative += weights[i];
        }
        out.push(i);
        pointer += step;
    }
}

/// One multinomial draw from the cumulative weights `cumulative` (`cumulative[i]` = sum of the
/// weights `0..=i`, non-decreasing, last entry the total) with a uniform `u ∈ [0, 1)`: the first
/// index whose cumulative weight exceeds `u · total`, found by binary search (O(log M)); a
/// zero-weight particle is never drawn. This is the draw of AMCL's `pf_update_resample`, which
/// scans the table linearly.
///
/// ```
/// use mapkeeper_localiser::multinomial_draw;
/// let c = [0.5, 0.75, 0.75, 1.0];
/// assert_eq!(multinomial_draw(&c, 0.0), 0);
/// assert_eq!(multinomial_draw(&c, 0.6), 1);
/// assert_eq!(multinomial_draw(&c, 0.75), 3);
/// ```
pub fn multinomial_draw(cumulative: &[f64], u: f64) -> usize {
    let total = cumulative.last().copied().unwrap_or(0.0);
    let target = u.clamp(0.0, 1.0) * total;
    cumulative.partition_point(|&c| c <= target).min(cumulative.len().saturating_sub(1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::ChaCha8Rng;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn copies_are_floor_or_ceil_of_expected() {
        let w = [0.05, 0.3, 0.0, 0.15, 0.42, 0.08];
        let n = 37;
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut out = Vec::new();
        for _ in 0..1000 {
            systematic_resample(&w, n, rng.random::<f64>(), &mut out);
            assert_eq!(out.len(), n);
            assert!(out.windows(2).all(|p| p[0] <= p[1]));
            for (i, &wi) in w.iter().enumerate() {
                let c = out.iter().filter(|&&k| k == i).count() as f64;
                let e = wi * n as f64;
                assert!(c >= e.floor() - 1e-9 && c <= e.ceil() + 1e-9, "particle {i}: {c} copies, expected {e}");
            }
        }
    }

    /// Unbiasedness: over many draws with a fixed seed, the mean number of copies of each
    /// particle is n·wᵢ (within 5 standard errors; systematic counts vary by at most one).
    #[test]
    fn resampler_is_unbiased() {
        let w = [0.013, 0.2, 0.087, 0.35, 0.0, 0.25, 0.1];
        let n = 10;
        let trials = 20_000;
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let mut counts = [0.0f64; 7];
        let mut out = Vec::new();
        for _ in 0..trials {
            systematic_resample(&w, n, rng.random::<f64>(), &mut out);
            for &k in &out {
                counts[k] += 1.0;
            }
        }
        for (i, &wi) in w.iter().enumerate() {
            let e = wi * n as f64;
            let mean = counts[i] / trials as f64;
            // Copies ∈ {⌊e⌋, ⌈e⌉}: variance f(1−f) with f the fractional part of e.
            let f = e - e.floor();
            let se = (f * (1.0 - f) / trials as f64).sqrt();
            assert!((mean - e).abs() <= 5.0 * se + 1e-9, "particle {i}: mean {mean} vs {e}");
        }
    }

    #[test]
    fn degenerate_inputs_do_not_panic() {
        let mut out = vec![9];
        systematic_resample(&[0.0, 0.0], 5, 0.5, &mut out);
        assert!(out.is_empty());
        systematic_resample(&[], 5, 0.5, &mut out);
        assert!(out.is_empty());
        // A sum slightly below 1 never walks past the last particle with weight.
        systematic_resample(&[0.3, 0.3, 0.3999999, 0.0], 3, 0.9999999, &mut out);
        assert_eq!(out, vec![1, 2, 2]);
    }

    #[test]
    fn multinomial_draws_follow_the_weights_and_skip_zero_weights() {
        let w = [0.1, 0.0, 0.6, 0.3];
        let mut c = Vec::new();
        let mut run = 0.0;
        for x in w {
            run += x;
            c.push(run);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut counts = [0usize; 4];
        let n = 200_000;
        for _ in 0..n {
            counts[multinomial_draw(&c, rng.random::<f64>())] += 1;
        }
        assert_eq!(counts[1], 0);
        for (i, &wi) in w.iter().enumerate() {
            let share = counts[i] as f64 / n as f64;
            assert!((share - wi).abs() < 0.005, "particle {i}: {share} for {wi}");
        }
        // The top of the range lands on the last non-zero particle, never past the end.
        assert_eq!(multinomial_draw(&c, 0.999_999_999), 3);
        assert_eq!(multinomial_draw(&[0.0, 0.0], 0.5), 1);
    }
}
