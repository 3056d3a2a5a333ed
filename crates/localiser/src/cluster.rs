//! The pose estimate: particles are grouped by their KLD histogram bins, bins that touch (26
//! neighbours in x, y, yaw, yaw wrapping) form one cluster, and the estimate is the weighted
//! mean and covariance of the heaviest cluster (circular mean for yaw).

use crate::kld::{BinKey, Bins};
use mapkeeper_grid::{Pose2, angle_diff};
use rustc_hash::FxHashMap;

/// The weighted mean and covariance of the heaviest cluster.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClusterStats {
    /// Weighted mean pose (circular mean for yaw).
    pub mean: Pose2,
    /// Weighted covariance of (x m, y m, yaw rad), yaw deviations wrapped around the mean.
    pub covariance: [[f64; 3]; 3],
    /// Share of the total weight in this cluster, in [0, 1].
    pub weight: f64,
    /// Number of clusters found.
    pub clusters: usize,
}

/// Reusable buffers for [`best_cluster`].
#[derive(Clone, Debug, Default)]
pub struct ClusterScratch {
    keyed: Vec<(BinKey, u32)>,
    /// The particles' bin keys, and their packed sort keys (see [`bin_particles`]).
    keys: Vec<BinKey>,
    packed: Vec<u64>,
    bins: Vec<(BinKey, u32, u32)>,
    parent: Vec<u32>,
    weight: Vec<f64>,
    /// Bin key → index into `bins`, for the neighbour look-ups.
    index: FxHashMap<BinKey, u32>,
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = p;
    }
    i
}

/// Sorts the particles by bin (`s.keyed`: key, particle index), lists the occupied bins in key
/// order (`s.bins`: key, range in `s.keyed`) and makes each bin its own root in `s.parent`.
///
/// The sort is the costly part; when the keys' ranges fit in 32 bits, each (key, index) is packed
/// into one `u64` whose order is the tuples' order (offsets from the smallest x and y, then the
/// yaw bin, then the index), which sorts several times faster and gives the same sequence (every
/// pair is distinct).
fn bin_particles(poses: &[Pose2], bins: &Bins, s: &mut ClusterScratch) {
    s.keys.clear();
    s.keys.extend(poses.iter().map(|p| bins.key(p)));
    s.keyed.clear();
    if let Some(pack) = Packing::fit(&s.keys, bins.yaw_bins()) {
        s.packed.clear();
        s.packed.extend(s.keys.iter().enumerate().map(|(i, k)| (pack.key(k) << 32) | i as u64));
        s.packed.sort_unstable();
        s.keyed.extend(s.packed.iter().map(|&v| {
            let i = (v & 0xffff_ffff) as u32;
            (s.keys[i as usize], i)
        }));
    } else {
        s.keyed.extend(s.keys.iter().enumerate().map(|(i, &k)| (k, i as u32)));
        s.keyed.sort_unstable();
    }
    s.bins.clear();
    for (j, &(key, _)) in s.keyed.iter().enumerate() {
        match s.bins.last_mut() {
            Some(last) if last.0 == key => last.2 = j as u32 + 1,
            _ => s.bins.push((key, j as u32, j as u32 + 1)),
        }
    }
    s.parent.clear();
    s.parent.extend(0..s.bins.len() as u32);
}

/// An order-preserving packing of bin keys into 32 bits: x and y as offsets from their smallest
/// value, then the yaw bin, each in as many bits as its range needs.
struct Packing {
    x0: i64,
    y0: i64,
    y_bits: u32,
    a_bits: u32,
}

impl Packing {
    /// The packing of `keys`, if their ranges fit in 32 bits (and there are at most 2^32 keys);
    /// none for no keys.
    fn fit(keys: &[BinKey], yaw_bins: i32) -> Option<Self> {
        let &(x, y, _) = keys.first()?;
        let (mut x0, mut x1, mut y0, mut y1) = (i64::from(x), i64::from(x), i64::from(y), i64::from(y));
        for &(x, y, _) in keys {
            (x0, x1) = (x0.min(i64::from(x)), x1.max(i64::from(x)));
            (y0, y1) = (y0.min(i64::from(y)), y1.max(i64::from(y)));
        }
        let bits = |span: i64| 64 - (span.max(0) as u64).leading_zeros();
        let (x_bits, y_bits, a_bits) = (bits(x1 - x0), bits(y1 - y0), bits(i64::from(yaw_bins) - 1));
        (u32::try_from(keys.len()).is_ok() && x_bits + y_bits + a_bits <= 32).then_some(Self { x0, y0, y_bits, a_bits })
    }

    fn key(&self, &(x, y, a): &BinKey) -> u64 {
        let (dx, dy) = ((i64::from(x) - self.x0) as u64, (i64::from(y) - self.y0) as u64);
        (dx << (self.y_bits + self.a_bits)) | (dy << self.a_bits) | a as u64
    }
}

