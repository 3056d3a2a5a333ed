//! The measured hit points of one step, bucketed for "is there a hit within r of this point?"
//! queries.
//!
//! Serves only the hit clearance of the removal vote ([`crate::additions::removal_gates`], a
//! project addition, see `UpdaterParams::removal_hit_clearance_m`): a cell that a
//! detected-change ray crosses is not
//! voted "removed" when some beam of the same step hit a surface within the clearance of the
//! cell's centre. The evidence of an occupied surface there is stronger than that of a ray
//! grazing past it; without the rule, rays at grazing incidence along a wall erode the wall's
//! edge cells whenever the pose is a fraction of a cell off.
//!
//! Memory is proportional to the beams of one step, not to the map: the points are kept
//! sorted by bucket, and a query looks at the 3 × 3 buckets around the query point.

use mapkeeper_grid::Point2;

/// Hit points bucketed on a square grid over their bounding box (bucket side ≥ the query
/// radius), stored bucket by bucket (compressed rows: `starts[b]..starts[b + 1]` indexes
/// `points`).
#[derive(Clone, Debug, Default)]
pub struct HitIndex {
    bucket_m: f64,
    radius_sq: f64,
    /// Lower-left corner of bucket (0, 0).
    x0: f64,
    y0: f64,
    nx: usize,
    ny: usize,
    starts: Vec<u32>,
    points: Vec<Point2>,
    /// Scratch: each point's bucket, the next free slot of each bucket, the points unsorted.
    keys: Vec<u32>,
    next: Vec<u32>,
    unsorted: Vec<Point2>,
}

/// Most buckets of an index; a larger bounding box gets larger buckets.
const MAX_BUCKETS: f64 = (1 << 20) as f64;

impl HitIndex {
    /// An empty index.
    pub fn new() -> Self {
        Self::default()
    }

    /// Refills the index with `points` for queries of radius `radius_m` (> 0). Non-finite
    /// points are ignored; a non-positive or non-finite radius empties the index.
    pub fn rebuild(&mut self, radius_m: f64, points: impl Iterator<Item = Point2>) {
        self.points.clear();
        self.unsorted.clear();
        self.starts.clear();
        self.keys.clear();
        self.nx = 0;
        self.ny = 0;
        if !(radius_m.is_finite() && radius_m > 0.0) {
            return;
        }
        self.radius_sq = radius_m * radius_m;
        self.unsorted
            .extend(points.filter(|p| p.x.is_finite() && p.y.is_finite() && p.x.abs() < 1e9 && p.y.abs() < 1e9));
        if self.unsorted.is_empty() {
            return;
        }
        let (mut lo, mut hi) = (self.unsorted[0], self.unsorted[0]);
        for p in &self.unsorted {
            lo = Point2::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Point2::new(hi.x.max(p.x), hi.y.max(p.y));
        }
        let area = ((hi.x - lo.x) / radius_m + 1.0) * ((hi.y - lo.y) / radius_m + 1.0);
        self.bucket_m = if area > MAX_BUCKETS { radius_m * (area / MAX_BUCKETS).sqrt().ceil() } else { radius_m };
        self.x0 = lo.x;
        self.y0 = lo.y;
        self.nx = ((hi.x - lo.x) / self.bucket_m).floor() as usize + 1;
        self.ny = ((hi.y - lo.y) / self.bucket_m).floor() as usize + 1;
        self.starts.resize(self.nx * self.ny + 1, 0);
        for k in 0..self.unsorted.len() {
            let b = self.bucket_of(self.unsorted[k]);
            self.keys.push(b as u32);
            self.starts[b + 1] += 1;
        }
        for b in 0..self.nx * self.ny {
            self.starts[b + 1] += self.starts[b];
        }
        // Place the points bucket by bucket (a counting sort; within a bucket, input order).
        self.next.clear();
        self.next.extend_from_slice(&self.starts[..self.nx * self.ny]);
        self.points.resize(self.unsorted.len(), Point2::new(0.0, 0.0));
        for (p, &b) in self.unsorted.iter().zip(&self.keys) {
            self.points[self.next[b as usize] as usize] = *p;
            self.next[b as usize] += 1;
        }
    }

