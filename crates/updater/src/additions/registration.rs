//! Registration before writing (a `mapkeeper` addition, issue 27 item 1): before the classifier
//! and the cells update use a step's pose, refine it against `M_{i-1}` with the step's own scans,
//! and accept the refined pose only when the fit is good and unambiguous.
//!
//! Why: the paper writes the localiser's pose straight into the map. A yaw error of a fraction
//! of a degree, which AMCL on a stale map makes routinely, puts far hit points 5-15 cm off the
//! walls that produced them; the classifier's window (±v·Δθ) is narrower than that error, so fixed
//! walls and racks erode a cell at a time, and the eroded map is the next world's prior.
//!
//! How: the scan's end points (every lidar, with its mounting pose; an even subsample of the
//! valid beams) are scored against a distance field of the occupied cells of `M_{i-1}`. The
//! distance of a point is the bilinear interpolation of the cell-centre distance field minus half
//! a cell, floored at 0: a point anywhere inside an occupied cell fits exactly, so the fit pulls
//! no point towards cell centres. Yaw first: a 1-D search over ±`yaw_search_rad` at the given
//! position; then Gauss–Newton over (x, y, yaw) on the points within `truncate_m` of the map
//! (points on people, robots and changed items are left out by the truncation). The result is
//! accepted only if
//! - enough points were used ([`RegistrationParams::min_points`]);
//! - the fit is good: a share ≥ `min_inlier_share` of the points lies within `inlier_m`, with
//!   an RMSE ≤ `max_inlier_rmse_m` over those;
//! - the fit is unambiguous: the information of the inliers' surface normals in its weakest
//!   direction (x, y, and yaw scaled by the points' RMS range), per inlier, is at least
//!   `min_constraint` (a scan of one straight wall, or of a long bare aisle, constrains nothing
//!   along it);
//! - the correction is small: at most `max_shift_m` and `max_turn_rad` (a larger error is the
//!   localisation check's and pose updating's business, not a refinement's).
//!
//! When refused, the step writes nothing (the localisation check still runs at the given pose).
//! The refined pose is the updater's own: it never reaches the localiser.

use mapkeeper_common::ParamError;
use mapkeeper_grid::geometry::floor_exact;
use mapkeeper_grid::{CellState, DistanceField, GridGeometry, OccupancyGrid, Point2, Pose2, wrap_angle};
use mapkeeper_sensor::{BeamValidity, LaserScan};
use serde::{Deserialize, Serialize};

/// Parameters of registration before writing (`UpdaterParams::registration`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RegistrationParams {
    /// Refine each step's pose before classifying and writing. Default `false` (`mapkeeper`
    /// `true`).
    pub enabled: bool,
    /// End points used per step, evenly over the valid beams of all lidars. Default 240.
    pub max_points: u32,
    /// Fewest points (within `truncate_m` of the map after the fit) to accept. Default 40.
    pub min_points: u32,
    /// Half-width of the yaw search done first, radians. Default 3° (0.0524).
    pub yaw_search_rad: f64,
    /// Step of the yaw search, radians. Default 0.2° (0.00349).
    pub yaw_step_rad: f64,
    /// Points further than this from the map's surfaces are left out of the fit, metres.
    /// Default 0.25.
    pub truncate_m: f64,
    /// Gauss–Newton iterations at most. Default 12.
    pub iterations: u32,
    /// A point within this of the map's surfaces is an inlier, metres. Default 0.05.
    pub inlier_m: f64,
    /// Smallest accepted share of inliers among the points. Default 0.5.
    pub min_inlier_share: f64,
    /// Largest accepted RMSE over the inliers, metres. Default 0.03.
    pub max_inlier_rmse_m: f64,
    /// Smallest accepted information per inlier in the weakest direction (0..1). Default 0.08.
    pub min_constraint: f64,
    /// Largest accepted position correction, metres. Default 0.3.
    pub max_shift_m: f64,
    /// Largest accepted yaw correction, radians. Default 3° (0.0524).
    pub max_turn_rad: f64,
    /// Score each point by its distance to the nearest occupied cell's centre instead of to the
    /// cell's boundary (flat inside occupied cells). The boundary cost leaves the pose free by
    /// the thickness of the faces; the centre cost pins it to a fraction of a cell where many
    /// faces at different sub-cell offsets agree. Default `false` (not written when `false`).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub pull_to_centres: bool,
}