/// Joins every occupied bin with its occupied neighbours (26-connected, yaw wrapping) in the
/// union-find `s.parent`, the smaller index as root. Touching is symmetric (yaw wrapping and the
/// saturation at the ends of `i32` included), so each pair is looked up once, from its smaller
/// key; the root of a cluster is its smallest bin index whatever the order of the unions, so the
/// clusters and their roots are those of looking every pair up from both sides.
fn link_neighbour_bins(s: &mut ClusterScratch, yaw_bins: i32) {
    s.index.clear();
    s.index.extend(s.bins.iter().enumerate().map(|(b, e)| (e.0, b as u32)));
    for b in 0..s.bins.len() {
        let key = s.bins[b].0;
        let (x, y, a) = key;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for da in -1..=1 {
                    let n = (x.saturating_add(dx), y.saturating_add(dy), (a + da).rem_euclid(yaw_bins));
                    if n <= key {
                        continue;
                    }
                    if let Some(&o) = s.index.get(&n) {
                        let (ra, rb) = (find(&mut s.parent, b as u32), find(&mut s.parent, o));
                        if ra != rb {
                            // Smaller index as root: deterministic.
                            let (lo, hi) = (ra.min(rb), ra.max(rb));
                            s.parent[hi as usize] = lo;
                        }
                    }
                }
            }
        }
    }
}

