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
//! 2. **Search**: every cell offset within the position window and every yaw within the yaw
//!    window on a grid of [`COARSE_YAW_STEP_RAD`], nearest-cell distances. The windows are
//!    `window_xy_m` and `window_yaw_rad`, widened where the odometry's travel since the last
//!    filter update could carry a larger error ([`ScanMatchParams::window_for`]: scans a metre
//!    apart, a half turn between two scans); the prior's scale is the same window.
//! 3. **Refine**: hill climbing from the best candidate on bilinearly interpolated distances, the
//!    steps halved down to 1/16 of a cell.
//! 4. **Accept** when at least `min_inlier_share` of the beams end within `inlier_m` of an
//!    occupied cell at the matched pose; otherwise the odometry stands.
//!
//! Everything is deterministic (no randomness; ties broken by search order).

use mapkeeper_common::ParamError;
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
    /// The position window grows to this many metres per metre the odometry travelled since the
    /// last filter update, where that exceeds `window_xy_m` (up to `max_window_xy_m`). Default 0
    /// (a fixed window).
    pub window_xy_per_m: f64,
    /// The yaw window grows to this many radians per metre travelled plus per radian turned by
    /// the odometry since the last filter update, where that exceeds `window_yaw_rad` (up to
    /// `max_window_yaw_rad`). Default 0 (a fixed window).
    pub window_yaw_per_motion: f64,
    /// The largest position window the growth reaches, metres (the search's cost grows with its
    /// square; below `window_xy_m` it only stops the growth). Default 1.
    pub max_window_xy_m: f64,
    /// The largest yaw window the growth reaches, radians. Default 0.5.
    pub max_window_yaw_rad: f64,
    /// A match accepted with fewer inliers than this is a weak fit, searched again as a refused
    /// or clipped one is (`refused_window_xy_per_m`). Default 0 (never).
    pub weak_inlier_share: f64,
    /// When the match in the window is refused, clipped by the window's edge or weak, search
    /// again in a position window of
    /// `window_xy_m` plus this many metres per metre the odometry travelled since the last
    /// update (up to `max_window_xy_m`): an odometry that missed a reversal errs by up to twice
    /// its travel. Default 0 (no second search).
    pub refused_window_xy_per_m: f64,
    /// The second search's match replaces an accepted first only if its inlier share is at least
    /// this much higher (a wider search finds more wrong fits: look-alike rooms); otherwise,
    /// where the two differ, half the particles move by each and the scans' likelihood decides.
    /// Default 0 (a second match at least as good replaces the first).
    pub refused_min_inlier_gain: f64,
    /// An accepted match moves the particles by the matched increment with the motion model's
    /// noise of an increment at most this long (metres; its turn likewise at most this many
    /// radians): a match pins the pose, so its error does not grow with the travel as the
    /// odometry's does. `None` (default): the noise of the whole increment.
    pub matched_noise_max_motion: Option<f64>,
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
            window_xy_per_m: 0.0,
            window_yaw_per_motion: 0.0,
            max_window_xy_m: 1.0,
            max_window_yaw_rad: 0.5,
            weak_inlier_share: 0.0,
            refused_window_xy_per_m: 0.0,
            refused_min_inlier_gain: 0.0,
            matched_noise_max_motion: None,
        }
    }
}

