//! The measured hit points of one step, bucketed for "is there a hit within r of this point?"
//! queries.
//!
//! Serves only the hit clearance of the removal vote (`additions::removal_gates`, a
//! project addition, see `RemovalParams::hit_clearance_m`): a cell that a
//! detected-change ray crosses is not
//! voted "removed" when some beam of the same step hit a surface within the clearance of the
//! cell's centre. The evidence of an occupied surface there is stronger than that of a ray
//! grazing past it; without the rule, rays at grazing incidence along a wall erode the wall's
//! edge cells whenever the pose is a fraction of a cell off.
//!
//! Memory is proportional to the beams of one step, not to the map: the points are kept
//! sorted by bucket, and a query looks at the 3 × 3 buckets around the query point.

use mapkeeper_grid::Point2;
use mapkeeper_grid::buckets::PointBuckets;

/// Hit points bucketed on a square grid over their bounding box (bucket side ≥ the query
/// radius; [`PointBuckets`], compressed rows).
#[derive(Clone, Debug, Default)]
pub struct HitIndex {
    radius_sq: f64,
    buckets: PointBuckets,
    /// Scratch: the points as given (finite, bounded), before bucketing.
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
        self.unsorted.clear();
        self.buckets.clear();
        if !(radius_m.is_finite() && radius_m > 0.0) {
            return;
        }
        self.radius_sq = radius_m * radius_m;
        self.unsorted
            .extend(points.filter(|p| p.x.is_finite() && p.y.is_finite() && p.x.abs() < 1e9 && p.y.abs() < 1e9));
        // Buckets of the radius, scaled up by a whole factor when there would be too many.
        self.buckets.rebuild(&self.unsorted, |lo, hi| {
            let area = ((hi.x - lo.x) / radius_m + 1.0) * ((hi.y - lo.y) / radius_m + 1.0);
            if area > MAX_BUCKETS { radius_m * (area / MAX_BUCKETS).sqrt().ceil() } else { radius_m }
        });
    }

    /// Whether a point of the index lies strictly closer than the radius to `p`.
    pub fn any_within(&self, p: Point2) -> bool {
        // Bucket side ≥ radius: the 3 × 3 buckets around p's hold every point within it.
        let Some(rect) = self.buckets.neighbourhood(p, 1) else { return false };
        let points = self.buckets.points();
        self.buckets.rect_spans(rect).any(|s| points[s].iter().any(|q| q.distance_sq(p) < self.radius_sq))
    }

    /// Points held.
    pub fn len(&self) -> usize {
        self.buckets.len()
    }

    /// Whether the index is empty.
    pub fn is_empty(&self) -> bool {
        self.buckets.is_empty()
    }

    /// Heap bytes held (scratch, reused from step to step).
    pub fn capacity_bytes(&self) -> usize {
        self.buckets.heap_bytes() + self.unsorted.capacity() * size_of::<Point2>()
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
