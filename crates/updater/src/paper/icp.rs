//! The registration of pose updating (§4.6: "any method ... e.g. Iterative Closest Point"):
//! 2D **point-to-line** ICP in SE(2). Each source point is paired with its nearest target point
//! within a correspondence distance that shrinks per iteration, and the residual is its
//! distance along that target point's normal (the major axis of its neighbours within 0.15 m;
//! points whose neighbourhood is not line-like are skipped). Each iteration is one Gauss–Newton
//! step on those residuals (3 × 3 normal equations, Cholesky, damped by 1e-6·(tr H + 1) so a
//! corridor's free direction cannot blow up), not a closed-form point-to-point alignment:
//! point-to-point pairs slide along walls. [`fitness`] measures point-to-point distances to the
//! nearest target point (inlier ratio, RMSE) and returns the point-to-line information matrix
//! for the covariance. Nearest neighbours come from a uniform bucket grid ([`PointGrid`],
//! compressed rows, exact ring search); its buffers are reused from build to build, and
//! nothing is allocated per iteration.

use crate::params::PoseUpdatingParams;
use mapkeeper_grid::{Point2, Pose2, wrap_angle};
use nalgebra::{Matrix3, Vector3};

/// The most buckets a [`PointGrid`] uses (the cell grows to stay under it).
const MAX_BUCKETS: usize = 1 << 20;

/// Radius of the neighbourhood whose spread gives a target point's normal, metres.
const NORMAL_RADIUS_M: f64 = 0.15;

/// Target points sorted into square buckets (compressed rows: `starts[b]..starts[b+1]`).
#[derive(Clone, Debug, Default)]
pub struct PointGrid {
    x0: f64,
    y0: f64,
    cell_m: f64,
    width: usize,
    height: usize,
    starts: Vec<u32>,
    points: Vec<Point2>,
    normals: Vec<Point2>,
    scratch: Vec<u32>,
}

impl PointGrid {
    /// An empty grid.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of target points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether there is no target point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Heap bytes held (points, normals, buckets; reused from build to build).
    pub fn heap_bytes(&self) -> usize {
        (self.points.capacity() + self.normals.capacity()) * size_of::<Point2>()
            + (self.starts.capacity() + self.scratch.capacity()) * size_of::<u32>()
    }

    /// Rebuilds the grid over `points` (non-finite points are ignored) with buckets of about
    /// `cell_m` (a query radius up to `cell_m` looks at 3 × 3 buckets at most).
    pub fn build(&mut self, points: &[Point2], cell_m: f64) {
        self.points.clear();
        self.normals.clear();
        self.starts.clear();
        let finite = points.iter().filter(|p| p.is_finite());
        let (mut x0, mut y0, mut x1, mut y1) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in finite.clone() {
            x0 = x0.min(p.x);
            y0 = y0.min(p.y);
            x1 = x1.max(p.x);
            y1 = y1.max(p.y);
        }
        if !x0.is_finite() {
            self.width = 0;
            self.height = 0;
            return;
        }
        let mut cell = cell_m.max(1e-3);
        loop {
            let w = ((x1 - x0) / cell).floor() as usize + 1;
            let h = ((y1 - y0) / cell).floor() as usize + 1;
            if w.saturating_mul(h) <= MAX_BUCKETS {
                self.width = w;
                self.height = h;
                break;
            }
            cell *= 2.0;
        }
        (self.x0, self.y0, self.cell_m) = (x0, y0, cell);
        let n_buckets = self.width * self.height;
        self.starts.resize(n_buckets + 1, 0);
        self.scratch.clear();
        for p in finite.clone() {
            let b = self.bucket_of(*p);
            self.scratch.push(b as u32);
            self.starts[b + 1] += 1;
        }
        for b in 0..n_buckets {
            self.starts[b + 1] += self.starts[b];
        }
        self.points.resize(self.scratch.len(), Point2::default());
        let mut fill: Vec<u32> = self.starts[..n_buckets].to_vec();
        for (p, &b) in finite.zip(&self.scratch) {
            let slot = &mut fill[b as usize];
            self.points[*slot as usize] = *p;
            *slot += 1;
        }
        let radius = NORMAL_RADIUS_M.min(self.cell_m);
        self.normals.clear();
        for k in 0..self.points.len() {
            let n = self.estimate_normal(k, radius);
            self.normals.push(n);
        }
    }

