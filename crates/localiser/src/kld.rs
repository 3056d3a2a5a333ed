//! KLD sampling (Fox 2003): how many particles keep the Kullback–Leibler divergence between the
//! sample-based and the true posterior below `ε` with probability `1 − δ`, given the number `k`
//! of histogram bins the samples occupy.

use mapkeeper_grid::geometry::floor_exact;
use mapkeeper_grid::{Pose2, wrap_angle};
use std::f64::consts::PI;

/// Fox's bound: `n = (k−1)/(2ε) · (1 − 2/(9(k−1)) + sqrt(2/(9(k−1)))·z)³`, with `z` the upper
/// `1 − δ` standard normal quantile. Returns 0 for `k ≤ 1` (the caller clamps to its
/// minimum) and rounds up.
///
/// ```
/// use mapkeeper_localiser::kld_bound;
/// assert_eq!(kld_bound(1, 0.05, 0.99), 0);
/// assert_eq!(kld_bound(2, 0.05, 0.99), 20);
/// ```
pub fn kld_bound(k: usize, err: f64, z: f64) -> usize {
    if k <= 1 {
        return 0;
    }
    let km1 = (k - 1) as f64;
    let a = 2.0 / (9.0 * km1);
    let b = 1.0 - a + a.sqrt() * z;
    let n = km1 / (2.0 * err) * b * b * b;
    if n.is_finite() && n > 0.0 { n.ceil().min(usize::MAX as f64 / 2.0) as usize } else { 0 }
}

/// Histogram bins over (x, y, yaw): sides `xy_m` and `yaw_rad`, with yaw bins wrapping around.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bins {
    inv_xy: f64,
    inv_yaw: f64,
    yaw_bins: i32,
}

/// One bin's integer coordinates `(ix, iy, iyaw)`, ordered so they can be sorted.
pub type BinKey = (i32, i32, i32);

impl Bins {
    /// Bins of the given sides (both positive and finite; see `FilterParams::validate`).
    pub fn new(xy_m: f64, yaw_rad: f64) -> Self {
        let yaw_bins = ((2.0 * PI / yaw_rad).ceil() as i32).max(1);
        Self { inv_xy: 1.0 / xy_m, inv_yaw: 1.0 / yaw_rad, yaw_bins }
    }

    /// Number of yaw bins around the circle.
    pub fn yaw_bins(&self) -> i32 {
        self.yaw_bins
    }

    /// The bin of a pose (saturating far away; non-finite components land in bin 0).
    #[inline]
    pub fn key(&self, p: &Pose2) -> BinKey {
        let yaw = wrap_angle(p.yaw) + PI; // [0, 2π]
        let iyaw = (floor_exact(yaw * self.inv_yaw) as i32).rem_euclid(self.yaw_bins);
        (floor_exact(p.x * self.inv_xy) as i32, floor_exact(p.y * self.inv_xy) as i32, iyaw)
    }
}

/// Number of distinct bins among `poses`, using `scratch` (cleared) for the keys.
pub fn count_bins<'a>(bins: &Bins, poses: impl Iterator<Item = &'a Pose2>, scratch: &mut Vec<BinKey>) -> usize {
    scratch.clear();
    scratch.extend(poses.map(|p| bins.key(p)));
    scratch.sort_unstable();
    scratch.dedup();
    scratch.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bound against the formula evaluated independently for a few (k, ε, z).
    #[test]
    fn bound_matches_fox_2003() {
        for &(k, err, z) in &[(2usize, 0.05, 0.99), (10, 0.05, 0.99), (100, 0.01, 2.326), (1000, 0.05, 0.99)] {
            let km1 = k as f64 - 1.0;
            let want = km1 / (2.0 * err) * (1.0 - 2.0 / (9.0 * km1) + (2.0 / (9.0 * km1)).sqrt() * z).powi(3);
            assert_eq!(kld_bound(k, err, z), want.ceil() as usize, "k = {k}");
        }
        // Hand-evaluated: k = 2, ε = 0.05, z = 0.99: 10 · (1 − 2/9 + 0.99·sqrt(2/9))³ = 19.27…
        assert_eq!(kld_bound(2, 0.05, 0.99), 20);
        // Large k: ~ (k−1)/(2ε).
        let n = kld_bound(100_001, 0.05, 0.0) as f64;
        assert!((n / 1e6 - 1.0).abs() < 1e-4);
        assert_eq!(kld_bound(0, 0.05, 0.99), 0);
    }

    #[test]
    fn bins_wrap_yaw_and_count() {
        let b = Bins::new(0.5, 10f64.to_radians());
        assert_eq!(b.yaw_bins(), 36);
        assert_eq!(b.key(&Pose2::new(0.49, -0.01, 0.0)), (0, -1, 18));
        assert_eq!(b.key(&Pose2::new(0.0, 0.0, PI)).2, 0); // π + π = 2π wraps to bin 0
        assert_eq!(b.key(&Pose2::new(0.0, 0.0, -PI + 1e-9)).2, 0);
        let poses = [Pose2::new(0.1, 0.1, 0.0), Pose2::new(0.2, 0.3, 0.01), Pose2::new(0.6, 0.1, 0.0)];
        assert_eq!(count_bins(&b, poses.iter(), &mut Vec::new()), 2);
        assert!(b.key(&Pose2::new(f64::NAN, 1e300, f64::NAN)).0 == 0);
    }
}
