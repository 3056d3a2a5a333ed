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
use mapkeeper_grid::buckets::PointBuckets;
use mapkeeper_grid::{Point2, Pose2, wrap_angle};
use nalgebra::{Matrix3, Vector3};

/// The most buckets a [`PointGrid`] uses (the cell grows to stay under it).
const MAX_BUCKETS: usize = 1 << 20;

/// Radius of the neighbourhood whose spread gives a target point's normal, metres.
const NORMAL_RADIUS_M: f64 = 0.15;

/// Target points sorted into square buckets ([`PointBuckets`], compressed rows), with each
/// point's normal.
#[derive(Clone, Debug, Default)]
pub struct PointGrid {
    buckets: PointBuckets,
    /// Normal of `buckets.points()[k]`.
    normals: Vec<Point2>,
}

impl PointGrid {
    /// An empty grid.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of target points.
    pub fn len(&self) -> usize {
        self.buckets.len()
    }

    /// Whether there is no target point.
    pub fn is_empty(&self) -> bool {
        self.buckets.is_empty()
    }

    /// Heap bytes held (points, normals, buckets; reused from build to build).
    pub fn heap_bytes(&self) -> usize {
        self.buckets.heap_bytes() + self.normals.capacity() * size_of::<Point2>()
    }

    /// Rebuilds the grid over `points` (non-finite points are ignored) with buckets of about
    /// `cell_m` (a query radius up to `cell_m` looks at 3 × 3 buckets at most).
    pub fn build(&mut self, points: &[Point2], cell_m: f64) {
        self.normals.clear();
        // The bucket side doubles until the grid has at most MAX_BUCKETS buckets.
        self.buckets.rebuild(points, |lo, hi| {
            let mut cell = cell_m.max(1e-3);
            loop {
                let w = ((hi.x - lo.x) / cell).floor() as usize + 1;
                let h = ((hi.y - lo.y) / cell).floor() as usize + 1;
                if w.saturating_mul(h) <= MAX_BUCKETS {
                    return cell;
                }
                cell *= 2.0;
            }
        });
        let radius = NORMAL_RADIUS_M.min(self.buckets.side_m());
        for k in 0..self.buckets.len() {
            let n = self.estimate_normal(k, radius);
            self.normals.push(n);
        }
    }

    /// The nearest target point closer than `max_m` to `p`, with its squared distance.
    #[inline]
    pub fn nearest(&self, p: Point2, max_m: f64) -> Option<(Point2, f64)> {
        self.nearest_index(p, max_m).map(|(k, d2)| (self.buckets.points()[k], d2))
    }

    /// Unit normal of target point `k` from the spread of its neighbours within `radius_m`
    /// (zero when the neighbourhood is too small or not line-like).
    fn estimate_normal(&self, k: usize, radius_m: f64) -> Point2 {
        let p = self.buckets.points()[k];
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
        let Some(rect) = self.buckets.covering(p, r) else { return };
        let (r2, points) = (r * r, self.buckets.points());
        for s in self.buckets.rect_spans(rect) {
            for q in &points[s] {
                if q.distance_sq(p) <= r2 {
                    f(*q);
                }
            }
        }
    }

    /// Index of the nearest target point closer than `max_m` to `p`, with its squared distance
    /// (exact ring search, [`PointBuckets::nearest_within`]).
    #[inline]
    pub fn nearest_index(&self, p: Point2, max_m: f64) -> Option<(usize, f64)> {
        self.buckets.nearest_within(p, max_m)
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
            let (m, nrm) = (target.buckets.points()[k], target.normals[k]);
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