impl Default for RegistrationParams {
    fn default() -> Self {
        Self {
            enabled: false,
            max_points: 240,
            min_points: 40,
            yaw_search_rad: 3f64.to_radians(),
            yaw_step_rad: 0.2f64.to_radians(),
            truncate_m: 0.25,
            iterations: 12,
            inlier_m: 0.05,
            min_inlier_share: 0.5,
            max_inlier_rmse_m: 0.03,
            min_constraint: 0.08,
            max_shift_m: 0.3,
            max_turn_rad: 3f64.to_radians(),
            pull_to_centres: false,
        }
    }
}

impl RegistrationParams {
    /// Checks every field; the first bad one is named with its dotted name
    /// (`registration.…`).
    pub fn validate(&self) -> Result<(), ParamError> {
        for (name, v) in [
            ("registration.yaw_search_rad", self.yaw_search_rad),
            ("registration.max_shift_m", self.max_shift_m),
            ("registration.max_turn_rad", self.max_turn_rad),
            ("registration.min_constraint", self.min_constraint),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError::new(name, v, "must be finite and >= 0"));
            }
        }
        for (name, v) in [
            ("registration.yaw_step_rad", self.yaw_step_rad),
            ("registration.truncate_m", self.truncate_m),
            ("registration.inlier_m", self.inlier_m),
            ("registration.max_inlier_rmse_m", self.max_inlier_rmse_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ParamError::new(name, v, "must be finite and > 0"));
            }
        }
        if self.yaw_search_rad > 0.5 || self.yaw_search_rad / self.yaw_step_rad > 200.0 {
            return Err(ParamError::new(
                "registration.yaw_search_rad",
                format!("{} and {}", self.yaw_search_rad, self.yaw_step_rad),
                "must be at most 0.5 rad and 200 steps of yaw_step_rad each side",
            ));
        }
        if !(0.0..=1.0).contains(&self.min_inlier_share) {
            return Err(ParamError::new("registration.min_inlier_share", self.min_inlier_share, "must lie in [0, 1]"));
        }
        if !(1..=100_000).contains(&self.max_points) || self.min_points > self.max_points {
            return Err(ParamError::new(
                "registration.max_points",
                format!("{} and {}", self.max_points, self.min_points),
                "must lie in 1..=100000 and be >= min_points",
            ));
        }
        if !(1..=200).contains(&self.iterations) {
            return Err(ParamError::new("registration.iterations", self.iterations, "must lie in 1..=200"));
        }
        Ok(())
    }
}

/// Why a refinement was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Refusal {
    /// Fewer than `min_points` end points near the map's surfaces.
    TooFewPoints,
    /// Too few inliers, or their RMSE too large.
    PoorFit,
    /// The inliers leave a direction unconstrained (one wall, a bare aisle).
    Degenerate,
    /// The correction exceeds `max_shift_m` or `max_turn_rad`.
    TooFar,
}

/// What registration did with one step's pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Registration {
    /// The refined pose (the given pose when refused).
    pub pose: Pose2,
    /// `None`: accepted; otherwise why it was refused.
    pub refused: Option<Refusal>,
    /// Position correction, metres (of the fit, even when refused).
    pub shift_m: f64,
    /// Yaw correction, radians (signed).
    pub turn_rad: f64,
    /// Share of the points within `inlier_m` after the fit.
    pub inlier_share: f64,
    /// RMSE over the inliers, metres.
    pub rmse_m: f64,
    /// Information per inlier in the weakest direction.
    pub constraint: f64,
    /// One-sigma yaw uncertainty of the fit, radians (from the inliers' normals and RMSE).
    pub yaw_sigma_rad: f64,
    /// One-sigma position uncertainty of the fit, metres (the larger of x and y).
    pub xy_sigma_m: f64,
}

impl Registration {
    /// Whether the refined pose was accepted.
    pub fn accepted(&self) -> bool {
        self.refused.is_none()
    }
}

