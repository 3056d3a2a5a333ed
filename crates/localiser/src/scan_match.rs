//! The scan-matching front end (this project's, off unless [`ScanMatchParams::enabled`]): before
//! the particles move, the scan is matched against the map around the pose the odometry
//! predicts, and the particles move by the *matched* increment instead of the odometry's.
//!
//! Why: a particle filter whose odometry noise is small enough for centimetre tracking cannot
//! absorb a wheel slip or an odometry that misses a reversal (0.2 m per step against the robot's
//! real motion on Freiburg 079); one whose noise is large enough is loose everywhere else. The
//! matcher takes the motion from the map wherever the scan pins it down and leaves the odometry
//! where it does not (the match is refused), so the filter keeps one small noise everywhere.
//!
//! The match (a correlative search, then a local refinement):
//!
//! 1. **Score**: each beam endpoint is scored by a Gaussian kernel `exp(−d² / 2σ²)` of its
//!    distance `d` to the nearest occupied cell (σ = `kernel_sigma_m`), so a beam that hits
//!    something the map does not hold costs nothing more than a miss; the pose's score is the
//!    mean over beams minus a prior `prior_weight · ½ (Δxy² / window_xy² + Δyaw² / window_yaw²)`
//!    on its distance from the prediction (ties along a corridor go to the odometry).
//! 2. **Search**: every cell offset within `window_xy_m` and every yaw within `window_yaw_rad` on
//!    a grid of [`COARSE_YAW_STEP_RAD`], nearest-cell distances.
//! 3. **Refine**: hill climbing from the best candidate on bilinearly interpolated distances, the
//!    steps halved down to 1/16 of a cell.
//! 4. **Accept** when at least `min_inlier_share` of the beams end within `inlier_m` of an
//!    occupied cell at the matched pose; otherwise the odometry stands.
//!
//! Everything is deterministic (no randomness; ties broken by search order).

use mapkeeper_grid::geometry::floor_exact;
use mapkeeper_grid::{DistanceField, OccupancyGrid, Pose2, wrap_angle};
use serde::{Deserialize, Serialize};

/// The coarse search's yaw step, radians (0.5°: a beam 6 m out moves by one 0.05 m cell).
pub const COARSE_YAW_STEP_RAD: f64 = 0.5 * std::f64::consts::PI / 180.0;
/// The refinement stops when its position step falls below this share of a cell.
const REFINE_MIN_STEP_CELLS: f64 = 1.0 / 16.0;
/// The refinement's evaluation budget (each evaluation scores every beam).
const REFINE_MAX_EVALUATIONS: usize = 300;

/// The scan-matching front end's parameters (`[scan_match]` in a localiser TOML).
///
/// ```
/// use mapkeeper_localiser::ScanMatchParams;
/// let p = ScanMatchParams::default();
/// assert!(!p.enabled && p.validate().is_ok());
/// assert!(ScanMatchParams { window_xy_m: -1.0, ..p }.validate().is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ScanMatchParams {
    /// Whether the particles move by the matched increment (when a match is accepted). Default
    /// false (every preset but `mapkeeper-real`).
    pub enabled: bool,
    /// Beams per lidar used by the match, evenly over the valid readings. Default 180.
    pub max_beams: usize,
    /// Half-width of the position search around the odometry's prediction, metres. Default 0.3.
    pub window_xy_m: f64,
    /// Half-width of the yaw search, radians. Default 0.1 (5.7°).
    pub window_yaw_rad: f64,
    /// σ of the beam score's Gaussian kernel, metres. Default 0.05.
    pub kernel_sigma_m: f64,
    /// A beam ending this close to an occupied cell is an inlier, metres. Default 0.1.
    pub inlier_m: f64,
    /// A match is accepted when at least this share of the beams are inliers. Default 0.5.
    pub min_inlier_share: f64,
    /// Weight of the prior towards the prediction (in mean-score units at the window's edge, per
    /// axis). Default 0.05.
    pub prior_weight: f64,
    /// The match runs only while the filter's position standard deviation `√(σx² + σy²)` is at
    /// most this, metres: a spread filter has no pose to match from. Default 0.5.
    pub max_position_sd_m: f64,
}

