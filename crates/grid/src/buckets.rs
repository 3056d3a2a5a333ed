//! Points of the plane sorted into square buckets, for "which points are near here?" queries.
//!
//! [`PointBuckets`] lays a grid of square buckets over the bounding box of its points and keeps
//! the points bucket by bucket (a counting sort, stable: within a bucket, input order), in
//! compressed rows: the points of bucket `b` are `points()[starts[b]..starts[b + 1]]`, so a run
//! of adjacent buckets of one row is one contiguous slice ([`PointBuckets::span`]). Its
//! buffers are reused from build to build: once they have grown to the largest input, a
//! rebuild allocates nothing.
//!
//! The bucket side is the caller's choice, made from the bounding box at each build (see
//! [`PointBuckets::rebuild`]), so that each user keeps its own sizing rule.
//!
//! ```
//! use mapkeeper_grid::Point2;
//! use mapkeeper_grid::buckets::PointBuckets;
//! let pts = [Point2::new(0.0, 0.0), Point2::new(0.25, 0.0), Point2::new(2.0, 1.0)];
//! let mut b = PointBuckets::new();
//! b.rebuild(&pts, |_lo, _hi| 0.5);
//! assert_eq!((b.nx(), b.ny()), (5, 3));
//! let near: Vec<Point2> = b.neighbourhood(Point2::new(0.1, 0.1), 1).map_or(Vec::new(), |r| {
//!     b.rect_spans(r).flat_map(|s| b.points()[s].iter().copied()).collect()
//! });
//! assert_eq!(near, [pts[0], pts[1]]);
//! assert_eq!(b.nearest_within(Point2::new(2.0, 0.75), 0.5), Some((2, 0.0625)));
//! ```

use crate::Point2;
use crate::geometry::floor_exact;
use std::ops::Range;

/// The most buckets a layout may have; [`PointBuckets::rebuild`] refuses a larger one.
pub const MAX_BUCKETS: usize = 1 << 26;

/// An inclusive rectangle of buckets: columns `x0..=x1`, rows `y0..=y1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BucketRect {
    /// First column.
    pub x0: usize,
    /// Last column (inclusive).
    pub x1: usize,
    /// First row.
    pub y0: usize,
    /// Last row (inclusive).
    pub y1: usize,
}

/// Points sorted into square buckets over their bounding box (see the [module](self)).
#[derive(Clone, Debug, Default)]
pub struct PointBuckets {
    /// Lower-left corner of bucket (0, 0): the bounding box's minimum.
    x0: f64,
    y0: f64,
    side_m: f64,
    nx: usize,
    ny: usize,
    /// `starts[b]..starts[b + 1]` indexes `points` (`nx · ny + 1` entries; empty when empty).
    starts: Vec<u32>,
    points: Vec<Point2>,
    /// Scratch: each point's bucket.
    keys: Vec<u32>,
}

impl PointBuckets {
    /// An empty structure.
    pub fn new() -> Self {
        Self::default()
    }

    /// Empties the structure (keeps its buffers).
    pub fn clear(&mut self) {
        self.points.clear();
        self.starts.clear();
        self.keys.clear();
        self.nx = 0;
        self.ny = 0;
    }