/// The distance field of `M_{i-1}`'s occupied cells and the per-step scratch.
#[derive(Clone, Debug)]
pub struct Registrar {
    /// Cells subtracted from the cell-centre distance: ½ (the boundary cost) or 0 (centres).
    inside_cells: f64,
    geometry: GridGeometry,
    /// Cell-centre distance to the nearest occupied cell, in cells, capped.
    dist_cells: Vec<f32>,
    cap_cells: f32,
    /// sin and cos of the grid origin's yaw (grid gradients to the map frame).
    origin_sin_cos: (f64, f64),
    /// End points of the step in the robot frame.
    points: Vec<Point2>,
}

/// One evaluation of a point for judging a fit: boundary distance (metres) and the normal.
#[derive(Clone, Copy, Debug)]
struct Sample {
    d_m: f64,
    /// Gradient of the cell-centre field, normalised (the surface normal), for the constraint.
    nx: f64,
    ny: f64,
}

impl Registrar {
    /// A registrar for `base` = `M_{i-1}`; distances are kept up to `truncate_m` + 2 cells.
    pub fn new(base: &OccupancyGrid, p: &RegistrationParams) -> Self {
        let g = *base.geometry();
        let r = g.resolution_m();
        let cap_m = p.truncate_m + 2.0 * r;
        let field = DistanceField::from_sites(&g, cap_m, |i| base.cells()[i] == CellState::Occupied);
        let dist_cells = field.distances_m().iter().map(|&d| d / r as f32).collect();
        Self {
            inside_cells: if p.pull_to_centres { 0.0 } else { 0.5 },
            geometry: g,
            dist_cells,
            cap_cells: (cap_m / r) as f32,
            origin_sin_cos: g.origin().yaw.sin_cos(),
            points: Vec::new(),
        }
    }

    /// Heap bytes of the distance field (one `f32` per cell of `M_{i-1}`).
    pub fn cache_bytes(&self) -> usize {
        self.dist_cells.capacity() * size_of::<f32>()
    }

    /// Heap bytes of the per-step scratch.
    pub fn scratch_bytes(&self) -> usize {
        self.points.capacity() * size_of::<Point2>()
    }

    /// The cell-centre distance (cells) at integer cell (x, y); the cap outside the grid.
    #[inline]
    fn at(&self, x: i64, y: i64) -> f64 {
        let (w, h) = (self.geometry.width() as i64, self.geometry.height() as i64);
        if x < 0 || y < 0 || x >= w || y >= h {
            return f64::from(self.cap_cells);
        }
        f64::from(self.dist_cells[(y * w + x) as usize])
    }

    /// The four cell-centre distances around a map-frame point and the point's offsets from
    /// the lower-left one; `None` for a non-finite or absurdly far point.
    #[inline]
    fn corners(&self, p: Point2) -> Option<([f64; 4], f64, f64)> {
        let (u, v) = self.geometry.world_to_grid(p);
        // Cell centres sit at integer + 0.5.
        let (fu, fv) = (u - 0.5, v - 0.5);
        if !(fu.is_finite() && fv.is_finite()) || fu.abs() > 1e9 || fv.abs() > 1e9 {
            return None;
        }
        // |fu|, |fv| ≤ 1e9: the floors are exact integers in i64.
        let (x0, y0) = (floor_exact(fu) as i64, floor_exact(fv) as i64);
        let (a, b) = (fu - x0 as f64, fv - y0 as f64);
        let (w, h) = (self.geometry.width() as i64, self.geometry.height() as i64);
        if x0 >= 0 && y0 >= 0 && x0 + 1 < w && y0 + 1 < h {
            // All four inside: one index, no per-corner bounds tests.
            let i = (y0 * w + x0) as usize;
            let d = |k: usize| self.dist_cells.get(k).map_or(f64::from(self.cap_cells), |&v| f64::from(v));
            let up = i + w as usize;
            return Some(([d(i), d(i + 1), d(up), d(up + 1)], a, b));
        }
        Some(([self.at(x0, y0), self.at(x0 + 1, y0), self.at(x0, y0 + 1), self.at(x0 + 1, y0 + 1)], a, b))
    }