impl Default for ScanMatchParams {
    fn default() -> Self {
        Self {
            enabled: false,
            max_beams: 180,
            window_xy_m: 0.3,
            window_yaw_rad: 0.1,
            kernel_sigma_m: 0.05,
            inlier_m: 0.1,
            min_inlier_share: 0.5,
            prior_weight: 0.05,
            max_position_sd_m: 0.5,
        }
    }
}

impl ScanMatchParams {
    /// Checks every field: the first violation as `(field, value, requirement)`.
    pub fn validate(&self) -> Result<(), (&'static str, f64, &'static str)> {
        let checks: [(&'static str, f64, bool, &'static str); 8] = [
            ("scan_match.max_beams", self.max_beams as f64, (1..=100_000).contains(&self.max_beams), "1 to 100000"),
            ("scan_match.window_xy_m", self.window_xy_m, (0.0..=5.0).contains(&self.window_xy_m), "in [0, 5]"),
            ("scan_match.window_yaw_rad", self.window_yaw_rad, (0.0..=1.0).contains(&self.window_yaw_rad), "in [0, 1]"),
            ("scan_match.kernel_sigma_m", self.kernel_sigma_m, self.kernel_sigma_m > 0.0, "> 0"),
            ("scan_match.inlier_m", self.inlier_m, self.inlier_m > 0.0, "> 0"),
            (
                "scan_match.min_inlier_share",
                self.min_inlier_share,
                (0.0..=1.0).contains(&self.min_inlier_share),
                "in [0, 1]",
            ),
            ("scan_match.prior_weight", self.prior_weight, self.prior_weight >= 0.0, ">= 0"),
            ("scan_match.max_position_sd_m", self.max_position_sd_m, self.max_position_sd_m > 0.0, "> 0"),
        ];
        for (name, value, ok, requirement) in checks {
            if !(ok && value.is_finite()) {
                return Err((name, value, requirement));
            }
        }
        Ok(())
    }
}

/// What one match found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    /// The matched pose, map frame.
    pub pose_in_map: Pose2,
    /// Share of the beams ending within `inlier_m` of an occupied cell there.
    pub inlier_share: f64,
    /// Whether it passed `min_inlier_share`.
    pub accepted: bool,
}

/// The map's distance table for matching (metres to the nearest occupied cell, capped).
#[derive(Clone, Debug)]
pub struct ScanMatcher {
    width: usize,
    height: usize,
    resolution_m: f64,
    inv_resolution: f64,
    map_in_grid: Pose2,
    /// `sin_cos` of the grid's yaw in the map frame.
    grid_axes_sin_cos: (f64, f64),
    distances_m: Vec<f32>,
    /// The kernel of each cell's distance, for the coarse search.
    kernel: Vec<f32>,
    cap_m: f32,
    params: ScanMatchParams,
}

impl ScanMatcher {
    /// The table for `map` (one distance transform, capped at 4 σ + the inlier distance).
    pub fn new(map: &OccupancyGrid, params: ScanMatchParams) -> Self {
        let g = map.geometry();
        let cap = (4.0 * params.kernel_sigma_m + params.inlier_m).max(g.resolution_m());
        let df = DistanceField::to_occupied(map, cap);
        let distances_m = df.distances_m().to_vec();
        let s2 = 2.0 * params.kernel_sigma_m * params.kernel_sigma_m;
        let kernel = distances_m.iter().map(|&d| (-(d as f64 * d as f64) / s2).exp() as f32).collect();
        Self {
            width: g.width(),
            height: g.height(),
            resolution_m: g.resolution_m(),
            inv_resolution: 1.0 / g.resolution_m(),
            map_in_grid: g.origin().inverse(),
            grid_axes_sin_cos: g.origin().yaw.sin_cos(),
            distances_m,
            kernel,
            cap_m: df.max_distance_m(),
            params,
        }
    }