    #[inline]
    fn bucket_of(&self, p: Point2) -> usize {
        let bx = (((p.x - self.x0) / self.cell_m).floor() as usize).min(self.width - 1);
        let by = (((p.y - self.y0) / self.cell_m).floor() as usize).min(self.height - 1);
        by * self.width + bx
    }

    /// The nearest target point closer than `max_m` to `p`, with its squared distance.
    #[inline]
    pub fn nearest(&self, p: Point2, max_m: f64) -> Option<(Point2, f64)> {
        self.nearest_index(p, max_m).map(|(k, d2)| (self.points[k], d2))
    }

    /// Unit normal of target point `k` from the spread of its neighbours within `radius_m`
    /// (zero when the neighbourhood is too small or not line-like).
    fn estimate_normal(&self, k: usize, radius_m: f64) -> Point2 {
        let p = self.points[k];
        let (mut n, mut sx, mut sy, mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        self.for_each_within(p, radius_m, |q| {
            n += 1.0;
            sx += q.x;
            sy += q.y;
            sxx += q.x * q.x;
            sxy += q.x * q.y;
            syy += q.y * q.y;
        });
        if n < 3.0 {
            return Point2::default();
        }
        let (mx, my) = (sx / n, sy / n);
        let (cxx, cxy, cyy) = (sxx / n - mx * mx, sxy / n - mx * my, syy / n - my * my);
        // Eigen-decomposition of the 2 × 2 covariance: the line direction is the major axis.
        let tr = cxx + cyy;
        let det = cxx * cyy - cxy * cxy;
        let disc = (tr * tr / 4.0 - det).max(0.0).sqrt();
        let (l_major, l_minor) = (tr / 2.0 + disc, tr / 2.0 - disc);
        if l_major <= 0.0 || l_minor > 0.25 * l_major {
            return Point2::default();
        }
        let angle = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
        Point2::new(-angle.sin(), angle.cos())
    }

    fn for_each_within(&self, p: Point2, r: f64, mut f: impl FnMut(Point2)) {
        let Some((bx0, bx1, by0, by1)) = self.bucket_range(p, r) else { return };
        let r2 = r * r;
        for by in by0..=by1 {
            let row = by * self.width;
            let (s, e) = (self.starts[row + bx0] as usize, self.starts[row + bx1 + 1] as usize);
            for q in &self.points[s..e] {
                if q.distance_sq(p) <= r2 {
                    f(*q);
                }
            }
        }
    }

    #[inline]
    fn bucket_range(&self, p: Point2, max_m: f64) -> Option<(usize, usize, usize, usize)> {
        if self.points.is_empty() || !p.is_finite() {
            return None;
        }
        let fx0 = ((p.x - max_m - self.x0) / self.cell_m).floor();
        let fx1 = ((p.x + max_m - self.x0) / self.cell_m).floor();
        let fy0 = ((p.y - max_m - self.y0) / self.cell_m).floor();
        let fy1 = ((p.y + max_m - self.y0) / self.cell_m).floor();
        if fx1 < 0.0 || fy1 < 0.0 || fx0 >= self.width as f64 || fy0 >= self.height as f64 {
            return None;
        }
        Some((
            fx0.max(0.0) as usize,
            (fx1 as usize).min(self.width - 1),
            fy0.max(0.0) as usize,
            (fy1 as usize).min(self.height - 1),
        ))
    }

    /// Index of the nearest target point closer than `max_m` to `p`, with its squared distance.
    /// Buckets are visited in square rings around `p`'s bucket, and the search stops as soon as
    /// no bucket further out can hold a closer point (exact, like a scan of every bucket within
    /// `max_m`).
    #[inline]
    pub fn nearest_index(&self, p: Point2, max_m: f64) -> Option<(usize, f64)> {
        let (bx0, bx1, by0, by1) = self.bucket_range(p, max_m)?;
        let mut best = max_m * max_m;
        let mut found = None;
        let scan = |row_start: usize, x0: usize, x1: usize, best: &mut f64, found: &mut Option<usize>| {
            let (s, e) = (self.starts[row_start + x0] as usize, self.starts[row_start + x1 + 1] as usize);
            for (k, q) in self.points[s..e].iter().enumerate() {
                let d = q.distance_sq(p);
                if d < *best {
                    *best = d;
                    *found = Some(s + k);
                }
            }
        };
        // The bucket of p, clamped into the searched rectangle (p may lie outside the grid).
        let fx = ((p.x - self.x0) / self.cell_m).floor();
        let fy = ((p.y - self.y0) / self.cell_m).floor();
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
                scan(by * self.width, x0, x1, &mut best, &mut found);
                if r == 0 {
                    break;
                }
            }
            if r > 0 {
                let (y0, y1) = (cy.saturating_sub(r - 1).max(by0), (cy + r - 1).min(by1));
                for by in y0..=y1 {
                    let row = by * self.width;
                    if cx >= r && cx - r >= bx0 {
                        scan(row, cx - r, cx - r, &mut best, &mut found);
                    }
                    if cx + r <= bx1 {
                        scan(row, cx + r, cx + r, &mut best, &mut found);
                    }
                }
            }
            // Every point of ring r + 1 is at least r cells from p when p lies in its bucket.
            if inside && found.is_some() {
                let reach = r as f64 * self.cell_m;
                if reach * reach >= best {
                    break;
                }
            }
        }
        found.map(|k| (k, best))
    }
}