    /// Refills the structure with the finite points of `points`; non-finite points are
    /// ignored. `side_m` gets the bounding box (lower-left, upper-right corner) of those points
    /// and returns the bucket side, metres. The layout is `nx = ⌊(hi.x − lo.x) / side⌋ + 1`
    /// columns by `ny = ⌊(hi.y − lo.y) / side⌋ + 1` rows with bucket (0, 0) starting at `lo`.
    ///
    /// The structure is left empty when no point is finite, or when the side is not finite
    /// and positive or gives more than [`MAX_BUCKETS`] buckets (or more than `u32::MAX`
    /// points are given); `side_m` is not called without a finite point.
    pub fn rebuild(&mut self, points: &[Point2], side_m: impl FnOnce(Point2, Point2) -> f64) {
        self.clear();
        let finite = || points.iter().filter(|p| p.is_finite());
        let (mut lo, mut hi) =
            (Point2::new(f64::INFINITY, f64::INFINITY), Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY));
        let mut n = 0usize;
        for p in finite() {
            lo = Point2::new(lo.x.min(p.x), lo.y.min(p.y));
            hi = Point2::new(hi.x.max(p.x), hi.y.max(p.y));
            n += 1;
        }
        if n == 0 || n > u32::MAX as usize {
            return;
        }
        let side = side_m(lo, hi);
        if !(side.is_finite() && side > 0.0) {
            return;
        }
        let (fx, fy) = (floor_exact((hi.x - lo.x) / side), floor_exact((hi.y - lo.y) / side));
        if !(fx < MAX_BUCKETS as f64 && fy < MAX_BUCKETS as f64) {
            return;
        }
        let (nx, ny) = (fx as usize + 1, fy as usize + 1);
        if nx * ny > MAX_BUCKETS {
            return;
        }
        (self.x0, self.y0, self.side_m, self.nx, self.ny) = (lo.x, lo.y, side, nx, ny);
        let n_buckets = nx * ny;
        // Counting sort. First starts[b] = points in buckets 0..=b, then the points are placed
        // from the last to the first, each bucket filled from its end: afterwards starts[b] is
        // the first slot of bucket b, and a bucket holds its points in input order.
        self.starts.resize(n_buckets + 1, 0);
        for p in finite() {
            let b = self.bucket_of(*p);
            self.keys.push(b as u32);
            self.starts[b] += 1;
        }
        for b in 1..n_buckets {
            self.starts[b] += self.starts[b - 1];
        }
        self.starts[n_buckets] = n as u32;
        self.points.resize(n, Point2::default());
        for (p, &b) in finite().rev().zip(self.keys.iter().rev()) {
            let slot = &mut self.starts[b as usize];
            *slot -= 1;
            self.points[*slot as usize] = *p;
        }
    }

    /// The points, bucket by bucket (row-major buckets; within a bucket, input order).
    pub fn points(&self) -> &[Point2] {
        &self.points
    }

    /// Number of points held.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point is held.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Columns of buckets (0 when empty).
    pub fn nx(&self) -> usize {
        self.nx
    }

    /// Rows of buckets (0 when empty).
    pub fn ny(&self) -> usize {
        self.ny
    }

    /// Side of a bucket, metres (meaningless when empty).
    pub fn side_m(&self) -> f64 {
        self.side_m
    }

    /// Lower-left corner of bucket (0, 0) (meaningless when empty).
    pub fn origin(&self) -> Point2 {
        Point2::new(self.x0, self.y0)
    }

    /// The bucket (row-major index `row · nx + column`) of `p`, clamped into the grid: a point
    /// left of or below the grid (or NaN) counts as column or row 0, one right of or above it as
    /// the last. Requires a non-empty structure.
    pub fn bucket_of(&self, p: Point2) -> usize {
        let bx = (floor_exact((p.x - self.x0) / self.side_m) as usize).min(self.nx - 1);
        let by = (floor_exact((p.y - self.y0) / self.side_m) as usize).min(self.ny - 1);
        by * self.nx + bx
    }

    /// Bucket coordinates of `p`, not clamped: `(⌊(p.x − x0) / side⌋, ⌊(p.y − y0) / side⌋)`.
    pub fn bucket_coords(&self, p: Point2) -> (f64, f64) {
        (floor_exact((p.x - self.x0) / self.side_m), floor_exact((p.y - self.y0) / self.side_m))
    }

    /// The buckets within `k` columns and rows of `p`'s bucket ((2k + 1) × (2k + 1) of them,
    /// fewer at the grid's border), or `None` when there is none (empty structure, non-finite
    /// `p`, or `p` more than `k` buckets outside the grid). With `side ≥ r`, every point closer
    /// than `r` to `p` lies in the rectangle of `k = 1`.
    pub fn neighbourhood(&self, p: Point2, k: usize) -> Option<BucketRect> {
        if self.points.is_empty() || !p.is_finite() {
            return None;
        }
        let (fx, fy) = self.bucket_coords(p);
        let kf = k as f64;
        if fx < -kf || fy < -kf || fx > (self.nx - 1) as f64 + kf || fy > (self.ny - 1) as f64 + kf {
            return None;
        }
        let (bx, by, k) = (fx as i64, fy as i64, k as i64);
        Some(BucketRect {
            x0: (bx - k).max(0) as usize,
            x1: ((bx + k) as usize).min(self.nx - 1),
            y0: (by - k).max(0) as usize,
            y1: ((by + k) as usize).min(self.ny - 1),
        })
    }

    /// The buckets that meet the square of half-side `r` about `p` (every point within `r` of
    /// `p` lies in them), or `None` when there is none (empty structure, non-finite `p`, or the
    /// square misses the grid).
    pub fn covering(&self, p: Point2, r: f64) -> Option<BucketRect> {
        if self.points.is_empty() || !p.is_finite() {
            return None;
        }
        let fx0 = floor_exact((p.x - r - self.x0) / self.side_m);
        let fx1 = floor_exact((p.x + r - self.x0) / self.side_m);
        let fy0 = floor_exact((p.y - r - self.y0) / self.side_m);
        let fy1 = floor_exact((p.y + r - self.y0) / self.side_m);
        if fx1 < 0.0 || fy1 < 0.0 || fx0 >= self.nx as f64 || fy0 >= self.ny as f64 {
            return None;
        }
        Some(BucketRect {
            x0: fx0.max(0.0) as usize,
            x1: (fx1 as usize).min(self.nx - 1),
            y0: fy0.max(0.0) as usize,
            y1: (fy1 as usize).min(self.ny - 1),
        })
    }

    /// Indices into [`PointBuckets::points`] of the points in columns `x0..=x1` of row `row`
    /// (one slice, as a row's buckets are stored one after the other).
    #[inline]
    pub fn span(&self, row: usize, x0: usize, x1: usize) -> Range<usize> {
        let at = row * self.nx;
        self.starts[at + x0] as usize..self.starts[at + x1 + 1] as usize
    }

    /// The spans ([`PointBuckets::span`]) of the rows of `rect`, bottom row first.
    pub fn rect_spans(&self, rect: BucketRect) -> impl Iterator<Item = Range<usize>> + '_ {
        (rect.y0..=rect.y1).map(move |row| self.span(row, rect.x0, rect.x1))
    }

    /// Index of the point nearest to `p` among those strictly closer than `max_m`, with its
    /// squared distance (among equally near points, the first one visited). Exact: buckets are
    /// visited in square rings around `p`'s bucket, and the search stops once no bucket further
    /// out can hold a closer point.
    #[inline]
    pub fn nearest_within(&self, p: Point2, max_m: f64) -> Option<(usize, f64)> {
        let BucketRect { x0: bx0, x1: bx1, y0: by0, y1: by1 } = self.covering(p, max_m)?;
        let mut best = max_m * max_m;
        let mut found = None;
        let scan = |row: usize, x0: usize, x1: usize, best: &mut f64, found: &mut Option<usize>| {
            let s = self.span(row, x0, x1);
            let start = s.start;
            for (k, q) in self.points[s].iter().enumerate() {
                let d = q.distance_sq(p);
                if d < *best {
                    *best = d;
                    *found = Some(start + k);
                }
            }
        };
        // The bucket of p, clamped into the searched rectangle (p may lie outside the grid).
        let (fx, fy) = self.bucket_coords(p);
        let cx = (fx.max(bx0 as f64) as usize).min(bx1);
        let cy = (fy.max(by0 as f64) as usize).min(by1);
        let inside = fx >= 0.0 && fy >= 0.0 && fx as usize == cx && fy as usize == cy;
        let max_ring = (cx - bx0).max(bx1 - cx).max(cy - by0).max(by1 - cy);
        for r in 0..=max_ring {
            let (x0, x1) = (cx.saturating_sub(r).max(bx0), (cx + r).min(bx1));
            for by in [cy.checked_sub(r), Some(cy + r)].into_iter().flatten() {
                if by < by0 || by > by1 || (r == 0 && by != cy) {
                    continue;
                }
                scan(by, x0, x1, &mut best, &mut found);
                if r == 0 {
                    break;
                }
            }
            if r > 0 {
                let (y0, y1) = (cy.saturating_sub(r - 1).max(by0), (cy + r - 1).min(by1));
                for by in y0..=y1 {
                    if cx >= r && cx - r >= bx0 {
                        scan(by, cx - r, cx - r, &mut best, &mut found);
                    }
                    if cx + r <= bx1 {
                        scan(by, cx + r, cx + r, &mut best, &mut found);
                    }
                }
            }
            // Every point of ring r + 1 is at least r buckets from p when p lies in its bucket.
            if inside && found.is_some() {
                let reach = r as f64 * self.side_m;
                if reach * reach >= best {
                    break;
                }
            }
        }
        found.map(|k| (k, best))
    }

    /// Heap bytes held (points, bucket starts, scratch; reused from build to build).
    pub fn heap_bytes(&self) -> usize {
        self.points.capacity() * size_of::<Point2>()
            + (self.starts.capacity() + self.keys.capacity()) * size_of::<u32>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pt(x: f64, y: f64) -> Point2 {
        Point2::new(x, y)
    }

    /// The points of a rectangle, in storage order.
    fn in_rect(b: &PointBuckets, r: Option<BucketRect>) -> Vec<Point2> {
        r.map_or(Vec::new(), |r| b.rect_spans(r).flat_map(|s| b.points()[s].to_vec()).collect())
    }

    /// The buckets' contents, bucket by bucket.
    fn contents(b: &PointBuckets) -> Vec<Vec<Point2>> {
        (0..b.ny()).flat_map(|y| (0..b.nx()).map(move |x| b.points()[b.span(y, x, x)].to_vec())).collect()
    }

    #[test]
    fn empty_and_non_finite_inputs_give_an_empty_structure() {
        let mut b = PointBuckets::new();
        assert!(b.is_empty() && b.neighbourhood(pt(0.0, 0.0), 1).is_none());
        b.rebuild(&[], |_, _| panic!("no point, no sizing"));
        assert!(b.is_empty() && (b.nx(), b.ny()) == (0, 0));
        b.rebuild(&[pt(f64::NAN, 0.0), pt(0.0, f64::INFINITY), pt(f64::NEG_INFINITY, 1.0)], |_, _| 1.0);
        assert!(b.is_empty());
        assert_eq!(b.nearest_within(pt(0.0, 0.0), 10.0), None);
        assert_eq!(b.covering(pt(0.0, 0.0), 10.0), None);
        // Non-finite points among finite ones are dropped and do not widen the box.
        b.rebuild(&[pt(f64::NAN, 5.0), pt(1.0, 1.0), pt(f64::INFINITY, 0.0), pt(2.0, 3.0)], |lo, hi| {
            assert_eq!((lo, hi), (pt(1.0, 1.0), pt(2.0, 3.0)));
            1.0
        });
        assert_eq!((b.len(), b.nx(), b.ny()), (2, 2, 3));
        // A bad side or too many buckets leaves it empty.
        for side in [0.0, -1.0, f64::NAN, f64::INFINITY, 1e-12] {
            b.rebuild(&[pt(0.0, 0.0), pt(1.0, 1.0)], |_, _| side);
            assert!(b.is_empty(), "{side}");
        }
        // A previous build leaves nothing behind.
        b.rebuild(&[pt(0.0, 0.0)], |_, _| 1.0);
        assert_eq!(b.points(), [pt(0.0, 0.0)]);
        b.clear();
        assert!(b.is_empty() && b.neighbourhood(pt(0.0, 0.0), 1).is_none());
    }

    #[test]
    fn points_on_bucket_borders_go_to_the_upper_bucket_and_the_box_edge_to_the_last() {
        // Box [0, 2] × [0, 1], side 0.5: 5 × 3 buckets (the upper edges open a last bucket).
        let pts = [pt(0.5, 0.0), pt(0.0, 0.0), pt(2.0, 1.0), pt(1.0, 0.5), pt(0.49, 0.5), pt(0.5, 0.49)];
        let mut b = PointBuckets::new();
        b.rebuild(&pts, |_, _| 0.5);
        assert_eq!((b.nx(), b.ny(), b.origin(), b.side_m()), (5, 3, pt(0.0, 0.0), 0.5));
        assert_eq!(b.bucket_of(pt(0.5, 0.0)), 1);
        assert_eq!(b.bucket_of(pt(0.49, 0.5)), 5);
        assert_eq!(b.bucket_of(pt(1.0, 0.5)), 7);
        assert_eq!(b.bucket_of(pt(2.0, 1.0)), 14);
        // Clamped outside the grid.
        assert_eq!(b.bucket_of(pt(-3.0, -3.0)), 0);
        assert_eq!(b.bucket_of(pt(9.0, 9.0)), 14);
        let mut want = vec![Vec::new(); 15];
        want[0] = vec![pt(0.0, 0.0)];
        want[1] = vec![pt(0.5, 0.0), pt(0.5, 0.49)];
        want[5] = vec![pt(0.49, 0.5)];
        want[7] = vec![pt(1.0, 0.5)];
        want[14] = vec![pt(2.0, 1.0)];
        assert_eq!(contents(&b), want);
        assert_eq!(b.span(0, 0, 4), 0..3);
        assert_eq!(b.span(1, 0, 4), 3..5);
        assert_eq!(b.span(2, 0, 4), 5..6);
    }

    #[test]
    fn a_bucket_keeps_input_order() {
        let pts = [pt(0.3, 0.3), pt(5.0, 5.0), pt(0.1, 0.2), pt(0.2, 0.1), pt(4.9, 4.8)];
        let mut b = PointBuckets::new();
        b.rebuild(&pts, |_, _| 1.0);
        // Box from (0.1, 0.1): 5 × 5 buckets; the last two points share bucket (4, 4).
        assert_eq!((b.nx(), b.ny()), (5, 5));
        assert_eq!(b.points(), [pt(0.3, 0.3), pt(0.1, 0.2), pt(0.2, 0.1), pt(5.0, 5.0), pt(4.9, 4.8)]);
    }

    #[test]
    fn neighbourhood_is_clamped_and_refused_far_outside() {
        // 4 × 2 buckets of 1 m from (0, 0).
        let mut b = PointBuckets::new();
        b.rebuild(&[pt(0.0, 0.0), pt(3.5, 1.5)], |_, _| 1.0);
        assert_eq!((b.nx(), b.ny()), (4, 2));
        let r = |x0, x1, y0, y1| Some(BucketRect { x0, x1, y0, y1 });
        assert_eq!(b.neighbourhood(pt(1.5, 0.5), 1), r(0, 2, 0, 1));
        assert_eq!(b.neighbourhood(pt(1.5, 0.5), 0), r(1, 1, 0, 0));
        assert_eq!(b.neighbourhood(pt(-0.5, -0.5), 1), r(0, 0, 0, 0));
        assert_eq!(b.neighbourhood(pt(-1.5, 0.5), 1), None);
        assert_eq!(b.neighbourhood(pt(-1.5, 0.5), 2), r(0, 0, 0, 1));
        assert_eq!(b.neighbourhood(pt(4.99, 2.99), 1), r(3, 3, 1, 1));
        assert_eq!(b.neighbourhood(pt(5.0, 0.5), 1), None);
        assert_eq!(b.neighbourhood(pt(f64::NAN, 0.5), 1), None);
        assert_eq!(b.covering(pt(1.5, 0.5), 0.25), r(1, 1, 0, 0));
        assert_eq!(b.covering(pt(1.5, 0.5), 0.75), r(0, 2, 0, 1));
        assert_eq!(b.covering(pt(-0.5, 0.5), 0.25), None);
        assert_eq!(b.covering(pt(-0.5, 0.5), 0.5), r(0, 0, 0, 1));
        assert_eq!(in_rect(&b, b.neighbourhood(pt(2.5, 1.5), 1)), [pt(3.5, 1.5)]);
    }

    #[test]
    fn heap_bytes_count_the_buffers_and_rebuilds_reuse_them() {
        let pts: Vec<Point2> = (0..100).map(|k| pt(k as f64 * 0.1, (k % 7) as f64)).collect();
        let mut b = PointBuckets::new();
        b.rebuild(&pts, |_, _| 0.5);
        let bytes = b.heap_bytes();
        assert!(bytes >= 100 * size_of::<Point2>() + (b.nx() * b.ny() + 1 + 100) * size_of::<u32>());
        b.rebuild(&pts[..50], |_, _| 0.5);
        assert_eq!(b.heap_bytes(), bytes);
    }

    fn points_strategy() -> impl Strategy<Value = Vec<Point2>> {
        prop::collection::vec((-5.0f64..5.0, -3.0f64..3.0).prop_map(|(x, y)| pt(x, y)), 0..80)
    }

    proptest! {
        #[test]
        fn neighbourhood_and_nearest_equal_brute_force(
            pts in points_strategy(),
            side in 0.05f64..2.0,
            queries in prop::collection::vec((-7.0f64..7.0, -5.0f64..5.0), 1..20),
            k in 0usize..3,
        ) {
            let mut b = PointBuckets::new();
            b.rebuild(&pts, |_, _| side);
            prop_assert_eq!(b.len(), pts.len());
            // Stored bucket by bucket, stable: a stable sort of the input by bucket.
            if !pts.is_empty() {
                let mut sorted = pts.clone();
                sorted.sort_by_key(|p| b.bucket_of(*p));
                prop_assert_eq!(b.points(), &sorted[..]);
            }
            for (qx, qy) in queries {
                let q = pt(qx, qy);
                // The (2k+1)² neighbourhood holds every point within k buckets' reach …
                let r = k as f64 * side;
                let got = in_rect(&b, b.neighbourhood(q, k));
                let brute: Vec<Point2> = b.points().iter().copied().filter(|p| p.distance(q) < r).collect();
                let got_near: Vec<Point2> = got.iter().copied().filter(|p| p.distance(q) < r).collect();
                prop_assert_eq!(got_near, brute);
                // … and exactly the points whose bucket is within k of q's.
                let (fx, fy) = b.bucket_coords(q);
                let expect: usize = b.points().iter().filter(|p| {
                    let (px, py) = b.bucket_coords(**p);
                    let (px, py) = (px.min((b.nx() - 1) as f64), py.min((b.ny() - 1) as f64));
                    (px - fx).abs() <= k as f64 && (py - fy).abs() <= k as f64
                }).count();
                prop_assert_eq!(got.len(), expect);
                // Covering: every point within r of q.
                let rr = side * 1.3;
                let cov = in_rect(&b, b.covering(q, rr));
                for p in b.points() {
                    if p.distance(q) <= rr {
                        prop_assert!(cov.contains(p));
                    }
                }
                // Nearest within a radius: the brute-force minimum.
                for max_m in [side * 0.5, side * 2.5, 20.0] {
                    let brute = b.points().iter().map(|p| p.distance_sq(q)).filter(|&d| d < max_m * max_m).reduce(f64::min);
                    let got = b.nearest_within(q, max_m);
                    prop_assert_eq!(got.map(|g| g.1), brute);
                    if let Some((i, d)) = got {
                        prop_assert_eq!(b.points()[i].distance_sq(q), d);
                    }
                }
            }
        }
    }
}
