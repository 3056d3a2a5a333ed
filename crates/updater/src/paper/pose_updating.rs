//! Pose updating (§4.6). When the localisation check says Lost, the expected point cloud
//! P_exp is ray-cast from the current `M_i` at the predicted pose (the last pose that passed
//! the check, moved on by odometry since), and the current scans' points P(k) are registered to
//! it with ICP from several initial hypotheses. If none of them gives an accepted pose, a
//! correlative search scores every pose of a wider window against the occupied cells of `M_i`
//! and its best distinct poses are registered in turn. Every candidate is checked against the
//! cloud expected from *its own* pose (so that what the map says should be visible from there
//! is what is compared). The best must pass a fitness gate (inlier ratio, RMSE) and must not be
//! ambiguous; otherwise the answer is "not recovered" — never a wrong pose silently.

use crate::paper::icp::{Fitness, PointGrid, fitness, icp_from};
use crate::params::PoseUpdatingParams;
use crate::support::chessboard::chessboard_distance;
use mapkeeper_grid::geometry::floor_exact;
use mapkeeper_grid::{CellState, OccupancyGrid, Point2, Pose2, RayStop, angle_diff, cast_ray, wrap_angle};
use mapkeeper_sensor::{BeamValidity, LaserScan};
use nalgebra::Matrix3;

/// ICP iterations every hypothesis gets before the best ones are refined.
const COARSE_ITERATIONS: u32 = 8;
/// Hypotheses iterated to convergence.
const REFINED_HYPOTHESES: usize = 6;
/// The coarse iterations of every hypothesis use every k-th source point.
const COARSE_POINT_STEP: usize = 3;
/// Distinct local hypotheses that are checked against their own expected cloud.
const CHECKED_LOCAL: usize = 3;
/// Starting correspondence distance when a candidate is registered to its own expected cloud,
/// metres (candidates are already close).
const CHECK_CORRESPONDENCE_M: f64 = 0.5;
/// Source points used by the correlative search (every k-th, k chosen to stay near this).
const SEARCH_POINTS: usize = 160;
/// Score of a cell at chessboard distance d (cells) from an occupied cell: `SCORE_MAX − d`.
const SCORE_MAX: u8 = 4;
/// Search peaks below this share of the highest possible score are not worth checking.
const MIN_SEARCH_SCORE: f64 = 0.3;

/// Largest translation step of the search used for the offsets, cells (2^40): more than the
/// 1e9 cells a scan point may lie off the map plus the largest map side, so a point shifted by
/// a non-zero multiple of it lands off the map, as with any larger step.
const MAX_STEP_CELLS: f64 = (1u64 << 40) as f64;

/// The window of the correlative search on a map of `res` metres per cell: the translation
/// step in whole cells (at least one), the steps each side in x and y, the yaw steps each side.
/// The steps are counted from the step as given, in f64; the step used for the offsets is capped
/// at [`MAX_STEP_CELLS`], which moves every point off any map as a larger step would, so
/// `tx · step` and the shifted cells stay within i64. (The fuzz target `updater_params` found
/// `search_step_m = 1e300` saturating the cast to i64: an overflow, or without overflow checks
/// 20001² positions where `validate()` had counted 3².)
fn search_window(p: &PoseUpdatingParams, res: f64) -> (i64, i64, i64) {
    let step_cells = (p.search_step_m / res).round().max(1.0);
    let n_t = ((p.search_radius_m / (step_cells * res)).floor() as i64).min(10_000);
    let n_yaw = ((p.search_yaw_rad / p.search_yaw_step_rad).floor() as i64).min(100_000);
    (step_cells.min(MAX_STEP_CELLS) as i64, n_t, n_yaw)
}

/// Best first: more inliers, then lower RMSE, then hypothesis order (stable sort).
fn sort_candidates(c: &mut [(Pose2, Fitness, f64, bool)]) {
    c.sort_by(|a, b| b.1.inlier_ratio.total_cmp(&a.1.inlier_ratio).then(a.1.rmse_m.total_cmp(&b.1.rmse_m)));
}