    /// The boundary distance alone (what [`Registrar::sample`] gives as `d_m`), metres.
    #[inline]
    fn distance_m(&self, p: Point2) -> f64 {
        let Some(([d00, d10, d01, d11], a, b)) = self.corners(p) else { return f64::INFINITY };
        let d = d00 * (1.0 - a) * (1.0 - b) + d10 * a * (1.0 - b) + d01 * (1.0 - a) * b + d11 * a * b;
        (d - self.inside_cells).max(0.0) * self.geometry.resolution_m()
    }

    /// The interpolated cell-centre distance (cells) at a map-frame point and its gradient in
    /// the map frame (cells per cell); `None` where [`Registrar::corners`] has none.
    #[inline]
    fn field_at(&self, p: Point2) -> Option<(f64, f64, f64)> {
        let ([d00, d10, d01, d11], a, b) = self.corners(p)?;
        let d = d00 * (1.0 - a) * (1.0 - b) + d10 * a * (1.0 - b) + d01 * (1.0 - a) * b + d11 * a * b;
        // Gradient in grid units, then rotated into the map frame.
        let du = (d10 - d00) * (1.0 - b) + (d11 - d01) * b;
        let dv = (d01 - d00) * (1.0 - a) + (d11 - d10) * a;
        let (sin, cos) = self.origin_sin_cos;
        Some((d, cos * du - sin * dv, sin * du + cos * dv))
    }

    /// The boundary distance (metres) and its map-frame gradient (zero where the distance is
    /// 0): [`Registrar::sample`]'s `d_m`, `gx` and `gy`, without the normal's `hypot`.
    #[inline]
    fn distance_and_gradient(&self, p: Point2) -> (f64, f64, f64) {
        match self.field_at(p) {
            Some((d, wx, wy)) => self.boundary(d, wx, wy),
            None => (f64::INFINITY, 0.0, 0.0),
        }
    }

    /// From the field's value and gradient: the boundary distance, half a cell less than the
    /// cell-centre distance and floored at 0 (flat inside occupied cells), in metres, and its
    /// gradient.
    #[inline(always)]
    fn boundary(&self, d: f64, wx: f64, wy: f64) -> (f64, f64, f64) {
        let boundary = (d - self.inside_cells).max(0.0);
        let (gx, gy) = if boundary > 0.0 { (wx, wy) } else { (0.0, 0.0) };
        (boundary * self.geometry.resolution_m(), gx, gy)
    }

    /// Bilinear sample at a map-frame point, with the normal.
    #[inline]
    fn sample(&self, p: Point2) -> Sample {
        let Some((d, wx, wy)) = self.field_at(p) else {
            return Sample { d_m: f64::INFINITY, nx: 0.0, ny: 0.0 };
        };
        let norm = wx.hypot(wy);
        let (nx, ny) = if norm > 1e-9 { (wx / norm, wy / norm) } else { (0.0, 0.0) };
        let (d_m, _, _) = self.boundary(d, wx, wy);
        Sample { d_m, nx, ny }
    }

    /// Collects the step's end points in the robot frame (an even subsample of the valid beams
    /// below `max_range_m`).
    fn collect(&mut self, scans: &[LaserScan], max_range_m: f64, max_points: usize) {
        self.points.clear();
        let valid =
            |s: &LaserScan, i: usize| s.validity(i) == BeamValidity::Valid && f64::from(s.ranges_m[i]) < max_range_m;
        let total: usize =
            scans.iter().filter(|s| s.validate().is_ok()).map(|s| (0..s.len()).filter(|&i| valid(s, i)).count()).sum();
        if total == 0 {
            return;
        }
        let stride = total.div_ceil(max_points.max(1)).max(1);
        let mut k = 0usize;
        for s in scans.iter().filter(|s| s.validate().is_ok()) {
            for i in 0..s.len() {
                if !valid(s, i) {
                    continue;
                }
                if k.is_multiple_of(stride) {
                    let (a, r) = (s.beam_angle(i as f64), f64::from(s.ranges_m[i]));
                    self.points.push(s.lidar_in_robot.transform_point(Point2::new(r * a.cos(), r * a.sin())));
                }
                k += 1;
            }
        }
    }

