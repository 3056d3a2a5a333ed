//! The local map of the scan-odometry maker: the last key scans' surfaces, as a fine distance
//! field for the localiser's [`ScanMatcher`] and a coarse kernel table for the wide search
//! (scans far apart, or a match the narrow window refused).

use super::ScanOdometryParams;
use mapkeeper_grid::geometry::floor_exact;
use mapkeeper_grid::{DistanceField, GridGeometry, Point2, Pose2, traverse, wrap_angle};
use mapkeeper_localiser::{ScanMatcher, Window};
use mapkeeper_sensor::{BeamValidity, LaserScan};
use std::collections::VecDeque;
use std::ops::ControlFlow;

/// The largest gap between two neighbouring beams' endpoints that the local map fills in, metres
/// (a wider one is a jump from one surface to another, or a surface seen too obliquely to trust).
pub const MAX_FILL_GAP_M: f64 = 0.2;

/// Beams the wide search scores (evenly over the match's beams).
pub const WIDE_SEARCH_BEAMS: usize = 90;

/// A wide-search pose whose beams end in known space fewer than this share of them is scored as
/// if the others ended there and fitted nothing.
pub const MIN_KNOWN_SHARE: f64 = 0.5;

/// One key scan of the local map: its pose, its points ([`map_points`]) and its matched beams'
/// endpoints, in the robot frame.
#[derive(Clone, Debug)]
struct KeyScan {
    pose: Pose2,
    points: Vec<[f64; 2]>,
    ends: Vec<[f64; 2]>,
}

/// The local map: the last key scans, the matcher built on them and the wide search's table.
pub(super) struct LocalMap {
    keys: VecDeque<KeyScan>,
    /// The fine matcher, `None` before the first key scan.
    pub matcher: Option<ScanMatcher>,
    /// The wide search's table, `None` before the first key scan.
    pub wide: Option<WideSearch>,
}

impl LocalMap {
    /// An empty map.
    pub fn new() -> Self {
        Self { keys: VecDeque::new(), matcher: None, wide: None }
    }

    /// Whether `pose` is far enough from the last key scan to be one.
    pub fn wants_key(&self, pose: &Pose2, p: &ScanOdometryParams) -> bool {
        self.keys.back().is_none_or(|k| {
            k.pose.distance(pose) >= p.key_distance_m || wrap_angle(k.pose.yaw - pose.yaw).abs() >= p.key_turn_rad
        })
    }

    /// Adds a key scan, its points and its beams' endpoints in the robot frame (dropping the
    /// oldest beyond `submap_scans`), and rebuilds the tables around it.
    pub fn add(&mut self, pose: Pose2, points: Vec<[f64; 2]>, ends: &[[f64; 2]], p: &ScanOdometryParams) {
        self.keys.push_back(KeyScan { pose, points, ends: ends.to_vec() });
        while self.keys.len() > p.submap_scans {
            self.keys.pop_front();
        }
        // The fine table needs the kernel's reach (3 σ) and the inlier distance, and a cell more
        // for the interpolation between cell centres.
        let fine_cap = (3.0 * p.matcher.kernel_sigma_m).max(p.matcher.inlier_m) + p.resolution_m;
        self.matcher = self.field(pose, p.resolution_m, fine_cap, p).map(|f| ScanMatcher::from_field(&f, p.matcher));
        let sigma = p.wide_resolution_m;
        self.wide = self
            .field(pose, p.wide_resolution_m, 3.0 * sigma, p)
            .map(|f| WideSearch::new(&f, sigma, &self.known(f.geometry())));
    }

    /// Forgets every key scan.
    pub fn clear(&mut self) {
        self.keys.clear();
        self.matcher = None;
        self.wide = None;
    }

