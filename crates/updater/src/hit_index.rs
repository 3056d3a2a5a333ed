//! The measured hit points of one step, bucketed for "is there a hit within r of this point?"
//! queries.
//!
//! Used by the changed cells evaluator's hit clearance (a project addition, see
//! `UpdaterParams::removal_hit_clearance_m`): a cell that a detected-change ray crosses is not
//! voted "removed" when some beam of the same step hit a surface within the clearance of the
//! cell's centre. The evidence of an occupied surface there is stronger than that of a ray
//! grazing past it; without the rule, rays at grazing incidence along a wall erode the wall's
//! edge cells whenever the pose is a fraction of a cell off.
//!
//! Memory is proportional to the beams of one step, not to the map: the points are kept
//! sorted by bucket, and a query looks at the 3 × 3 buckets around the query point.

use mapkeeper_grid::Point2;

/// Hit points sorted by square bucket (side = the query radius).
#[derive(Clone, Debug, Default)]
pub struct HitIndex {
    bucket_m: f64,
    radius_sq: f64,
    entries: Vec<(i64, Point2)>,
}

/// Bucket rows are packed as `row * ROW_STRIDE + column`; columns are offset to stay positive.
const ROW_STRIDE: i64 = 1 << 32;
const COLUMN_OFFSET: i64 = 1 << 31;

impl HitIndex {
    /// An empty index.
    pub fn new() -> Self {
        Self::default()
    }

    /// Refills the index with `points` for queries of radius `radius_m` (> 0). Non-finite
    /// points are ignored.
    pub fn rebuild(&mut self, radius_m: f64, points: impl Iterator<Item = Point2>) {
        self.entries.clear();
        if !(radius_m.is_finite() && radius_m > 0.0) {
            self.bucket_m = 0.0;
            return;
        }
        self.bucket_m = radius_m;
        self.radius_sq = radius_m * radius_m;
        for p in points {
            if let Some(key) = self.key(p) {
                self.entries.push((key, p));
            }
        }
        self.entries.sort_unstable_by_key(|e| e.0);
    }

    fn bucket(&self, p: Point2) -> Option<(i64, i64)> {
        let (bx, by) = ((p.x / self.bucket_m).floor(), (p.y / self.bucket_m).floor());
        // Far beyond any map: ignore rather than wrap.
        let limit = (COLUMN_OFFSET / 2) as f64;
        (bx.abs() < limit && by.abs() < limit).then_some((bx as i64, by as i64))
    }

    fn key(&self, p: Point2) -> Option<i64> {
        if self.bucket_m <= 0.0 {
            return None;
        }
        self.bucket(p).map(|(bx, by)| by * ROW_STRIDE + bx + COLUMN_OFFSET)
    }

    /// Whether a point of the index lies strictly closer than the radius to `p`.
    pub fn any_within(&self, p: Point2) -> bool {
        if self.entries.is_empty() || self.bucket_m <= 0.0 {
            return false;
        }
        let Some((bx, by)) = self.bucket(p) else {
            return false;
        };
        for row in by - 1..=by + 1 {
            let lo = row * ROW_STRIDE + bx - 1 + COLUMN_OFFSET;
            let hi = lo + 2;
            let start = self.entries.partition_point(|e| e.0 < lo);
            for &(key, q) in &self.entries[start..] {
                if key > hi {
                    break;
                }
                if q.distance_sq(p) < self.radius_sq {
                    return true;
                }
            }
        }
        false
    }

    /// Points held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the index is empty.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Heap bytes held (scratch, reused from step to step).
    pub fn capacity_bytes(&self) -> usize {
        self.entries.capacity() * size_of::<(i64, Point2)>()
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