    /// The truncated squared cost of the points at `pose` (the sum of
    /// `min(distance², truncate_m²)` in the points' order) if it is below `bound`, else `None`:
    /// the terms are never negative, so the running sum only grows and stops once it reaches
    /// `bound` (the same sum, term for term, when it does not).
    fn cost_below(&self, pose: Pose2, truncate_m: f64, bound: f64) -> Option<f64> {
        let c2 = truncate_m * truncate_m;
        let t = pose.prepare();
        let mut sum = 0.0f64;
        for e in &self.points {
            sum += self.distance_m(t.transform_point(*e)).powi(2).min(c2);
            if sum >= bound {
                return None;
            }
        }
        Some(sum)
    }

    /// The best yaw of the 1-D search at the given position (ties: the smallest offset).
    fn yaw_search(&self, given: Pose2, p: &RegistrationParams) -> Pose2 {
        let n = (p.yaw_search_rad / p.yaw_step_rad).floor() as i64;
        // Every term is at most truncate_m², so the given pose's cost is always below +∞.
        let mut best = (self.cost_below(given, p.truncate_m, f64::INFINITY).unwrap_or(f64::INFINITY), given);
        for k in (1..=n).flat_map(|k| [k, -k]) {
            let cand = Pose2::new(given.x, given.y, given.yaw + k as f64 * p.yaw_step_rad);
            // Only a strictly lower cost replaces the best, so a candidate may stop counting
            // once it reaches the best's.
            if let Some(c) = self.cost_below(cand, p.truncate_m, best.0) {
                best = (c, cand);
            }
        }
        best.1
    }

    /// Gauss–Newton over (x, y, yaw) on the points within `truncate_m`.
    fn refine(&self, start: Pose2, p: &RegistrationParams) -> Pose2 {
        let mut pose = start;
        for _ in 0..p.iterations {
            let (mut h, mut b) = ([[0.0f64; 3]; 3], [0.0f64; 3]);
            let t = pose.prepare();
            let (sin, cos) = t.sin_cos();
            for e in &self.points {
                let (d_m, gx, gy) = self.distance_and_gradient(t.transform_point(*e));
                if !(d_m > 0.0 && d_m <= p.truncate_m) {
                    continue;
                }
                // d_m = r · boundary(u, v) with u, v in cells: per metre, the grid gradient.
                let (dqx, dqy) = (-sin * e.x - cos * e.y, cos * e.x - sin * e.y);
                let j = [gx, gy, gx * dqx + gy * dqy];
                for (row, &jr) in h.iter_mut().zip(&j) {
                    for (cell, &jc) in row.iter_mut().zip(&j) {
                        *cell += jr * jc;
                    }
                }
                for (bk, &jk) in b.iter_mut().zip(&j) {
                    *bk += jk * d_m;
                }
            }
            // A little damping keeps a near-singular step bounded.
            let trace = h[0][0] + h[1][1] + h[2][2];
            for (k, row) in h.iter_mut().enumerate() {
                row[k] += 1e-6 * trace + 1e-12;
            }
            let Some(delta) = solve3(&h, &b) else { break };
            pose = Pose2::new(pose.x - delta[0], pose.y - delta[1], pose.yaw - delta[2]);
            if delta[0].hypot(delta[1]) < 1e-5 && delta[2].abs() < 1e-6 {
                break;
            }
        }
        pose
    }

    /// Refines `given` (the robot's pose in the map) with `scans`; see the module docs.
    pub fn register(
        &mut self,
        given: Pose2,
        scans: &[LaserScan],
        max_range_m: f64,
        p: &RegistrationParams,
    ) -> Registration {
        let refused = |why| Registration {
            pose: given,
            refused: Some(why),
            shift_m: 0.0,
            turn_rad: 0.0,
            inlier_share: 0.0,
            rmse_m: 0.0,
            constraint: 0.0,
            yaw_sigma_rad: f64::INFINITY,
            xy_sigma_m: f64::INFINITY,
        };
        if !given.is_finite() {
            return refused(Refusal::TooFewPoints);
        }
        self.collect(scans, max_range_m, p.max_points as usize);
        if self.points.len() < p.min_points as usize {
            return refused(Refusal::TooFewPoints);
        }
        let pose = self.refine(self.yaw_search(given, p), p);
        let mut r = self.judge(pose, p);
        r.shift_m = pose.position().distance(given.position());
        r.turn_rad = wrap_angle(pose.yaw - given.yaw);
        r.refused = r
            .refused
            .or_else(|| (r.shift_m > p.max_shift_m || r.turn_rad.abs() > p.max_turn_rad).then_some(Refusal::TooFar));
        if r.refused.is_some() {
            r.pose = given;
        }
        r
    }