    /// Matches the beam endpoints `ends` (robot frame) around `predicted` (map frame). `None`
    /// without beams.
    pub fn match_scan(&self, predicted: &Pose2, ends: &[[f64; 2]]) -> Option<Match> {
        if ends.is_empty() {
            return None;
        }
        let coarse = self.coarse(predicted, ends);
        let pose = self.refine(predicted, coarse, ends);
        let inliers = self.inlier_share(&pose, ends);
        Some(Match { pose_in_map: pose, inlier_share: inliers, accepted: inliers >= self.params.min_inlier_share })
    }

    fn prior(&self, predicted: &Pose2, pose: &Pose2) -> f64 {
        let p = &self.params;
        let axis = |d: f64, w: f64| if w > 0.0 { (d / w) * (d / w) } else { 0.0 };
        let (dx, dy) = (pose.x - predicted.x, pose.y - predicted.y);
        let da = wrap_angle(pose.yaw - predicted.yaw);
        0.5 * p.prior_weight * (axis(dx, p.window_xy_m) + axis(dy, p.window_xy_m) + axis(da, p.window_yaw_rad))
    }

    /// The best pose of the coarse grid (cell steps in x, y; [`COARSE_YAW_STEP_RAD`] in yaw).
    fn coarse(&self, predicted: &Pose2, ends: &[[f64; 2]]) -> Pose2 {
        let p = &self.params;
        let cells = (p.window_xy_m * self.inv_resolution).round() as i64;
        let yaws = (p.window_yaw_rad / COARSE_YAW_STEP_RAD).round() as i64;
        let n = ends.len() as f64;
        let mut best = (f64::NEG_INFINITY, *predicted);
        let mut idx: Vec<(i64, i64)> = Vec::with_capacity(ends.len());
        for k in -yaws..=yaws {
            let yaw = wrap_angle(predicted.yaw + k as f64 * COARSE_YAW_STEP_RAD);
            let base = Pose2::new(predicted.x, predicted.y, yaw);
            let g = self.map_in_grid.compose(&base);
            let (s, c) = g.yaw.sin_cos();
            idx.clear();
            idx.extend(ends.iter().map(|&[ex, ey]| {
                let u = (g.x + c * ex - s * ey) * self.inv_resolution;
                let v = (g.y + s * ex + c * ey) * self.inv_resolution;
                (floor_i64(u), floor_i64(v))
            }));
            for j in -cells..=cells {
                for i in -cells..=cells {
                    let mut sum = 0.0f64;
                    for &(u, v) in &idx {
                        sum += self.kernel_at(u + i, v + j) as f64;
                    }
                    let (sx, sy) = self.cell_shift(i, j);
                    let pose = Pose2::new(predicted.x + sx, predicted.y + sy, yaw);
                    let score = sum / n - self.prior(predicted, &pose);
                    if score > best.0 {
                        best = (score, pose);
                    }
                }
            }
        }
        best.1
    }

    /// A shift of (i, j) cells along the grid's axes as a map-frame (x, y) shift (the grid may
    /// be rotated).
    fn cell_shift(&self, i: i64, j: i64) -> (f64, f64) {
        let (s, c) = self.grid_axes_sin_cos;
        let (i, j) = (i as f64 * self.resolution_m, j as f64 * self.resolution_m);
        (c * i - s * j, s * i + c * j)
    }

    fn kernel_at(&self, u: i64, v: i64) -> f32 {
        if (u as u64) < self.width as u64 && (v as u64) < self.height as u64 {
            self.kernel[v as usize * self.width + u as usize]
        } else {
            0.0
        }
    }

    fn distance_cell(&self, u: i64, v: i64) -> f64 {
        if (u as u64) < self.width as u64 && (v as u64) < self.height as u64 {
            self.distances_m[v as usize * self.width + u as usize] as f64
        } else {
            self.cap_m as f64
        }
    }