    /// The bucket of a point inside the bounding box.
    fn bucket_of(&self, p: Point2) -> usize {
        let bx = (((p.x - self.x0) / self.bucket_m).floor() as usize).min(self.nx - 1);
        let by = (((p.y - self.y0) / self.bucket_m).floor() as usize).min(self.ny - 1);
        by * self.nx + bx
    }

    /// Whether a point of the index lies strictly closer than the radius to `p`.
    pub fn any_within(&self, p: Point2) -> bool {
        if self.points.is_empty() || !(p.x.is_finite() && p.y.is_finite()) {
            return false;
        }
        let (fx, fy) = (((p.x - self.x0) / self.bucket_m).floor(), ((p.y - self.y0) / self.bucket_m).floor());
        // Buckets fx-1 ..= fx+1 (and the same in y) that exist.
        if fx < -1.0 || fy < -1.0 || fx > self.nx as f64 || fy > self.ny as f64 {
            return false;
        }
        let (bx, by) = (fx as i64, fy as i64);
        let (x_lo, x_hi) = ((bx - 1).max(0) as usize, ((bx + 1) as usize).min(self.nx - 1));
        let (y_lo, y_hi) = ((by - 1).max(0) as usize, ((by + 1) as usize).min(self.ny - 1));
        for row in y_lo..=y_hi {
            let (a, b) = (self.starts[row * self.nx + x_lo] as usize, self.starts[row * self.nx + x_hi + 1] as usize);
            if self.points[a..b].iter().any(|q| q.distance_sq(p) < self.radius_sq) {
                return true;
            }
        }
        false
    }

    /// Points held.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the index is empty.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Heap bytes held (scratch, reused from step to step).
    pub fn capacity_bytes(&self) -> usize {
        (self.points.capacity() + self.unsorted.capacity()) * size_of::<Point2>()
            + (self.starts.capacity() + self.keys.capacity() + self.next.capacity()) * size_of::<u32>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_points_within_the_radius_only() {
        let mut h = HitIndex::new();
        let pts = [Point2::new(0.0, 0.0), Point2::new(1.0, 1.0), Point2::new(-3.02, 5.5)];
        h.rebuild(0.1, pts.into_iter());
        assert_eq!(h.len(), 3);
        assert!(h.any_within(Point2::new(0.05, 0.05)));
        assert!(!h.any_within(Point2::new(0.08, 0.08)));
        assert!(h.any_within(Point2::new(0.95, 1.02)));
        assert!(h.any_within(Point2::new(-2.95, 5.45)));
        assert!(!h.any_within(Point2::new(-2.9, 5.5)));
        // Across bucket borders in every direction.
        for (dx, dy) in [(0.099, 0.0), (-0.099, 0.0), (0.0, 0.099), (0.0, -0.099), (0.06, -0.06)] {
            assert!(h.any_within(Point2::new(1.0 + dx, 1.0 + dy)), "{dx} {dy}");
        }
    }

    #[test]
    fn brute_force_agreement() {
        let pts: Vec<Point2> = (0..200)
            .map(|k| Point2::new(((k * 37) % 101) as f64 * 0.031 - 1.5, ((k * 53) % 97) as f64 * 0.029))
            .collect();
        let mut h = HitIndex::new();
        h.rebuild(0.12, pts.iter().copied());
        for a in 0..60 {
            for b in 0..60 {
                let q = Point2::new(a as f64 * 0.057 - 1.7, b as f64 * 0.051 - 0.1);
                let brute = pts.iter().any(|p| p.distance_sq(q) < 0.12 * 0.12);
                assert_eq!(h.any_within(q), brute, "{q:?}");
            }
        }
    }

    #[test]
    fn degenerate_inputs() {
        let mut h = HitIndex::new();
        h.rebuild(0.0, [Point2::new(0.0, 0.0)].into_iter());
        assert!(h.is_empty() && !h.any_within(Point2::new(0.0, 0.0)));
        h.rebuild(0.1, [Point2::new(f64::NAN, 0.0), Point2::new(1e300, 0.0)].into_iter());
        assert!(h.is_empty());
        assert!(!h.any_within(Point2::new(f64::NAN, 1.0)));
    }
}