    /// The quality of the fit at `pose`: inliers, RMSE, the weakest constraint, the yaw sigma.
    fn judge(&self, pose: Pose2, p: &RegistrationParams) -> Registration {
        let (mut used, mut inliers, mut sq) = (0usize, 0usize, 0.0f64);
        let mut info = [[0.0f64; 3]; 3];
        let mut range_sq = 0.0;
        let t = pose.prepare();
        let (sin, cos) = t.sin_cos();
        for e in &self.points {
            let s = self.sample(t.transform_point(*e));
            if s.d_m > p.truncate_m {
                continue;
            }
            used += 1;
            if s.d_m <= p.inlier_m {
                inliers += 1;
                sq += s.d_m * s.d_m;
                let (dqx, dqy) = (-sin * e.x - cos * e.y, cos * e.x - sin * e.y);
                let j = [s.nx, s.ny, s.nx * dqx + s.ny * dqy];
                for (row, &jr) in info.iter_mut().zip(&j) {
                    for (cell, &jc) in row.iter_mut().zip(&j) {
                        *cell += jr * jc;
                    }
                }
                range_sq += e.x * e.x + e.y * e.y;
            }
        }
        let n = self.points.len() as f64;
        let inlier_share = inliers as f64 / n;
        let rmse_m = if inliers > 0 { (sq / inliers as f64).sqrt() } else { f64::INFINITY };
        // Yaw scaled by the inliers' RMS range, so that all three directions are in metres.
        let rho = if inliers > 0 { (range_sq / inliers as f64).sqrt().max(1e-3) } else { 1.0 };
        let mut scaled = info;
        for row in scaled.iter_mut() {
            row[2] /= rho;
        }
        for v in scaled[2].iter_mut() {
            *v /= rho;
        }
        let constraint = if inliers > 0 { min_eigenvalue_sym3(&scaled) / inliers as f64 } else { 0.0 };
        // Var(yaw) ≈ σ² (H⁻¹)_θθ with σ the per-point noise (at least a uniform cell's spread).
        let sigma = rmse_m.max(self.geometry.resolution_m() / 12f64.sqrt());
        let sd = |k| inverse_diag3(&info, k).map_or(f64::INFINITY, |v: f64| sigma * v.max(0.0).sqrt());
        let (yaw_sigma_rad, xy_sigma_m) = (sd(2), sd(0).max(sd(1)));
        let refused = if used < p.min_points as usize {
            Some(Refusal::TooFewPoints)
        } else if inlier_share < p.min_inlier_share || rmse_m > p.max_inlier_rmse_m {
            Some(Refusal::PoorFit)
        } else if constraint < p.min_constraint {
            Some(Refusal::Degenerate)
        } else {
            None
        };
        Registration {
            pose,
            refused,
            shift_m: 0.0,
            turn_rad: 0.0,
            inlier_share,
            rmse_m,
            constraint,
            yaw_sigma_rad,
            xy_sigma_m,
        }
    }
}