    /// The distance field, at `resolution_m` and capped at `cap_m`, of the key scans' points in
    /// the square around `centre` (to the points themselves, not to their cells: no bias towards
    /// the cell lattice).
    fn field(&self, centre: Pose2, resolution_m: f64, cap_m: f64, p: &ScanOdometryParams) -> Option<DistanceField> {
        let cells = (2.0 * p.submap_radius_m / resolution_m).ceil() as usize;
        let origin = Pose2::new(centre.x - p.submap_radius_m, centre.y - p.submap_radius_m, 0.0);
        let geometry = GridGeometry::new(cells, cells, resolution_m, origin).ok()?;
        let points = self.keys.iter().flat_map(|k| {
            let frame = k.pose.prepare();
            k.points.iter().map(move |&[x, y]| frame.transform_point(Point2::new(x, y)))
        });
        Some(DistanceField::to_points(&geometry, points, cap_m))
    }
}

impl LocalMap {
    /// Which cells of `geometry` the key scans saw: those their beams crossed or ended in.
    fn known(&self, geometry: &GridGeometry) -> Vec<bool> {
        let mut known = vec![false; geometry.len()];
        for k in &self.keys {
            let frame = k.pose.prepare();
            let from = k.pose.position();
            for &[x, y] in &k.ends {
                let to = frame.transform_point(Point2::new(x, y));
                let _ = traverse(geometry, from, to, |c| {
                    if let Some(i) = geometry.index(c) {
                        known[i] = true;
                    }
                    ControlFlow::<()>::Continue(())
                });
                if let Some(i) = geometry.world_to_cell(to).and_then(|c| geometry.index(c)) {
                    known[i] = true;
                }
            }
        }
        known
    }
}

/// The points of `scan` for the local map, robot frame: every valid endpoint short of
/// `max_range_m`, and between neighbouring beams whose endpoints are at most
/// [`MAX_FILL_GAP_M`] and five beam spacings apart, points every `spacing_m` along the segment
/// (a surface, not a scatter of points: a matched endpoint lands on the surface, not between
/// two samples of it).
pub(super) fn map_points(scan: &LaserScan, max_range_m: f64, spacing_m: f64, out: &mut Vec<[f64; 2]>) {
    let mut last: Option<(f64, Point2)> = None;
    for (i, &r) in scan.ranges_m.iter().enumerate() {
        if scan.validity_of(r) != BeamValidity::Valid || (r as f64) >= max_range_m {
            last = None;
            continue;
        }
        let r = r as f64;
        let a = scan.beam_angle(i as f64);
        let p = scan.lidar_in_robot.transform_point(Point2::new(r * a.cos(), r * a.sin()));
        if let Some((r0, q)) = last {
            let gap = p.distance(q);
            let spacing = 5.0 * r.min(r0) * scan.angle_increment_rad.abs();
            if gap <= MAX_FILL_GAP_M.min(spacing.max(spacing_m)) {
                let n = (gap / spacing_m).floor() as usize;
                out.extend((1..=n.min(64)).map(|k| {
                    let t = k as f64 / (n + 1) as f64;
                    [q.x + t * (p.x - q.x), q.y + t * (p.y - q.y)]
                }));
            }
        }
        out.push([p.x, p.y]);
        last = Some((r, p));
    }
}

/// The wide search: every cell offset and every yaw step within a wide window, scored on a
/// coarse table of the kernel `exp(−d² / 2σ²)` of the distance to the local map's points (σ a
/// coarse cell), as the localiser's correlative search does on the fine one, but over the beams
/// that end in space the key scans saw: a pose whose beams reach past the local map (the robot
/// moved on and sees more) is not outscored by one that stays inside it (a corridor's look-alike
/// a metre back), as it would be by a mean over every beam.
pub(super) struct WideSearch {
    width: usize,
    height: usize,
    resolution_m: f64,
    /// The grid's origin (its yaw is 0: the grid's axes are the odom frame's).
    origin: Point2,
    /// The kernel of each cell the key scans saw; −1 for a cell they did not.
    kernel: Vec<f32>,
}