impl ScanMatchParams {
    /// Checks every field; the first violation is returned, its name `scan_match.…`.
    pub fn validate(&self) -> Result<(), ParamError> {
        let noise = self.matched_noise_max_motion.unwrap_or(1.0);
        let checks: [(&'static str, f64, bool, &'static str); 16] = [
            (
                "scan_match.max_beams",
                self.max_beams as f64,
                (1..=100_000).contains(&self.max_beams),
                "must be 1 to 100000",
            ),
            ("scan_match.window_xy_m", self.window_xy_m, (0.0..=5.0).contains(&self.window_xy_m), "must be in [0, 5]"),
            (
                "scan_match.window_yaw_rad",
                self.window_yaw_rad,
                (0.0..=1.0).contains(&self.window_yaw_rad),
                "must be in [0, 1]",
            ),
            ("scan_match.kernel_sigma_m", self.kernel_sigma_m, self.kernel_sigma_m > 0.0, "must be > 0"),
            ("scan_match.inlier_m", self.inlier_m, self.inlier_m > 0.0, "must be > 0"),
            (
                "scan_match.min_inlier_share",
                self.min_inlier_share,
                (0.0..=1.0).contains(&self.min_inlier_share),
                "must be in [0, 1]",
            ),
            ("scan_match.prior_weight", self.prior_weight, self.prior_weight >= 0.0, "must be >= 0"),
            ("scan_match.max_position_sd_m", self.max_position_sd_m, self.max_position_sd_m > 0.0, "must be > 0"),
            (
                "scan_match.window_xy_per_m",
                self.window_xy_per_m,
                (0.0..=5.0).contains(&self.window_xy_per_m),
                "must be in [0, 5]",
            ),
            (
                "scan_match.window_yaw_per_motion",
                self.window_yaw_per_motion,
                (0.0..=1.0).contains(&self.window_yaw_per_motion),
                "must be in [0, 1]",
            ),
            (
                "scan_match.max_window_xy_m",
                self.max_window_xy_m,
                self.max_window_xy_m > 0.0 && self.max_window_xy_m <= 5.0,
                "must be in (0, 5]",
            ),
            (
                "scan_match.max_window_yaw_rad",
                self.max_window_yaw_rad,
                self.max_window_yaw_rad > 0.0 && self.max_window_yaw_rad <= 1.0,
                "must be in (0, 1]",
            ),
            ("scan_match.matched_noise_max_motion", noise, noise > 0.0, "must be > 0 (or absent: no bound)"),
            (
                "scan_match.refused_window_xy_per_m",
                self.refused_window_xy_per_m,
                (0.0..=5.0).contains(&self.refused_window_xy_per_m),
                "must be in [0, 5]",
            ),
            (
                "scan_match.weak_inlier_share",
                self.weak_inlier_share,
                (0.0..=1.0).contains(&self.weak_inlier_share),
                "must be in [0, 1]",
            ),
            (
                "scan_match.refused_min_inlier_gain",
                self.refused_min_inlier_gain,
                (0.0..=1.0).contains(&self.refused_min_inlier_gain),
                "must be in [0, 1]",
            ),
        ];
        for (name, value, ok, requirement) in checks {
            if !(ok && value.is_finite()) {
                return Err(ParamError::new(name, value, requirement));
            }
        }
        Ok(())
    }
}

/// The half-widths of one match's search (and the prior's scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window {
    /// Position, metres.
    pub xy_m: f64,
    /// Yaw, radians.
    pub yaw_rad: f64,
}

impl ScanMatchParams {
    /// The window for a match after the odometry travelled `travel_m` and turned `turn_rad`
    /// since the last filter update: `window_xy_m` and `window_yaw_rad`, or the travel's share
    /// (`window_xy_per_m`, `window_yaw_per_motion`) where that is larger, at most
    /// `max_window_xy_m` and `max_window_yaw_rad` (never below the fixed window: a cap under it
    /// only stops the growth). Scans a few centimetres apart keep the fixed window; a metre of
    /// travel or a half turn between scans widens it.
    ///
    /// ```
    /// use mapkeeper_localiser::ScanMatchParams;
    /// let p = ScanMatchParams { window_yaw_per_motion: 0.12, ..ScanMatchParams::default() };
    /// assert_eq!(p.window_for(0.05, 0.0).yaw_rad, 0.1);
    /// assert!((p.window_for(1.0, 1.5).yaw_rad - 0.3).abs() < 1e-12);
    /// assert_eq!(p.window_for(1.0, 6.0).yaw_rad, 0.5, "capped");
    /// ```
    pub fn window_for(&self, travel_m: f64, turn_rad: f64) -> Window {
        let grown = |base: f64, k: f64, motion: f64, max: f64| {
            let w = k * motion;
            if w.is_finite() && w > base { w.min(max).max(base) } else { base }
        };
        Window {
            xy_m: grown(self.window_xy_m, self.window_xy_per_m, travel_m, self.max_window_xy_m),
            yaw_rad: grown(
                self.window_yaw_rad,
                self.window_yaw_per_motion,
                travel_m + turn_rad.abs(),
                self.max_window_yaw_rad,
            ),
        }
    }