    /// The distance at a continuous grid position (cell units), bilinear between cell centres.
    fn distance_at(&self, u: f64, v: f64) -> f64 {
        let (u, v) = (u - 0.5, v - 0.5);
        let (u0, v0) = (floor_i64(u), floor_i64(v));
        let (fu, fv) = (u - u0 as f64, v - v0 as f64);
        let d00 = self.distance_cell(u0, v0);
        let d10 = self.distance_cell(u0 + 1, v0);
        let d01 = self.distance_cell(u0, v0 + 1);
        let d11 = self.distance_cell(u0 + 1, v0 + 1);
        (d00 * (1.0 - fu) + d10 * fu) * (1.0 - fv) + (d01 * (1.0 - fu) + d11 * fu) * fv
    }

    /// Calls `f` with each beam endpoint's interpolated distance at `pose`.
    fn for_each_distance(&self, pose: &Pose2, ends: &[[f64; 2]], mut f: impl FnMut(f64)) {
        let g = self.map_in_grid.compose(pose);
        let (s, c) = g.yaw.sin_cos();
        for &[ex, ey] in ends {
            let u = (g.x + c * ex - s * ey) * self.inv_resolution;
            let v = (g.y + s * ex + c * ey) * self.inv_resolution;
            f(self.distance_at(u, v));
        }
    }

    fn fine_score(&self, predicted: &Pose2, pose: &Pose2, ends: &[[f64; 2]]) -> f64 {
        let s2 = 2.0 * self.params.kernel_sigma_m * self.params.kernel_sigma_m;
        let mut sum = 0.0;
        self.for_each_distance(pose, ends, |d| sum += (-(d * d) / s2).exp());
        sum / ends.len() as f64 - self.prior(predicted, pose)
    }

    fn inlier_share(&self, pose: &Pose2, ends: &[[f64; 2]]) -> f64 {
        let mut inliers = 0usize;
        self.for_each_distance(pose, ends, |d| inliers += usize::from(d <= self.params.inlier_m));
        inliers as f64 / ends.len() as f64
    }

    /// Hill climbing on the interpolated score from `start`, steps halved when no neighbour is
    /// better.
    fn refine(&self, predicted: &Pose2, start: Pose2, ends: &[[f64; 2]]) -> Pose2 {
        let mut pose = start;
        let mut score = self.fine_score(predicted, &pose, ends);
        let (mut step_xy, mut step_yaw) = (0.5 * self.resolution_m, 0.5 * COARSE_YAW_STEP_RAD);
        let mut evaluations = 1;
        while step_xy >= REFINE_MIN_STEP_CELLS * self.resolution_m && evaluations < REFINE_MAX_EVALUATIONS {
            let mut improved = false;
            for (dx, dy, da) in [
                (step_xy, 0.0, 0.0),
                (-step_xy, 0.0, 0.0),
                (0.0, step_xy, 0.0),
                (0.0, -step_xy, 0.0),
                (0.0, 0.0, step_yaw),
                (0.0, 0.0, -step_yaw),
            ] {
                let cand = Pose2::new(pose.x + dx, pose.y + dy, wrap_angle(pose.yaw + da));
                let s = self.fine_score(predicted, &cand, ends);
                evaluations += 1;
                if s > score {
                    (pose, score, improved) = (cand, s, true);
                }
            }
            if !improved {
                step_xy *= 0.5;
                step_yaw *= 0.5;
            }
        }
        pose
    }
}