impl WideSearch {
    fn new(field: &DistanceField, sigma_m: f64, known: &[bool]) -> Self {
        let g = field.geometry();
        let s2 = 2.0 * sigma_m * sigma_m;
        let cap = field.max_distance_m();
        let at_cap = (-(cap as f64 * cap as f64) / s2).exp() as f32;
        let kernel = field
            .distances_m()
            .iter()
            .zip(known)
            .map(|(&d, &seen)| match (seen, d >= cap) {
                (false, _) => -1.0,
                (true, true) => at_cap,
                (true, false) => (-(d as f64 * d as f64) / s2).exp() as f32,
            })
            .collect();
        Self {
            width: g.width(),
            height: g.height(),
            resolution_m: g.resolution_m(),
            origin: g.origin().position(),
            kernel,
        }
    }

    /// The kernel at a cell, −1 where the key scans saw nothing (outside the grid too).
    fn kernel_at(&self, u: i64, v: i64) -> f32 {
        if (u as u64) < self.width as u64 && (v as u64) < self.height as u64 {
            self.kernel[v as usize * self.width + u as usize]
        } else {
            -1.0
        }
    }

    /// The best pose within `window` of `predicted` (cell steps in position, `yaw_step_rad` in
    /// yaw) for the endpoints `ends` (robot frame; [`WIDE_SEARCH_BEAMS`] of them are scored),
    /// by the mean kernel of the beams ending in known space (over at least [`MIN_KNOWN_SHARE`]
    /// of the beams) minus a prior of `prior_weight · ½ Σ (Δ / window)²` towards the prediction.
    /// `None` without endpoints.
    pub fn search(
        &self,
        predicted: &Pose2,
        ends: &[[f64; 2]],
        window: Window,
        yaw_step_rad: f64,
        prior_weight: f64,
    ) -> Option<Pose2> {
        if ends.is_empty() || yaw_step_rad.is_nan() || yaw_step_rad <= 0.0 {
            return None;
        }
        let stride = ends.len().div_ceil(WIDE_SEARCH_BEAMS).max(1);
        let chosen: Vec<[f64; 2]> = ends.iter().step_by(stride).copied().collect();
        let floor = MIN_KNOWN_SHARE * chosen.len() as f64;
        let cells = (window.xy_m / self.resolution_m).round() as i64;
        let yaws = (window.yaw_rad / yaw_step_rad).round() as i64;
        let inv = 1.0 / self.resolution_m;
        let axis = |d: f64, w: f64| if w > 0.0 { (d / w) * (d / w) } else { 0.0 };
        let mut best: Option<(f64, Pose2)> = None;
        let mut idx: Vec<(i64, i64)> = Vec::with_capacity(chosen.len());
        for k in -yaws..=yaws {
            let yaw = wrap_angle(predicted.yaw + k as f64 * yaw_step_rad);
            let (s, c) = yaw.sin_cos();
            let (gx, gy) = (predicted.x - self.origin.x, predicted.y - self.origin.y);
            idx.clear();
            idx.extend(chosen.iter().map(|&[ex, ey]| {
                let u = (gx + c * ex - s * ey) * inv;
                let v = (gy + s * ex + c * ey) * inv;
                (floor_cell(u), floor_cell(v))
            }));
            let yaw_prior = axis(k as f64 * yaw_step_rad, window.yaw_rad);
            for j in -cells..=cells {
                for i in -cells..=cells {
                    let (mut sum, mut known) = (0.0f64, 0usize);
                    for &(u, v) in &idx {
                        let k = self.kernel_at(u + i, v + j);
                        if k >= 0.0 {
                            sum += k as f64;
                            known += 1;
                        }
                    }
                    let (dx, dy) = (i as f64 * self.resolution_m, j as f64 * self.resolution_m);
                    let prior = 0.5 * prior_weight * (axis(dx, window.xy_m) + axis(dy, window.xy_m) + yaw_prior);
                    let score = sum / (known as f64).max(floor) - prior;
                    if best.is_none_or(|b| score > b.0) {
                        best = Some((score, Pose2::new(predicted.x + dx, predicted.y + dy, yaw)));
                    }
                }
            }
        }
        best.map(|b| b.1)
    }
}

/// The cell of a continuous grid coordinate; far outside for a non-finite one.
fn floor_cell(x: f64) -> i64 {
    if x.is_finite() && x.abs() < 1e15 { floor_exact(x) as i64 } else { i64::MIN / 2 }
}