/// Result of pose updating.
#[derive(Clone, Debug, PartialEq)]
pub enum PoseRecovery {
    /// A pose that passed the fitness gate.
    Recovered {
        /// The robot's pose in the map.
        pose_in_map: Pose2,
        /// Covariance of (x, y, yaw), m² / m·rad / rad²: RMSE² · (Σ JᵀJ)⁻¹ over the inliers.
        covariance: [[f64; 3]; 3],
        /// Fit quality of the accepted pose.
        fitness: Fitness,
    },
    /// No trustworthy pose.
    NotRecovered {
        /// Why.
        reason: RecoveryFailure,
    },
}

/// Why pose updating gave up.
#[derive(Clone, Debug, PartialEq)]
pub enum RecoveryFailure {
    /// Too few scan points or expected points to register.
    TooFewPoints {
        /// Scan points available.
        source: usize,
        /// Expected points available.
        expected: usize,
    },
    /// The best hypothesis failed the fitness gate.
    PoorFit {
        /// Its fitness.
        best: Fitness,
    },
    /// Two distant poses fit about equally well.
    Ambiguous {
        /// The best pose.
        first: Pose2,
        /// A distant runner-up.
        second: Pose2,
    },
    /// The fit does not constrain all three degrees of freedom: its covariance is singular, or
    /// weak in a direction along which the scans fit as well (a corridor).
    Degenerate,
}

/// A fit whose covariance leaves the position more uncertain than this in its weakest
/// direction (σ, metres) is tested for sliding: the point-to-plane information sees only the
/// surfaces' normals, so a featureless corridor (every pose along it fits) and a pillar seen
/// from below (its face's ends fix the pose, its normals do not) both give σ of 10⁸ m. Good
/// fits have σ of millimetres.
const SLIDE_TEST_SIGMA_M: f64 = 0.5;
/// The slides tried along the weakest direction, each way, metres.
const SLIDES_M: [f64; 2] = [0.5, 1.0];