#[inline]
fn floor_i64(x: f64) -> i64 {
    if x.is_finite() { floor_exact(x) as i64 } else { i64::MIN / 2 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, CellState, GridGeometry, cast_ray};

    /// A 6 m × 4 m room with walls on the border and two boxes, 0.05 m cells.
    fn room() -> OccupancyGrid {
        let g = GridGeometry::new(120, 80, 0.05, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::walled(g);
        for (i0, j0) in [(40, 20), (80, 50)] {
            for i in i0..i0 + 6 {
                for j in j0..j0 + 4 {
                    m.set(CellCoord::new(i, j), CellState::Occupied);
                }
            }
        }
        m
    }

    fn ends_from(map: &OccupancyGrid, truth: &Pose2, n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .filter_map(|k| {
                let a = -std::f64::consts::PI + k as f64 * 2.0 * std::f64::consts::PI / n as f64;
                let r = cast_ray(map, truth.position(), truth.yaw + a, 10.0, true).range_m;
                (r < 10.0).then(|| [r * a.cos(), r * a.sin()])
            })
            .collect()
    }

    fn on() -> ScanMatchParams {
        ScanMatchParams { enabled: true, ..ScanMatchParams::default() }
    }

    #[test]
    fn finds_the_true_pose_from_a_prediction_off_by_most_of_the_window() {
        let map = room();
        let truth = Pose2::new(2.33, 1.71, 0.4);
        let ends = ends_from(&map, &truth, 360);
        let m = ScanMatcher::new(&map, on());
        for off in [Pose2::new(0.22, -0.17, 0.07), Pose2::new(-0.25, 0.1, -0.08), Pose2::new(0.0, 0.0, 0.0)] {
            let predicted = Pose2::new(truth.x + off.x, truth.y + off.y, truth.yaw + off.yaw);
            let r = m.match_scan(&predicted, &ends).unwrap();
            assert!(r.accepted && r.inlier_share > 0.95, "{r:?}");
            assert!(r.pose_in_map.distance(&truth) < 0.015, "{off:?}: {:?}", r.pose_in_map);
            assert!(wrap_angle(r.pose_in_map.yaw - truth.yaw).abs() < 0.005, "{off:?}: {:?}", r.pose_in_map);
        }
    }

    #[test]
    fn a_scan_that_fits_nothing_is_refused_and_no_beams_is_no_match() {
        let map = room();
        let m = ScanMatcher::new(&map, on());
        // Endpoints in open space, far from every wall.
        let ends: Vec<[f64; 2]> = (0..50).map(|k| [0.4 + 0.001 * k as f64, 0.0]).collect();
        let r = m.match_scan(&Pose2::new(3.0, 2.0, 0.0), &ends).unwrap();
        assert!(!r.accepted && r.inlier_share < 0.5, "{r:?}");
        assert!(m.match_scan(&Pose2::new(3.0, 2.0, 0.0), &[]).is_none());
    }

    #[test]
    fn a_rotated_map_origin_matches_too() {
        // The same room in a grid whose origin is rotated by 30°: the search steps follow the grid.
        let src = room();
        let origin = Pose2::new(1.0, -2.0, 30f64.to_radians());
        let g = GridGeometry::new(120, 80, 0.05, origin).unwrap();
        let mut map = OccupancyGrid::filled(g, CellState::Free);
        for (i, s) in src.cells().iter().enumerate() {
            map.set(src.geometry().coord(i), *s);
        }
        let truth_in_grid = Pose2::new(2.33, 1.71, 0.4);
        let truth = origin.compose(&truth_in_grid);
        let ends = ends_from(&src, &truth_in_grid, 360);
        let m = ScanMatcher::new(&map, on());
        let predicted = truth.compose(&Pose2::new(0.15, 0.12, -0.05));
        let r = m.match_scan(&predicted, &ends).unwrap();
        assert!(r.accepted && r.pose_in_map.distance(&truth) < 0.015, "{r:?} vs {truth:?}");
    }

    #[test]
    fn parameters_are_validated() {
        assert!(on().validate().is_ok());
        for bad in [
            ScanMatchParams { max_beams: 0, ..on() },
            ScanMatchParams { kernel_sigma_m: 0.0, ..on() },
            ScanMatchParams { min_inlier_share: 1.5, ..on() },
            ScanMatchParams { window_yaw_rad: f64::NAN, ..on() },
            ScanMatchParams { prior_weight: -0.1, ..on() },
        ] {
            let (name, _, _) = bad.validate().unwrap_err();
            assert!(name.starts_with("scan_match."), "{name}");
        }
    }
}