/// How well a pose explains the source points.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Fitness {
    /// Inliers / source points.
    pub inlier_ratio: f64,
    /// Root mean square distance of the inliers to their nearest target point, metres.
    pub rmse_m: f64,
    /// Inlier count.
    pub inliers: usize,
    /// Source points.
    pub source_points: usize,
}

/// The outcome of one ICP run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcpRun {
    /// Final pose (source frame in the target frame).
    pub pose: Pose2,
    /// Iterations done.
    pub iterations: u32,
    /// Whether the convergence criteria were met.
    pub converged: bool,
}

/// Point-to-line ICP (Gauss–Newton on the distances along the target's normals, rotation
/// about the current pose's position): finds `pose` such that `pose · source[k]` lies on
/// `target`, starting at `init`. The correspondence distance shrinks from
/// `max_correspondence_m` by `correspondence_decay` per iteration down to
/// `min_correspondence_m`; converged when a step at the floor is below both convergence
/// thresholds.
pub fn icp(source: &[Point2], target: &PointGrid, init: Pose2, p: &PoseUpdatingParams) -> IcpRun {
    icp_from(source, target, init, p, p.max_correspondence_m, p.max_iterations).0
}

/// [`icp`] starting at correspondence distance `d_start` for at most `max_iterations`;
/// also returns the correspondence distance reached, to continue a run later.
pub fn icp_from(
    source: &[Point2],
    target: &PointGrid,
    init: Pose2,
    p: &PoseUpdatingParams,
    d_start: f64,
    max_iterations: u32,
) -> (IcpRun, f64) {
    let mut pose = init;
    let mut d_max = d_start;
    for it in 1..=max_iterations {
        let (h, g, n) = normal_equations(source, target, &pose, d_max);
        if n < 3 {
            return (IcpRun { pose, iterations: it, converged: false }, d_max);
        }
        // A little damping keeps a degenerate direction (corridor) from blowing up.
        let damped = h + Matrix3::identity() * (1e-6 * (h.trace() + 1.0));
        let Some(delta) = damped.cholesky().map(|c| c.solve(&(-g))) else {
            return (IcpRun { pose, iterations: it, converged: false }, d_max);
        };
        if !delta.iter().all(|v| v.is_finite()) {
            return (IcpRun { pose, iterations: it, converged: false }, d_max);
        }
        pose = Pose2::new(pose.x + delta[0], pose.y + delta[1], wrap_angle(pose.yaw + delta[2]));
        let at_floor = d_max <= p.min_correspondence_m;
        if at_floor
            && delta[0].hypot(delta[1]) < p.convergence_translation_m
            && delta[2].abs() < p.convergence_rotation_rad
        {
            return (IcpRun { pose, iterations: it, converged: true }, d_max);
        }
        d_max = (d_max * p.correspondence_decay).max(p.min_correspondence_m);
    }
    (IcpRun { pose, iterations: max_iterations, converged: false }, d_max)
}