/// The largest eigenvalue of the covariance's position block and its unit eigenvector.
fn weakest_xy(c: &[[f64; 3]; 3]) -> (f64, Point2) {
    let (a, b, d) = (c[0][0], c[0][1], c[1][1]);
    let l = 0.5 * (a + d) + (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let v = if b.abs() > 1e-12 * (a.abs() + d.abs()) {
        Point2::new(l - d, b)
    } else if a >= d {
        Point2::new(1.0, 0.0)
    } else {
        Point2::new(0.0, 1.0)
    };
    let n = v.x.hypot(v.y);
    (l, Point2::new(v.x / n, v.y / n))
}

/// A candidate registered to the cloud expected from its own pose.
#[derive(Clone, Copy, Debug)]
struct Checked {
    pose: Pose2,
    fit: Fitness,
    info: Matrix3<f64>,
    /// What the ambiguity test compares: `fit`'s inlier ratio, plus the inlier ratios of other
    /// scans at this pose when there are (`recovery_views`: earlier views).
    evidence: f64,
    /// How many other scans `evidence` sums (0: the current ones alone).
    views: usize,
}

/// Pose updating with its reusable buffers.
#[derive(Clone, Debug, Default)]
pub struct PoseUpdater {
    source: Vec<Point2>,
    coarse_source: Vec<Point2>,
    expected: Vec<Point2>,
    grid: PointGrid,
    candidates: Vec<(Pose2, Fitness, f64, bool)>,
    check_cloud: Vec<Point2>,
    check_grid: PointGrid,
    checked: Vec<Checked>,
    score: Vec<u8>,
    cells: Vec<(i32, i32)>,
    peaks: Vec<(u32, Pose2)>,
}

/// Whether two poses are the same place for the ambiguity test.
fn distinct(a: &Pose2, b: &Pose2, p: &PoseUpdatingParams) -> bool {
    a.distance(b) > p.ambiguity_distance_m || angle_diff(a.yaw, b.yaw).abs() > p.ambiguity_rotation_rad
}

/// P_exp: the points the map says the scans' beams would hit from `robot_in_map` (rays start
/// at each lidar's position, unknown cells count as occupied, beams that reach the range limit
/// give no point).
fn cast_expected(
    map: &OccupancyGrid,
    robot_in_map: &Pose2,
    scans: &[LaserScan],
    max_range_m: f64,
    out: &mut Vec<Point2>,
) {
    out.clear();
    for scan in scans {
        if scan.validate().is_err() {
            continue;
        }
        let range_max = max_range_m.min(scan.range_max_m as f64);
        let lidar_in_map = scan.lidar_in_map(robot_in_map);
        for i in 0..scan.ranges_m.len() {
            let a = lidar_in_map.yaw + scan.beam_angle(i as f64);
            let e = cast_ray(map, lidar_in_map.position(), a, range_max, true);
            if matches!(e.stop, RayStop::Occupied | RayStop::Unknown) {
                let (s, c) = a.sin_cos();
                out.push(Point2::new(lidar_in_map.x + e.range_m * c, lidar_in_map.y + e.range_m * s));
            }
        }
    }
}

/// P_exp from `pose` cast into `cloud` and indexed in `grid` (cells of the correspondence
/// floor, at least 0.15 m); `false` when the cloud has fewer points than pose updating needs
/// (`grid` then holds an older cloud).
pub(crate) fn expected_grid(
    map: &OccupancyGrid,
    pose: &Pose2,
    scans: &[LaserScan],
    max_range_m: f64,
    p: &PoseUpdatingParams,
    cloud: &mut Vec<Point2>,
    grid: &mut PointGrid,
) -> bool {
    cast_expected(map, pose, scans, max_range_m, cloud);
    if cloud.len() < (p.min_points as usize).max(3) {
        return false;
    }
    grid.build(cloud, p.min_correspondence_m.max(0.15));
    true
}

impl PoseUpdater {
    /// Empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers `scans` (robot frame, via each lidar's mounting pose) to the cloud expected in
    /// `map` from `predicted_in_map`. Rays of the expected cloud start at each lidar's position
    /// and count unknown cells as occupied; beams beyond `max_range_m` are not used.
    pub fn recover(
        &mut self,
        map: &OccupancyGrid,
        predicted_in_map: Pose2,
        scans: &[LaserScan],
        max_range_m: f64,
        p: &PoseUpdatingParams,
    ) -> PoseRecovery {
        self.source.clear();
        let step = p.source_beam_step.max(1) as usize;
        for scan in scans {
            if scan.validate().is_err() {
                continue;
            }
            let range_max = max_range_m.min(scan.range_max_m as f64);
            let mut valid_k = 0usize;
            for (i, &r) in scan.ranges_m.iter().enumerate() {
                if scan.validity_of(r) == BeamValidity::Valid && (r as f64) < range_max {
                    if valid_k.is_multiple_of(step) {
                        let (s, c) = scan.beam_angle(i as f64).sin_cos();
                        let z = r as f64;
                        self.source.push(scan.lidar_in_robot.transform_point(Point2::new(z * c, z * s)));
                    }
                    valid_k += 1;
                }
            }
        }
        cast_expected(map, &predicted_in_map, scans, max_range_m, &mut self.expected);
        let min = p.min_points as usize;
        if self.source.len() < min.max(3) || self.expected.len() < min.max(3) {
            return PoseRecovery::NotRecovered {
                reason: RecoveryFailure::TooFewPoints { source: self.source.len(), expected: self.expected.len() },
            };
        }
        // 1. Hypotheses around the predicted pose, registered to the cloud expected from it
        //    (a few iterations on a subset of the points, then the best to convergence).
        self.grid.build(&self.expected, p.min_correspondence_m.max(0.15));
        self.coarse_source.clear();
        self.coarse_source.extend(self.source.iter().step_by(COARSE_POINT_STEP));
        self.candidates.clear();
        for &dyaw in &p.yaw_offsets_rad {
            for &dx in &p.position_offsets_m {
                for &dy in &p.position_offsets_m {
                    let init =
                        Pose2::new(predicted_in_map.x + dx, predicted_in_map.y + dy, predicted_in_map.yaw + dyaw);
                    let (run, d) =
                        icp_from(&self.coarse_source, &self.grid, init, p, p.max_correspondence_m, COARSE_ITERATIONS);
                    let (fit, _) = fitness(&self.coarse_source, &self.grid, &run.pose, p.inlier_distance_m);
                    self.candidates.push((run.pose, fit, d, run.converged));
                }
            }
        }
        // Coarse-to-fine: only the most promising hypotheses are iterated to convergence.
        sort_candidates(&mut self.candidates);
        for cand in self.candidates.iter_mut().take(REFINED_HYPOTHESES) {
            let rest = p.max_iterations.saturating_sub(COARSE_ITERATIONS).max(1);
            let (run, d) = icp_from(&self.source, &self.grid, cand.0, p, cand.2, rest);
            let (fit, _) = fitness(&self.source, &self.grid, &run.pose, p.inlier_distance_m);
            *cand = (run.pose, fit, d, run.converged);
        }
        self.candidates.truncate(REFINED_HYPOTHESES);
        sort_candidates(&mut self.candidates);
        // 2. The best distinct ones, checked against the cloud expected from their own pose.
        self.checked.clear();
        let mut picked: Vec<Pose2> = Vec::new();
        let local: Vec<Pose2> = self.candidates.iter().map(|c| c.0).collect();
        for pose in local {
            if picked.len() >= CHECKED_LOCAL {
                break;
            }
            if picked.iter().all(|q| distinct(q, &pose, p)) {
                picked.push(pose);
                self.check(map, pose, scans, max_range_m, p);
            }
        }
        let local_answer = self.decide(map, scans, max_range_m, p);
        if matches!(local_answer, PoseRecovery::Recovered { .. }) || p.search_radius_m <= 0.0 {
            return local_answer;
        }
        // 3. Correlative search over the wider window, its peaks checked the same way.
        self.search(map, predicted_in_map, p);
        let peaks: Vec<Pose2> = self.peaks.iter().map(|&(_, pose)| pose).collect();
        for pose in peaks {
            self.check(map, pose, scans, max_range_m, p);
        }
        self.decide(map, scans, max_range_m, p)
    }

    /// The scan points (robot frame) of the last [`PoseUpdater::recover`] call.
    pub fn source_points(&self) -> &[Point2] {
        &self.source
    }

    /// Checks poses found by another search (e.g. a global one) as pose updating checks its
    /// own: each is registered to the cloud expected from it with the points of the last
    /// [`PoseUpdater::recover`] call (which must have been given the same `scans`), and the best
    /// must pass the fitness gate and the ambiguity test of `p`.
    pub fn verify(
        &mut self,
        map: &OccupancyGrid,
        candidates: &[Pose2],
        scans: &[LaserScan],
        max_range_m: f64,
        p: &PoseUpdatingParams,
    ) -> PoseRecovery {
        self.verify_with(map, candidates, scans, max_range_m, p, |_| (0.0, 0))
    }

    /// [`PoseUpdater::verify`] with more evidence per candidate: `more(pose)` gives the sum of
    /// the inlier ratios of other scans at a checked candidate's pose and how many scans that is
    /// (the `mapkeeper` addition `recovery_views` scores earlier views there). Each scan's ratio
    /// is evidence of its own, so the ambiguity test compares the sums (current ratio plus the
    /// others'): a difference seen in one earlier view counts in full, not diluted by views that
    /// cannot tell the places apart. The gate takes the current ratio and the mean of all. With
    /// `more` giving no scans it is `verify`.
    pub fn verify_with(
        &mut self,
        map: &OccupancyGrid,
        candidates: &[Pose2],
        scans: &[LaserScan],
        max_range_m: f64,
        p: &PoseUpdatingParams,
        mut more: impl FnMut(Pose2) -> (f64, usize),
    ) -> PoseRecovery {
        self.checked.clear();
        if self.source.len() < (p.min_points as usize).max(3) {
            return PoseRecovery::NotRecovered {
                reason: RecoveryFailure::TooFewPoints { source: self.source.len(), expected: 0 },
            };
        }
        for &pose in candidates {
            self.check(map, pose, scans, max_range_m, p);
        }
        for c in &mut self.checked {
            let (ratios, views) = more(c.pose);
            if views > 0 {
                (c.evidence, c.views) = (c.fit.inlier_ratio + ratios, views);
            }
        }
        self.decide(map, scans, max_range_m, p)
    }

    /// The best distinct poses of the last check, best first (after [`PoseUpdater::verify`] or
    /// [`PoseUpdater::recover`]), at most `k`.
    pub fn ranked_poses(&self, k: usize, p: &PoseUpdatingParams) -> Vec<Pose2> {
        let mut out: Vec<Pose2> = Vec::with_capacity(k);
        for c in &self.checked {
            if out.len() >= k {
                break;
            }
            if out.iter().all(|q| distinct(q, &c.pose, p)) {
                out.push(c.pose);
            }
        }
        out
    }

    /// Heap bytes of the map-sized score grid of the correlative search: one byte per cell of
    /// `M_i`, allocated at the first search and reused (0 before any search).
    pub fn cache_bytes(&self) -> usize {
        self.score.capacity() * size_of::<u8>()
    }

    /// Heap bytes of the reusable clouds, bucket grids and candidate lists (sized by the beams
    /// of a step and the search window, never by the map).
    pub fn scratch_bytes(&self) -> usize {
        (self.source.capacity()
            + self.coarse_source.capacity()
            + self.expected.capacity()
            + self.check_cloud.capacity())
            * size_of::<Point2>()
            + self.grid.heap_bytes()
            + self.check_grid.heap_bytes()
            + self.candidates.capacity() * size_of::<(Pose2, Fitness, f64, bool)>()
            + self.checked.capacity() * size_of::<Checked>()
            + self.cells.capacity() * size_of::<(i32, i32)>()
            + self.peaks.capacity() * size_of::<(u32, Pose2)>()
    }

    /// Registers the scan to the cloud expected from `pose`, re-casts the cloud at the result
    /// and records the fitness there.
    fn check(
        &mut self,
        map: &OccupancyGrid,
        pose: Pose2,
        scans: &[LaserScan],
        max_range_m: f64,
        p: &PoseUpdatingParams,
    ) {
        if !expected_grid(map, &pose, scans, max_range_m, p, &mut self.check_cloud, &mut self.check_grid) {
            return;
        }
        let d0 = CHECK_CORRESPONDENCE_M.min(p.max_correspondence_m).max(p.min_correspondence_m);
        let (run, _) = icp_from(&self.source, &self.check_grid, pose, p, d0, p.max_iterations);
        if !run.pose.is_finite() {
            return;
        }
        let moved =
            run.pose.distance(&pose) > 0.5 * p.inlier_distance_m || angle_diff(run.pose.yaw, pose.yaw).abs() > 0.01;
        if moved && !expected_grid(map, &run.pose, scans, max_range_m, p, &mut self.check_cloud, &mut self.check_grid) {
            return;
        }
        let (fit, info) = fitness(&self.source, &self.check_grid, &run.pose, p.inlier_distance_m);
        self.checked.push(Checked { pose: run.pose, fit, info, evidence: fit.inlier_ratio, views: 0 });
    }

    /// The best checked candidate through the fitness gate, the ambiguity test and, if its
    /// covariance is weak in some direction, the slide test.
    fn decide(
        &mut self,
        map: &OccupancyGrid,
        scans: &[LaserScan],
        max_range_m: f64,
        p: &PoseUpdatingParams,
    ) -> PoseRecovery {
        self.checked.sort_by(|a, b| b.evidence.total_cmp(&a.evidence).then(a.fit.rmse_m.total_cmp(&b.fit.rmse_m)));
        let Some(best) = self.checked.first().copied() else {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::PoorFit { best: Fitness::default() } };
        };
        // The current scans must pass the gate on their own, and the other scans on average:
        // other evidence ranks and breaks ties, it never makes a pose the current scans reject
        // acceptable, and a pose the earlier scans contradict is not accepted.
        let mean = best.evidence / (best.views + 1) as f64;
        if best.fit.inlier_ratio.min(mean) < p.min_inlier_ratio || best.fit.rmse_m > p.max_rmse_m {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::PoorFit { best: best.fit } };
        }
        for other in &self.checked[1..] {
            if best.evidence - other.evidence > p.ambiguity_ratio_margin {
                break;
            }
            if distinct(&other.pose, &best.pose, p) {
                return PoseRecovery::NotRecovered {
                    reason: RecoveryFailure::Ambiguous { first: best.pose, second: other.pose },
                };
            }
        }
        let Some(h_inv) = best.info.try_inverse() else {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::Degenerate };
        };
        // Floor the residual at 1 cm so a perfect synthetic fit still has a usable covariance.
        let sigma2 = best.fit.rmse_m.max(0.01).powi(2);
        let mut covariance = [[0.0; 3]; 3];
        for (r, row) in covariance.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = sigma2 * h_inv[(r, c)];
            }
        }
        if covariance.iter().flatten().any(|v| !v.is_finite()) || covariance[2][2] <= 0.0 {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::Degenerate };
        }
        if self.slides(map, scans, max_range_m, &best, &covariance, p) {
            return PoseRecovery::NotRecovered { reason: RecoveryFailure::Degenerate };
        }
        PoseRecovery::Recovered { pose_in_map: best.pose, covariance, fitness: best.fit }
    }

    /// Whether the best candidate slides: its covariance leaves the position uncertain beyond
    /// [`SLIDE_TEST_SIGMA_M`] in some direction, and the current scans fit a pose moved along
    /// it by one of [`SLIDES_M`] within the ambiguity margin (a pose that far is distinct, so
    /// this is the ambiguity test with the alternatives the covariance proposes). Found by a
    /// robot Lost in a corridor: a pose 14 m along it accepted with σ = 10⁸ m (test
    /// `views_kept_while_lost_tell_twin_places_apart`).
    fn slides(
        &mut self,
        map: &OccupancyGrid,
        scans: &[LaserScan],
        max_range_m: f64,
        best: &Checked,
        covariance: &[[f64; 3]; 3],
        p: &PoseUpdatingParams,
    ) -> bool {
        let (variance, dir) = weakest_xy(covariance);
        if variance <= SLIDE_TEST_SIGMA_M * SLIDE_TEST_SIGMA_M {
            return false;
        }
        for d in SLIDES_M {
            for sign in [1.0, -1.0] {
                let q = Pose2::new(best.pose.x + sign * d * dir.x, best.pose.y + sign * d * dir.y, best.pose.yaw);
                if !expected_grid(map, &q, scans, max_range_m, p, &mut self.check_cloud, &mut self.check_grid) {
                    continue;
                }
                let (fit, _) = fitness(&self.source, &self.check_grid, &q, p.inlier_distance_m);
                if best.fit.inlier_ratio - fit.inlier_ratio <= p.ambiguity_ratio_margin {
                    return true;
                }
            }
        }
        false
    }

    /// Correlative search: every pose of the window around `predicted` on a grid of
    /// `search_step_m` × `search_yaw_step_rad`, scored by how close the scan's points fall to
    /// occupied cells of `map`; the best distinct poses go to `self.peaks`.
    fn search(&mut self, map: &OccupancyGrid, predicted: Pose2, p: &PoseUpdatingParams) {
        self.peaks.clear();
        let g = *map.geometry();
        let (w, h) = (g.width(), g.height());
        self.build_score(map);
        let (step_cells, n_t, n_yaw) = search_window(p, g.resolution_m());
        let k = (self.source.len() / SEARCH_POINTS).max(1);
        let n_points = self.source.len().div_ceil(k);
        let min_score = (MIN_SEARCH_SCORE * f64::from(SCORE_MAX) * n_points as f64) as u32;
        let keep = p.search_candidates.max(1) as usize;
        let origin = g.grid_to_world(0.0, 0.0);
        let step_vec = |tx: i64, ty: i64| {
            let q = g.grid_to_world((tx * step_cells) as f64, (ty * step_cells) as f64);
            (q.x - origin.x, q.y - origin.y)
        };
        for j in -n_yaw..=n_yaw {
            let yaw = wrap_angle(predicted.yaw + j as f64 * p.search_yaw_step_rad);
            let at = Pose2::new(predicted.x, predicted.y, yaw);
            self.cells.clear();
            for pt in self.source.iter().step_by(k) {
                let (u, v) = g.world_to_grid(at.transform_point(*pt));
                if u.is_finite() && v.is_finite() && u.abs() < 1e9 && v.abs() < 1e9 {
                    self.cells.push((floor_exact(u) as i32, floor_exact(v) as i32));
                }
            }
            for ty in -n_t..=n_t {
                for tx in -n_t..=n_t {
                    let (ox, oy) = (tx * step_cells, ty * step_cells);
                    let mut s = 0u32;
                    for &(cu, cv) in &self.cells {
                        let (u, v) = (i64::from(cu) + ox, i64::from(cv) + oy);
                        if u >= 0 && v >= 0 && (u as usize) < w && (v as usize) < h {
                            s += u32::from(self.score[v as usize * w + u as usize]);
                        }
                    }
                    if s < min_score || (self.peaks.len() >= keep && s <= self.peaks[keep - 1].0) {
                        continue;
                    }
                    let (dx, dy) = step_vec(tx, ty);
                    let pose = Pose2::new(predicted.x + dx, predicted.y + dy, yaw);
                    self.insert_peak(s, pose, keep, p);
                }
            }
        }
    }

    /// Keeps the `keep` best distinct peaks, best first (a peak near a better one is dropped;
    /// a better peak replaces the worse ones near it).
    fn insert_peak(&mut self, s: u32, pose: Pose2, keep: usize, p: &PoseUpdatingParams) {
        if self.peaks.iter().any(|(t, q)| *t >= s && !distinct(q, &pose, p)) {
            return;
        }
        self.peaks.retain(|(_, q)| distinct(q, &pose, p));
        let at = self.peaks.iter().position(|(t, _)| *t < s).unwrap_or(self.peaks.len());
        self.peaks.insert(at, (s, pose));
        self.peaks.truncate(keep);
    }

    /// Per cell: `SCORE_MAX − d` for a chessboard distance of d < `SCORE_MAX` cells to the
    /// nearest occupied cell of `map`, else 0 (two raster passes).
    fn build_score(&mut self, map: &OccupancyGrid) {
        let g = map.geometry();
        let (w, h) = (g.width(), g.height());
        let far = SCORE_MAX;
        self.score.clear();
        self.score.extend(map.cells().iter().map(|&c| if c == CellState::Occupied { 0 } else { far }));
        let d = &mut self.score;
        chessboard_distance(d, w, h);
        for v in d.iter_mut() {
            *v = far.saturating_sub(*v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, GridGeometry};
    use mapkeeper_testkit::rooms::{fill_cells, walled_cells};

    /// An 8 m × 5 m walled room at 0.05 m with asymmetric furniture.
    fn room() -> OccupancyGrid {
        let mut m = walled_cells(160, 100, 0.05, Pose2::IDENTITY);
        fill_cells(&mut m, 40..52, 70..99, CellState::Occupied);
        fill_cells(&mut m, 100..106, 1..30, CellState::Occupied);
        fill_cells(&mut m, 120..140, 60..66, CellState::Occupied);
        m
    }

    fn scan360(map: &OccupancyGrid, pose: Pose2) -> LaserScan {
        let n = 720;
        let inc = std::f64::consts::TAU / n as f64;
        let ranges = (0..n)
            .map(|i| {
                let a = pose.yaw - std::f64::consts::PI + i as f64 * inc;
                cast_ray(map, pose.position(), a, 20.0, true).range_m as f32
            })
            .collect();
        LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: -std::f64::consts::PI,
            angle_increment_rad: inc,
            range_min_m: 0.05,
            range_max_m: 20.0,
            ranges_m: ranges,
            sweep: None,
        }
    }

    #[test]
    fn score_is_chessboard_distance_to_occupied() {
        let m = room();
        let mut pu = PoseUpdater::new();
        pu.build_score(&m);
        let w = 160;
        assert_eq!(pu.score[50 * w], SCORE_MAX);
        assert_eq!(pu.score[50 * w + 1], SCORE_MAX - 1);
        assert_eq!(pu.score[50 * w + 3], SCORE_MAX - 3);
        assert_eq!(pu.score[50 * w + 4], 0);
        assert_eq!(pu.score[2 * w + 2], SCORE_MAX - 2);
    }

    /// A predicted pose 1.6 m and 0.5 rad off, beyond the local hypotheses' reach: the
    /// correlative search finds the true pose.
    #[test]
    fn wide_search_recovers_a_far_prediction() {
        let m = room();
        let truth = Pose2::new(3.0, 2.5, 0.4);
        let scans = [scan360(&m, truth)];
        let predicted = Pose2::new(truth.x + 1.3, truth.y - 0.9, truth.yaw - 0.5);
        let mut pu = PoseUpdater::new();
        // Local hypotheses narrowed so that only the search can reach the truth.
        let p = PoseUpdatingParams {
            yaw_offsets_rad: vec![0.0],
            position_offsets_m: vec![0.0],
            max_correspondence_m: 0.3,
            ..Default::default()
        };
        match pu.recover(&m, predicted, &scans, f64::INFINITY, &p) {
            PoseRecovery::Recovered { pose_in_map, .. } => {
                assert!(pose_in_map.distance(&truth) < 0.03, "{pose_in_map:?}");
                assert!(angle_diff(pose_in_map.yaw, truth.yaw).abs() < 0.01);
            }
            other => panic!("{other:?}"),
        }
        // Without the search it is not found.
        let local = PoseUpdatingParams { search_radius_m: 0.0, ..p };
        let r = pu.recover(&m, predicted, &scans, f64::INFINITY, &local);
        assert!(
            !matches!(r, PoseRecovery::Recovered { pose_in_map, .. } if pose_in_map.distance(&truth) < 0.03),
            "{r:?}"
        );
    }

    /// `search_step_m = 1e300` (accepted by `validate()`: the search then has 3 × 3 positions)
    /// saturated the step's cast to i64 cells: `tx · step` overflowed, and without overflow
    /// checks the window was clamped to 20001 × 20001 positions (80 s for this call). The input
    /// `fuzz/corpus/updater_params/regression_search_step_overflows_i64.toml`.
    #[test]
    fn a_search_step_beyond_the_i64_range_of_cells_neither_overflows_nor_widens_the_window() {
        let m = room();
        let truth = Pose2::new(3.0, 2.5, 0.4);
        let scans = [scan360(&m, truth)];
        let predicted = Pose2::new(truth.x + 1.3, truth.y - 0.9, truth.yaw - 0.5);
        let p = |radius: f64, step: f64| PoseUpdatingParams {
            yaw_offsets_rad: vec![0.0],
            position_offsets_m: vec![0.0],
            search_radius_m: radius,
            search_step_m: step,
            search_yaw_rad: 5e-324,
            ..Default::default()
        };
        assert_eq!(search_window(&p(1e300, 1e300), 0.05), (1 << 40, 1, 0));
        assert_eq!(search_window(&p(2.0, 0.1), 0.05), (2, 20, 0));
        let mut huge = PoseUpdater::new();
        huge.recover(&m, predicted, &scans, f64::INFINITY, &p(1e300, 1e300));
        // A step of 1e6 m is 2e7 cells: the same 3 × 3 window, every shifted point off the map.
        let mut large = PoseUpdater::new();
        large.recover(&m, predicted, &scans, f64::INFINITY, &p(1e6, 1e6));
        assert_eq!(huge.peaks, large.peaks);
        assert!(huge.peaks.iter().all(|(_, q)| q.position() == predicted.position()), "{:?}", huge.peaks);
    }

    /// A square empty room seen from its centre has four equally good yaws: refused as
    /// ambiguous, not answered with one of them.
    #[test]
    fn a_symmetric_room_is_ambiguous() {
        let g = GridGeometry::new(120, 120, 0.05, Pose2::IDENTITY).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        for k in 0..120 {
            for c in [CellCoord::new(k, 0), CellCoord::new(k, 119), CellCoord::new(0, k), CellCoord::new(119, k)] {
                m.set(c, CellState::Occupied);
            }
        }
        let truth = Pose2::new(3.0, 3.0, 0.0);
        let scans = [scan360(&m, truth)];
        let p = PoseUpdatingParams::default();
        let mut pu = PoseUpdater::new();
        // Half-way between two of the four equally good yaws.
        let r = pu.recover(&m, Pose2::new(3.0, 3.0, std::f64::consts::FRAC_PI_4), &scans, f64::INFINITY, &p);
        assert!(matches!(r, PoseRecovery::NotRecovered { reason: RecoveryFailure::Ambiguous { .. } }), "{r:?}");
    }
}