    /// The window of the second search when the match in `first` (the window after `travel_m`)
    /// is refused: the position window `window_xy_m + refused_window_xy_per_m · travel`, at most
    /// `max_window_xy_m`, the yaw window as in `first`. `None` when it would be no wider.
    ///
    /// ```
    /// use mapkeeper_localiser::ScanMatchParams;
    /// let p = ScanMatchParams { refused_window_xy_per_m: 2.0, ..ScanMatchParams::default() };
    /// let first = p.window_for(0.25, 0.0);
    /// assert!((p.refused_window(0.25, first).unwrap().xy_m - 0.8).abs() < 1e-12);
    /// assert_eq!(p.refused_window(0.0, first), None);
    /// assert_eq!(ScanMatchParams::default().refused_window(0.25, first), None);
    /// ```
    pub fn refused_window(&self, travel_m: f64, first: Window) -> Option<Window> {
        let xy = (self.window_xy_m + self.refused_window_xy_per_m * travel_m).min(self.max_window_xy_m);
        (xy.is_finite() && xy > first.xy_m).then_some(Window { xy_m: xy, yaw_rad: first.yaw_rad })
    }

    /// The fixed window (`window_xy_m`, `window_yaw_rad`).
    pub fn base_window(&self) -> Window {
        Window { xy_m: self.window_xy_m, yaw_rad: self.window_yaw_rad }
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
    /// Whether the best pose of the search lies on its window's edge (within a cell or a yaw
    /// step): a best fit the window clipped, so the true pose may lie beyond it.
    pub at_edge: bool,
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
    /// The table for `map` (one distance transform, capped at [`ScanMatcher::cap_m`]).
    pub fn new(map: &OccupancyGrid, params: ScanMatchParams) -> Self {
        let cap = Self::cap_m(&params, map.geometry().resolution_m());
        Self::from_field(&DistanceField::to_occupied(map, cap), params)
    }

    /// The distance the table needs, metres: 4 σ + the inlier distance, at least a cell.
    pub fn cap_m(params: &ScanMatchParams, resolution_m: f64) -> f64 {
        (4.0 * params.kernel_sigma_m + params.inlier_m).max(resolution_m)
    }

    /// The table of a distance field made elsewhere (to scattered points rather than occupied
    /// cells: [`DistanceField::to_points`]), which should reach at least [`ScanMatcher::cap_m`].
    pub fn from_field(df: &DistanceField, params: ScanMatchParams) -> Self {
        let g = df.geometry();
        let distances_m = df.distances_m().to_vec();
        let s2 = 2.0 * params.kernel_sigma_m * params.kernel_sigma_m;
        // Most cells lie at the cap: their kernel is computed once.
        let cap = df.max_distance_m();
        let at_cap = (-(cap as f64 * cap as f64) / s2).exp() as f32;
        let kernel = distances_m
            .iter()
            .map(|&d| if d >= cap { at_cap } else { (-(d as f64 * d as f64) / s2).exp() as f32 })
            .collect();
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

    /// The map's cell size, metres.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// Matches the beam endpoints `ends` (robot frame) around `predicted` (map frame) within the
    /// fixed window ([`ScanMatchParams::base_window`]). `None` without beams.
    pub fn match_scan(&self, predicted: &Pose2, ends: &[[f64; 2]]) -> Option<Match> {
        self.match_scan_within(predicted, ends, self.params.base_window())
    }

    /// [`ScanMatcher::match_scan`] within `window` (from [`ScanMatchParams::window_for`]).
    pub fn match_scan_within(&self, predicted: &Pose2, ends: &[[f64; 2]], window: Window) -> Option<Match> {
        if ends.is_empty() {
            return None;
        }
        let coarse = self.coarse(predicted, ends, window);
        let pose = self.refine(predicted, coarse, ends, window);
        let inliers = self.inlier_share(&pose, ends);
        Some(Match {
            pose_in_map: pose,
            inlier_share: inliers,
            accepted: inliers >= self.params.min_inlier_share,
            at_edge: self.at_edge(predicted, &coarse, window),
        })
    }

    /// Whether `found` (the coarse search's best) lies within a cell or a yaw step of the edge
    /// of `window` around `predicted`, along the grid's axes (the search's square).
    fn at_edge(&self, predicted: &Pose2, found: &Pose2, w: Window) -> bool {
        let (s, c) = self.grid_axes_sin_cos;
        let (dx, dy) = (found.x - predicted.x, found.y - predicted.y);
        let (i, j) = (c * dx + s * dy, -s * dx + c * dy);
        let cells = (w.xy_m * self.inv_resolution).round() * self.resolution_m;
        let yaws = (w.yaw_rad / COARSE_YAW_STEP_RAD).round() * COARSE_YAW_STEP_RAD;
        let near = |d: f64, half: f64, step: f64| half > 0.0 && d.abs() >= half - 0.5 * step;
        near(i, cells, self.resolution_m)
            || near(j, cells, self.resolution_m)
            || near(wrap_angle(found.yaw - predicted.yaw), yaws, COARSE_YAW_STEP_RAD)
    }

    fn prior(&self, predicted: &Pose2, pose: &Pose2, w: Window) -> f64 {
        let axis = |d: f64, w: f64| if w > 0.0 { (d / w) * (d / w) } else { 0.0 };
        let (dx, dy) = (pose.x - predicted.x, pose.y - predicted.y);
        let da = wrap_angle(pose.yaw - predicted.yaw);
        0.5 * self.params.prior_weight * (axis(dx, w.xy_m) + axis(dy, w.xy_m) + axis(da, w.yaw_rad))
    }

    /// The best pose of the coarse grid (cell steps in x, y; [`COARSE_YAW_STEP_RAD`] in yaw).
    fn coarse(&self, predicted: &Pose2, ends: &[[f64; 2]], w: Window) -> Pose2 {
        let cells = (w.xy_m * self.inv_resolution).round() as i64;
        let yaws = (w.yaw_rad / COARSE_YAW_STEP_RAD).round() as i64;
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
                    let score = sum / n - self.prior(predicted, &pose, w);
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

    fn fine_score(&self, predicted: &Pose2, pose: &Pose2, ends: &[[f64; 2]], w: Window) -> f64 {
        let s2 = 2.0 * self.params.kernel_sigma_m * self.params.kernel_sigma_m;
        let mut sum = 0.0;
        self.for_each_distance(pose, ends, |d| sum += (-(d * d) / s2).exp());
        sum / ends.len() as f64 - self.prior(predicted, pose, w)
    }

    fn inlier_share(&self, pose: &Pose2, ends: &[[f64; 2]]) -> f64 {
        let mut inliers = 0usize;
        self.for_each_distance(pose, ends, |d| inliers += usize::from(d <= self.params.inlier_m));
        inliers as f64 / ends.len() as f64
    }

    /// Hill climbing on the interpolated score from `start`, steps halved when no neighbour is
    /// better.
    fn refine(&self, predicted: &Pose2, start: Pose2, ends: &[[f64; 2]], w: Window) -> Pose2 {
        let mut pose = start;
        let mut score = self.fine_score(predicted, &pose, ends, w);
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
                let s = self.fine_score(predicted, &cand, ends, w);
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
    use mapkeeper_grid::{CellState, GridGeometry, cast_ray};
    use mapkeeper_testkit::rooms::{fill_cells, walled_cells};

    /// A 6 m × 4 m room with walls on the border and two boxes, 0.05 m cells.
    fn room() -> OccupancyGrid {
        let mut m = walled_cells(120, 80, 0.05, Pose2::IDENTITY);
        for (i0, j0) in [(40, 20), (80, 50)] {
            fill_cells(&mut m, i0..i0 + 6, j0..j0 + 4, CellState::Occupied);
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
    fn a_half_turn_between_scans_is_found_in_the_window_its_motion_opens_and_missed_in_the_fixed_one() {
        // Scans far apart: the odometry turned 3 rad since the last match and erred by 0.35 rad
        // (Intel's worst steps thinned to one scan a metre erred by 0.25 rad). From the fixed
        // ±0.1 rad window the refinement cannot climb back to the truth; the window the motion
        // opens (0.12 rad per metre plus radian: ±0.40 rad) holds it.
        let map = room();
        let truth = Pose2::new(2.33, 1.71, 0.4);
        let ends = ends_from(&map, &truth, 360);
        let p = ScanMatchParams { window_yaw_per_motion: 0.12, ..on() };
        let m = ScanMatcher::new(&map, p);
        let predicted = Pose2::new(truth.x + 0.05, truth.y - 0.04, truth.yaw + 0.35);
        let window = p.window_for(0.3, 3.0);
        assert!((window.yaw_rad - 0.396).abs() < 1e-12 && window.xy_m == 0.3, "{window:?}");
        let wide = m.match_scan_within(&predicted, &ends, window).unwrap();
        assert!(wide.accepted && wide.pose_in_map.distance(&truth) < 0.015, "{wide:?}");
        assert!(wrap_angle(wide.pose_in_map.yaw - truth.yaw).abs() < 0.005, "{wide:?}");
        let fixed = m.match_scan(&predicted, &ends).unwrap();
        let off = wrap_angle(fixed.pose_in_map.yaw - truth.yaw).abs();
        assert!(off > 0.05, "the fixed window cannot turn 0.35 rad back: {fixed:?}");
        // A few centimetres of motion keep the fixed window, whatever the factor.
        assert_eq!(p.window_for(0.05, 0.02), p.base_window());
        // The caps hold, and a non-finite motion keeps the fixed window.
        let big = ScanMatchParams { window_xy_per_m: 2.0, ..p };
        assert_eq!(big.window_for(10.0, 10.0), Window { xy_m: 1.0, yaw_rad: 0.5 });
        assert_eq!(big.window_for(f64::NAN, f64::INFINITY), big.base_window());
        // A cap below the fixed window (a parameter file from before the caps with a 2 m
        // window) only stops the growth: it never shrinks the window.
        let wide = ScanMatchParams { window_xy_m: 2.0, window_yaw_rad: 0.6, window_yaw_per_motion: 0.12, ..on() };
        assert!(wide.validate().is_ok());
        assert_eq!(wide.window_for(3.0, 3.0), Window { xy_m: 2.0, yaw_rad: 0.6 }, "the 0.5 rad cap stops the growth");
        let capped = ScanMatchParams { max_window_yaw_rad: 1.0, ..wide };
        assert!((capped.window_for(3.0, 3.0).yaw_rad - 0.72).abs() < 1e-12);
        assert_eq!(wide.window_for(0.1, 0.0), wide.base_window());
    }

    #[test]
    fn a_best_fit_the_window_clips_is_flagged_at_its_edge() {
        let map = room();
        let truth = Pose2::new(2.33, 1.71, 0.4);
        let ends = ends_from(&map, &truth, 360);
        let m = ScanMatcher::new(&map, on());
        // 0.05 m off: found inside the ±0.3 m window.
        let near = m.match_scan(&Pose2::new(truth.x + 0.05, truth.y, truth.yaw), &ends).unwrap();
        assert!(near.accepted && !near.at_edge, "{near:?}");
        // 0.45 m off along x: the search stops at the window's edge (the refinement may climb a
        // little further), and says so.
        let far = m.match_scan(&Pose2::new(truth.x + 0.45, truth.y, truth.yaw), &ends).unwrap();
        assert!(far.at_edge, "{far:?}");
        // The same in yaw: 0.25 rad off against a ±0.1 rad window.
        let turned = m.match_scan(&Pose2::new(truth.x, truth.y, truth.yaw + 0.25), &ends).unwrap();
        assert!(turned.at_edge, "{turned:?}");
        // A wider window holds the far one inside.
        let wide = m.match_scan_within(
            &Pose2::new(truth.x + 0.45, truth.y, truth.yaw),
            &ends,
            Window { xy_m: 0.8, yaw_rad: 0.1 },
        );
        let wide = wide.unwrap();
        assert!(wide.accepted && !wide.at_edge && wide.pose_in_map.distance(&truth) < 0.015, "{wide:?}");
    }

    #[test]
    fn parameters_are_validated() {
        assert!(on().validate().is_ok());
        assert!(
            ScanMatchParams { matched_noise_max_motion: Some(0.5), window_yaw_per_motion: 0.12, ..on() }
                .validate()
                .is_ok()
        );
        for bad in [
            ScanMatchParams { max_beams: 0, ..on() },
            ScanMatchParams { kernel_sigma_m: 0.0, ..on() },
            ScanMatchParams { min_inlier_share: 1.5, ..on() },
            ScanMatchParams { window_yaw_rad: f64::NAN, ..on() },
            ScanMatchParams { prior_weight: -0.1, ..on() },
            ScanMatchParams { window_xy_per_m: -1.0, ..on() },
            ScanMatchParams { window_yaw_per_motion: f64::INFINITY, ..on() },
            ScanMatchParams { max_window_xy_m: 0.0, ..on() },
            ScanMatchParams { max_window_yaw_rad: 2.0, ..on() },
            ScanMatchParams { matched_noise_max_motion: Some(0.0), ..on() },
            ScanMatchParams { matched_noise_max_motion: Some(f64::NAN), ..on() },
            ScanMatchParams { weak_inlier_share: 1.5, ..on() },
            ScanMatchParams { refused_window_xy_per_m: -0.5, ..on() },
            ScanMatchParams { refused_min_inlier_gain: f64::NAN, ..on() },
        ] {
            let e = bad.validate().unwrap_err();
            assert!(e.name.starts_with("scan_match.") && e.requirement.starts_with("must be "), "{e}");
        }
    }
}