/// Σ JᵀJ, Σ Jᵀr and the number of used correspondences for the point-to-line residuals at
/// `pose` (coordinates centred on the pose's position, so the result is the information of
/// (x, y, yaw) of the pose itself).
fn normal_equations(
    source: &[Point2],
    target: &PointGrid,
    pose: &Pose2,
    d_max: f64,
) -> (Matrix3<f64>, Vector3<f64>, usize) {
    let (s, c) = pose.yaw.sin_cos();
    let mut h = Matrix3::zeros();
    let mut g = Vector3::zeros();
    let mut n = 0usize;
    for a in source {
        let (rx, ry) = (c * a.x - s * a.y, s * a.x + c * a.y);
        let q = Point2::new(pose.x + rx, pose.y + ry);
        if let Some((k, _)) = target.nearest_index(q, d_max) {
            let (m, nrm) = (target.points[k], target.normals[k]);
            if nrm.x == 0.0 && nrm.y == 0.0 {
                continue;
            }
            let r = nrm.x * (q.x - m.x) + nrm.y * (q.y - m.y);
            let j = Vector3::new(nrm.x, nrm.y, -ry * nrm.x + rx * nrm.y);
            h += j * j.transpose();
            g += j * r;
            n += 1;
        }
    }
    (h, g, n)
}

/// Fitness of `pose` (point-to-point distances to the nearest target point within `inlier_m`)
/// and the point-to-line information matrix Σ JᵀJ of its inliers (for the covariance).
pub fn fitness(source: &[Point2], target: &PointGrid, pose: &Pose2, inlier_m: f64) -> (Fitness, Matrix3<f64>) {
    let (s, c) = pose.yaw.sin_cos();
    let (mut n, mut sum_sq) = (0usize, 0.0);
    for a in source {
        let q = Point2::new(pose.x + c * a.x - s * a.y, pose.y + s * a.x + c * a.y);
        if let Some((_, d2)) = target.nearest(q, inlier_m) {
            n += 1;
            sum_sq += d2;
        }
    }
    let (h, _, _) = normal_equations(source, target, pose, inlier_m);
    let fit = Fitness {
        inlier_ratio: if source.is_empty() { 0.0 } else { n as f64 / source.len() as f64 },
        rmse_m: if n == 0 { f64::INFINITY } else { (sum_sq / n as f64).sqrt() },
        inliers: n,
        source_points: source.len(),
    };
    (fit, h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_matches_brute_force() {
        let pts: Vec<Point2> =
            (0..200).map(|k| Point2::new((k as f64 * 0.37).sin() * 5.0, (k as f64 * 0.91).cos() * 3.0)).collect();
        let mut g = PointGrid::new();
        g.build(&pts, 0.5);
        for k in 0..100 {
            let q = Point2::new((k as f64 * 0.13).cos() * 6.0, (k as f64 * 0.29).sin() * 4.0);
            let brute = pts.iter().map(|p| p.distance_sq(q)).fold(f64::INFINITY, f64::min);
            match g.nearest(q, 0.5) {
                Some((_, d2)) => assert!((d2 - brute).abs() < 1e-12),
                None => assert!(brute >= 0.25),
            }
        }
    }

    #[test]
    fn recovers_rigid_motion_of_an_l_shape() {
        let mut target = Vec::new();
        for k in 0..100 {
            target.push(Point2::new(k as f64 * 0.05, 0.0));
            target.push(Point2::new(0.0, k as f64 * 0.04));
            target.push(Point2::new(5.0, k as f64 * 0.03));
        }
        let truth = Pose2::new(0.2, -0.15, 0.08);
        let source: Vec<Point2> = target.iter().map(|p| truth.inverse().transform_point(*p)).collect();
        let mut g = PointGrid::new();
        g.build(&target, 1.0);
        let run = icp(&source, &g, Pose2::IDENTITY, &PoseUpdatingParams::default());
        assert!(run.pose.distance(&truth) < 1e-3, "{:?}", run);
        assert!((run.pose.yaw - truth.yaw).abs() < 1e-3);
        let (f, _) = fitness(&source, &g, &run.pose, 0.05);
        assert!(f.inlier_ratio > 0.99 && f.rmse_m < 1e-3);
    }
}