/// The heaviest cluster of the weighted particles. Weights need not be normalised; if they sum
/// to zero (or are not finite) every particle counts equally. `poses` must not be empty.
pub fn best_cluster(poses: &[Pose2], weights: &[f64], bins: &Bins, s: &mut ClusterScratch) -> ClusterStats {
    let total: f64 = weights.iter().sum();
    let uniform = !(total.is_finite() && total > 0.0);
    let w = |i: usize| if uniform { 1.0 } else { weights.get(i).copied().unwrap_or(0.0) };

    bin_particles(poses, bins, s);
    let nb = s.bins.len();
    link_neighbour_bins(s, bins.yaw_bins());
    s.weight.clear();
    s.weight.resize(nb, 0.0);
    let mut clusters = 0;
    for b in 0..nb {
        let r = find(&mut s.parent, b as u32) as usize;
        if r == b {
            clusters += 1;
        }
        let (_, lo, hi) = s.bins[b];
        s.weight[r] += s.keyed[lo as usize..hi as usize].iter().map(|&(_, i)| w(i as usize)).sum::<f64>();
    }
    let mut best = 0usize;
    for b in 0..nb {
        if s.weight[b] > s.weight[best] {
            best = b;
        }
    }
    let best_weight = s.weight.get(best).copied().unwrap_or(0.0);

    // Mean: linear in x, y; circular in yaw.
    let (mut sw, mut sx, mut sy, mut ss, mut sc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for b in 0..nb {
        if find(&mut s.parent, b as u32) as usize != best {
            continue;
        }
        let (_, lo, hi) = s.bins[b];
        for &(_, i) in &s.keyed[lo as usize..hi as usize] {
            let (p, wi) = (&poses[i as usize], w(i as usize));
            sw += wi;
            sx += wi * p.x;
            sy += wi * p.y;
            ss += wi * p.yaw.sin();
            sc += wi * p.yaw.cos();
        }
    }
    let sw_safe = if sw > 0.0 { sw } else { 1.0 };
    let mean = Pose2::new(sx / sw_safe, sy / sw_safe, ss.atan2(sc));
    let mut cov = [[0.0; 3]; 3];
    for b in 0..nb {
        if find(&mut s.parent, b as u32) as usize != best {
            continue;
        }
        let (_, lo, hi) = s.bins[b];
        for &(_, i) in &s.keyed[lo as usize..hi as usize] {
            let (p, wi) = (&poses[i as usize], w(i as usize));
            let d = [p.x - mean.x, p.y - mean.y, angle_diff(p.yaw, mean.yaw)];
            for r in 0..3 {
                for c in 0..3 {
                    cov[r][c] += wi * d[r] * d[c];
                }
            }
        }
    }
    for row in &mut cov {
        for v in row.iter_mut() {
            *v /= sw_safe;
        }
    }
    let all: f64 = s.weight.iter().sum();
    ClusterStats { mean, covariance: cov, weight: if all > 0.0 { best_weight / all } else { 0.0 }, clusters }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn heaviest_of_two_clusters_with_circular_yaw() {
        let bins = Bins::new(0.5, 10f64.to_radians());
        // Cluster A near (0, 0) across the ±π seam; cluster B far away with less weight.
        let poses = [
            Pose2::new(0.0, 0.0, PI - 0.05),
            Pose2::new(0.2, 0.0, -PI + 0.05),
            Pose2::new(5.0, 5.0, 0.0),
            Pose2::new(5.1, 5.0, 0.0),
        ];
        let weights = [0.3, 0.3, 0.2, 0.2];
        let st = best_cluster(&poses, &weights, &bins, &mut ClusterScratch::default());
        assert_eq!(st.clusters, 2);
        assert!((st.weight - 0.6).abs() < 1e-12);
        assert!((st.mean.x - 0.1).abs() < 1e-12 && st.mean.y.abs() < 1e-12);
        assert!((st.mean.yaw.abs() - PI).abs() < 1e-9, "{}", st.mean.yaw);
        assert!((st.covariance[0][0] - 0.01).abs() < 1e-12);
        assert!((st.covariance[2][2] - 0.0025).abs() < 1e-9);
        assert!((st.covariance[0][2] - st.covariance[2][0]).abs() < 1e-15);
    }

    /// The linking of the first releases: every bin looks up all 26 neighbours by binary search.
    fn link_from_both_sides(s: &mut ClusterScratch, yaw_bins: i32) {
        for b in 0..s.bins.len() {
            let (x, y, a) = s.bins[b].0;
            for (dx, dy, da) in
                (-1..=1).flat_map(|dx| (-1..=1).flat_map(move |dy| (-1..=1).map(move |da| (dx, dy, da))))
            {
                if (dx, dy, da) == (0, 0, 0) {
                    continue;
                }
                let n = (x.saturating_add(dx), y.saturating_add(dy), (a + da).rem_euclid(yaw_bins));
                if let Ok(o) = s.bins.binary_search_by(|e| e.0.cmp(&n)) {
                    let (ra, rb) = (find(&mut s.parent, b as u32), find(&mut s.parent, o as u32));
                    let (lo, hi) = (ra.min(rb), ra.max(rb));
                    s.parent[hi as usize] = lo;
                }
            }
        }
    }

    #[test]
    fn the_packed_sort_gives_the_tuples_order() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(11);
        for case in 0..40 {
            let bins = Bins::new([0.5, 0.05, 2.0][case % 3], [10f64.to_radians(), 0.01, 7.0][case % 3]);
            let spread = [0.3, 5.0, 80.0, 1e4][case % 4];
            let mut poses: Vec<Pose2> = (0..1 + case * 13)
                .map(|_| {
                    let c = |r: &mut rand::rngs::ChaCha8Rng| r.random_range(-spread..spread);
                    Pose2::new(c(&mut rng), c(&mut rng), rng.random_range(-PI..PI))
                })
                .collect();
            if case % 5 == 0 {
                poses.push(Pose2::new(-1e12, 1e12, 0.0)); // beyond i32: not packable
            }
            let mut s = ClusterScratch::default();
            bin_particles(&poses, &bins, &mut s);
            let mut want: Vec<(BinKey, u32)> = poses.iter().enumerate().map(|(i, p)| (bins.key(p), i as u32)).collect();
            want.sort_unstable();
            assert_eq!(s.keyed, want, "case {case}");
        }
        let mut s = ClusterScratch::default();
        bin_particles(&[], &Bins::new(0.5, 0.2), &mut s);
        assert!(s.keyed.is_empty() && s.bins.is_empty());
    }

    fn roots(s: &mut ClusterScratch) -> Vec<u32> {
        (0..s.bins.len() as u32).map(|b| find(&mut s.parent, b)).collect()
    }

    #[test]
    fn pairs_looked_up_once_give_the_clusters_of_looking_up_both_sides() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand::rngs::ChaCha8Rng::seed_from_u64(7);
        for case in 0..60 {
            // Yaw bins from 1 (every heading one bin) to 36, spreads from one bin to many, poses
            // across the ±π seam, and a few at the ends of i32 (saturated keys).
            let yaw_rad = [7.0, 3.5, 2.2, 0.5, 10f64.to_radians()][case % 5];
            let bins = Bins::new(0.5, yaw_rad);
            let spread = [0.6, 2.0, 6.0][case % 3];
            let n = 1 + (case * 37) % 400;
            let mut poses: Vec<Pose2> = (0..n)
                .map(|_| {
                    Pose2::new(
                        rng.random_range(-spread..spread),
                        rng.random_range(-spread..spread),
                        rng.random_range(-PI..PI),
                    )
                })
                .collect();
            if case % 7 == 0 {
                poses.push(Pose2::new(1e12, 0.0, 0.0));
                poses.push(Pose2::new(1e12, 0.4, 0.1));
                poses.push(Pose2::new(-1e12, -0.2, 3.1));
            }
            let mut once = ClusterScratch::default();
            bin_particles(&poses, &bins, &mut once);
            link_neighbour_bins(&mut once, bins.yaw_bins());
            let mut both = ClusterScratch::default();
            bin_particles(&poses, &bins, &mut both);
            link_from_both_sides(&mut both, bins.yaw_bins());
            assert_eq!(roots(&mut once), roots(&mut both), "case {case}");
        }
    }

    #[test]
    fn zero_weights_count_equally() {
        let bins = Bins::new(0.5, 0.2);
        let poses = [Pose2::new(1.0, 1.0, 0.0), Pose2::new(1.2, 1.0, 0.0)];
        let st = best_cluster(&poses, &[0.0, 0.0], &bins, &mut ClusterScratch::default());
        assert!((st.mean.x - 1.1).abs() < 1e-12 && st.clusters == 1 && st.weight == 1.0);
    }
}