/// Solves the 3×3 system `h x = b` (Cramer's rule); `None` if singular.
fn solve3(h: &[[f64; 3]; 3], b: &[f64; 3]) -> Option<[f64; 3]> {
    let det = det3(h);
    if !(det.abs() > 1e-300 && det.is_finite()) {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = *h;
        for (row, &bk) in m.iter_mut().zip(b) {
            row[k] = bk;
        }
        *xk = det3(&m) / det;
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

fn det3(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Diagonal element `k` of the inverse of a symmetric 3×3 matrix; `None` if singular.
fn inverse_diag3(m: &[[f64; 3]; 3], k: usize) -> Option<f64> {
    let det = det3(m);
    if !(det.abs() > 1e-300 && det.is_finite()) {
        return None;
    }
    let (i, j) = ((k + 1) % 3, (k + 2) % 3);
    Some((m[i][i] * m[j][j] - m[i][j] * m[j][i]) / det)
}

/// Smallest eigenvalue of a symmetric 3×3 matrix (closed form, trigonometric).
fn min_eigenvalue_sym3(m: &[[f64; 3]; 3]) -> f64 {
    let p1 = m[0][1].powi(2) + m[0][2].powi(2) + m[1][2].powi(2);
    let q = (m[0][0] + m[1][1] + m[2][2]) / 3.0;
    if p1 <= 1e-300 {
        return m[0][0].min(m[1][1]).min(m[2][2]);
    }
    let p2 = (m[0][0] - q).powi(2) + (m[1][1] - q).powi(2) + (m[2][2] - q).powi(2) + 2.0 * p1;
    let p = (p2 / 6.0).sqrt();
    let mut b = *m;
    for (k, row) in b.iter_mut().enumerate() {
        for v in row.iter_mut() {
            *v /= p;
        }
        row[k] -= q / p;
    }
    let r = (det3(&b) / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    // The eigenvalues are q + 2p cos(phi + 2πk/3); the smallest is k = 1.
    q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos()
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, cast_ray};
    use mapkeeper_testkit::rooms::{fill_cells, walled_cells};

    /// A 10 m × 8 m room at 0.05 m with walls and a few boxes (no symmetry).
    fn room() -> OccupancyGrid {
        let mut m = walled_cells(200, 160, 0.05, Pose2::IDENTITY);
        for (x0, y0, w, h) in [(40, 30, 10, 6), (120, 100, 6, 14), (150, 30, 20, 4)] {
            fill_cells(&mut m, x0..x0 + w, y0..y0 + h, CellState::Occupied);
        }
        m
    }

    /// A 270° scan of `world` from `robot`, 0.5° apart.
    fn scan(world: &OccupancyGrid, robot: Pose2) -> LaserScan {
        let inc = 0.5f64.to_radians();
        let a0 = -135f64.to_radians();
        let ranges_m = (0..541)
            .map(|i| cast_ray(world, robot.position(), robot.yaw + a0 + i as f64 * inc, 30.0, true).range_m as f32)
            .collect();
        LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: a0,
            angle_increment_rad: inc,
            range_min_m: 0.05,
            range_max_m: 30.0,
            ranges_m,
            sweep: None,
        }
    }

    fn on() -> RegistrationParams {
        RegistrationParams { enabled: true, ..RegistrationParams::default() }
    }

    #[test]
    fn a_yawed_pose_is_brought_back() {
        let map = room();
        let truth = Pose2::new(5.0, 4.0, 0.3);
        let s = scan(&map, truth);
        let mut reg = Registrar::new(&map, &on());
        for (dx, dy, dyaw) in [(0.0, 0.0, 1.5f64), (0.04, -0.03, -2.0), (0.08, 0.05, 0.8), (0.0, 0.0, 0.0)] {
            let given = Pose2::new(truth.x + dx, truth.y + dy, truth.yaw + dyaw.to_radians());
            let r = reg.register(given, std::slice::from_ref(&s), f64::INFINITY, &on());
            assert!(r.accepted(), "{r:?}");
            assert!(r.pose.position().distance(truth.position()) < 0.02, "{r:?}");
            assert!(wrap_angle(r.pose.yaw - truth.yaw).abs() < 0.15f64.to_radians(), "{r:?}");
            assert!(r.yaw_sigma_rad.is_finite() && r.yaw_sigma_rad < 0.01, "{r:?}");
        }
    }

    #[test]
    fn one_straight_wall_is_refused_as_degenerate() {
        // A single long wall: nothing constrains the position along it.
        let g = GridGeometry::new(400, 100, 0.05, Pose2::IDENTITY).unwrap();
        let mut map = OccupancyGrid::filled(g, CellState::Free);
        for x in 0..400 {
            map.set(CellCoord::new(x, 10), CellState::Occupied);
        }
        let truth = Pose2::new(10.0, 2.0, 0.0);
        let mut s = scan(&map, truth);
        // Only the beams that see the wall (the rest reach the map's edge: "no return").
        for r in &mut s.ranges_m {
            if *r > 5.0 {
                *r = f32::INFINITY;
            }
        }
        let mut reg = Registrar::new(&map, &on());
        let r = reg.register(Pose2::new(10.05, 2.0, 0.005), &[s], f64::INFINITY, &on());
        assert_eq!(r.refused, Some(Refusal::Degenerate), "{r:?}");
        assert_eq!(r.pose, Pose2::new(10.05, 2.0, 0.005));
    }

    #[test]
    fn a_pose_far_off_or_a_scan_of_another_place_is_refused() {
        let map = room();
        let truth = Pose2::new(5.0, 4.0, 0.3);
        let s = scan(&map, truth);
        let mut reg = Registrar::new(&map, &on());
        // 0.6 m off: beyond what a refinement may correct.
        let r = reg.register(Pose2::new(5.6, 4.0, 0.3), std::slice::from_ref(&s), f64::INFINITY, &on());
        assert!(!r.accepted(), "{r:?}");
        // A scan with nothing of the map in it (every beam 1.1 m: a person-sized ring).
        let mut ring = s.clone();
        ring.ranges_m.iter_mut().for_each(|r| *r = 1.1);
        let r = reg.register(truth, &[ring], f64::INFINITY, &on());
        assert!(!r.accepted(), "{r:?}");
        // No valid beam at all.
        let mut none = s;
        none.ranges_m.iter_mut().for_each(|r| *r = f32::NAN);
        let r = reg.register(truth, &[none], f64::INFINITY, &on());
        assert_eq!(r.refused, Some(Refusal::TooFewPoints));
    }

    #[test]
    fn a_bounded_cost_is_the_cost_or_none() {
        // The yaw search's early stop: the same sum, bit for bit, below the bound; None at or
        // above it; including points near and beyond the grid's edges.
        let map = room();
        let truth = Pose2::new(5.0, 4.0, 0.3);
        let mut reg = Registrar::new(&map, &on());
        reg.collect(&[scan(&map, truth)], f64::INFINITY, 240);
        assert!(reg.points.len() > 100);
        let mut seen = (0, 0);
        for k in -40..=40 {
            let pose = Pose2::new(truth.x + 0.011 * k as f64, truth.y - 0.007 * k as f64, truth.yaw + 0.004 * k as f64);
            let t = pose.prepare();
            let full =
                reg.points.iter().fold(0.0f64, |s, e| s + reg.distance_m(t.transform_point(*e)).powi(2).min(0.0625));
            for bound in [full * 0.5, full, f64::from_bits(full.to_bits() + 1), full * 2.0, f64::INFINITY] {
                match reg.cost_below(pose, 0.25, bound) {
                    Some(c) => {
                        assert_eq!(c.to_bits(), full.to_bits(), "{pose:?} {bound}");
                        seen.0 += 1;
                    }
                    None => {
                        assert!(full >= bound, "{pose:?}: {full} < {bound} but stopped");
                        seen.1 += 1;
                    }
                }
            }
        }
        assert!(seen.0 > 0 && seen.1 > 0, "{seen:?}");
    }

    #[test]
    fn the_smallest_eigenvalue_is_right() {
        let m = [[4.0, 1.0, 0.0], [1.0, 3.0, 0.0], [0.0, 0.0, 0.5]];
        assert!((min_eigenvalue_sym3(&m) - 0.5).abs() < 1e-9);
        let m = [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]];
        assert!((min_eigenvalue_sym3(&m) - 1.0).abs() < 1e-9);
        assert!(
            (inverse_diag3(&[[2.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 8.0]], 2).unwrap() - 0.125).abs() < 1e-12
        );
    }

    #[test]
    fn validate_names_the_field() {
        let p = RegistrationParams { inlier_m: -1.0, ..on() };
        assert_eq!(p.validate().unwrap_err(), ParamError::new("registration.inlier_m", -1, "must be finite and > 0"));
        let p = RegistrationParams { min_points: 500, ..on() };
        assert_eq!(p.validate().unwrap_err().name, "registration.max_points");
        assert!(on().validate().is_ok());
    }
}
