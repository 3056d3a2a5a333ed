//! Beam classifier (§4.1, eq. 2-5, Appendix A.1).
//!
//! For each valid beam, the hit point p_i (eq. 2, with the lidar's mounting pose) is compared
//! with the expected hit points of N = 2n_e + 1 rays cast in `M_{i-1}` from the same lidar at
//! angle offsets l·v·Δθ (eq. 3-4), unknown cells counting as occupied. The beam is a "detected
//! change" iff the smallest distance exceeds D_th(z) = min(m_th·z + q_th, D_max) (eq. 5).
//!
//! Two exact shortcuts keep it fast: the rays are tried central first and the search stops at
//! the first expected point within D_th (the minimum is then ≤ D_th whatever the others are);
//! and no ray is cast further than z + D_th, because an expected point at range z_e is at least
//! |z_e − z| from p_i whatever the angle offset.

use crate::UpdaterParams;
use mapkeeper_grid::{CellCoord, Point2, Pose2, RayCaster, RayDir, RayStop};
use mapkeeper_sensor::{BeamValidity, LaserScan};

/// The classifier's verdict on one beam.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BeamClass {
    /// Not usable (NaN, inf, out of range, or its scan's header is bad).
    Invalid,
    /// Agrees with `M_{i-1}` ("non-detected change").
    Unchanged,
    /// Disagrees with `M_{i-1}` ("detected change").
    Changed,
    /// A detected change removed by the outlier filter (`min_change_run`); neither counted in
    /// n_dc nor evaluated.
    Outlier,
    /// Agrees with the map but lies within `skip_near_changes_beams` of a change; not evaluated.
    NearChange,
}

/// One beam of the processed step.
#[derive(Clone, Copy, Debug)]
pub struct Beam {
    /// Index of the lidar frame in [`BeamClassifier::lidars`].
    pub lidar: u32,
    /// Measured range z_i, metres (0 when invalid).
    pub range_m: f64,
    /// Beam direction in the map frame, radians.
    pub angle_rad: f64,
    /// Hit point p_i in the map frame.
    pub hit: Point2,
    /// Distance from the lidar to the nearest tile holding a cell buffer that the beam's
    /// direction crosses, metres; +∞ if it crosses none (set by [`BeamClassifier::mark_near`]
    /// before the unchanged evaluator, which skips beams at +∞ and starts walking near the tile).
    pub near_buffer_m: f64,
    /// The verdict.
    pub class: BeamClass,
}

/// Where one scan's lidar was in the map during the step.
#[derive(Clone, Copy, Debug)]
pub struct LidarFrame {
    /// Lidar position in the map: the start of every ray of this scan.
    pub origin: Point2,
    /// First beam of this scan in [`BeamClassifier::beams`].
    pub first_beam: usize,
    /// Number of beams of this scan.
    pub beam_count: usize,
    /// Map-frame direction of beam 0, radians.
    pub angle0_rad: f64,
    /// Angle between consecutive beams, radians.
    pub increment_rad: f64,
}

/// Counts of one step's classification.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ClassCounts {
    /// n: valid beams over all lidars.
    pub n_valid: usize,
    /// Invalid beams (including every beam of an invalid scan).
    pub n_invalid: usize,
    /// Scans whose header failed [`LaserScan::validate`].
    pub invalid_scans: usize,
    /// n_dc: detected-change beams after the outlier filter.
    pub n_dc: usize,
}

/// The classifier with its per-step scratch (reused from step to step, never map-sized).
#[derive(Clone, Debug, Default)]
pub struct BeamClassifier {
    /// Every beam of every valid scan of the last step, scan after scan.
    pub beams: Vec<Beam>,
    /// One frame per valid scan of the last step.
    pub lidars: Vec<LidarFrame>,
}

/// Number of virtual rays each side and their spacing (in beam increments) for one scan.
pub fn virtual_rays(params: &UpdaterParams, increment_rad: f64) -> (i32, f64) {
    let v = params.virtual_ray_spacing_beams;
    if params.virtual_window_rad > 0.0 {
        let step = v * increment_rad.abs();
        let n = if step > 0.0 { (params.virtual_window_rad / step - 1e-9).ceil() } else { 0.0 };
        (n.clamp(0.0, 1024.0) as i32, v)
    } else {
        (params.virtual_rays_each_side as i32, v)
    }
}

/// Margin of the no-cast shortcut of [`detects_change_dir`] against the rounding of expected
/// points (about 1e-14 m at warehouse scale).
const EXPECTED_POINT_SLACK_M: f64 = 1e-6;

/// Eq. 3-5 for one beam: whether the smallest distance from `hit` (at range `z` along
/// `angle_rad` from `origin`) to the expected hit points of the 2n_e + 1 rays cast in `base` at
/// `angle_rad + l·v·increment_rad` exceeds `d_th`. Unknown cells block the rays.
#[allow(clippy::too_many_arguments)]
pub fn detects_change(
    base: &RayCaster,
    origin: Point2,
    angle_rad: f64,
    increment_rad: f64,
    hit: Point2,
    z: f64,
    n_e: i32,
    v: f64,
    max_range_m: f64,
    d_th: f64,
) -> bool {
    let mut hint = None;
    detects_change_dir(
        base,
        origin,
        &base.direction(angle_rad),
        increment_rad,
        hit,
        z,
        n_e,
        v,
        max_range_m,
        d_th,
        &mut hint,
    )
}

/// [`detects_change`] with the beam's direction prepared by `base` (its sine and cosine are
/// reused for the central ray; bit for bit the same answer). `stop_hint`: on entry, a distance
/// near which this ray may be blocked (where the previous beam's central ray stopped), tried
/// before casting; on return, where this beam's central ray stopped at a blocking cell (or a
/// bound for it), if known. Any hint gives the same answer; good ones save casts.
#[allow(clippy::too_many_arguments)]
pub fn detects_change_dir(
    base: &RayCaster,
    origin: Point2,
    beam: &RayDir,
    increment_rad: f64,
    hit: Point2,
    z: f64,
    n_e: i32,
    v: f64,
    max_range_m: f64,
    d_th: f64,
    stop_hint: &mut Option<f64>,
) -> bool {
    let incoming = stop_hint.take();
    let angle_rad = beam.angle();
    let cast_len = z + d_th + 1e-6;
    let (len, truncated) = if cast_len >= max_range_m { (max_range_m, false) } else { (cast_len, true) };
    // Exact shortcut: an expected point is on a blocking cell (or the ray's start inside one),
    // on the grid's border, or — only for a cast that is not truncated — at the maximum range.
    // With no blocking cell and no border within D_th of p_i (plus a margin far above the
    // rounding of the expected points), none of them can match: a change, without casting.
    if truncated && base.free_radius_m(hit) > d_th + EXPECTED_POINT_SLACK_M {
        *stop_hint = incoming;
        return true;
    }
    let d_th_sq = d_th * d_th;
    let r = base.map().geometry().resolution_m();
    // Exact shortcut: a ray whose point at some s ≤ z − D_th − slack lies inside a blocking
    // cell (away from its sides) stops at most there, so its expected point is farther than
    // D_th from p_i (the triangle inequality): it cannot match, no need to cast it. Points are
    // tried just beyond where a neighbouring ray stopped: the removed obstacle of most changes.
    let limit = z - d_th - EXPECTED_POINT_SLACK_M;
    let blocked_near = |near: f64, dir: &RayDir| {
        [near + 0.5 * r, near + r].into_iter().find(|&s| s <= limit && base.blocked_at(origin, dir, s))
    };
    // Where the central ray stopped at a blocking cell, or a bound for it.
    let mut central_block = None;
    for k in 0..=2 * n_e {
        // 0, -1, +1, -2, +2, ...
        let l = if k % 2 == 0 { -(k / 2) } else { (k + 1) / 2 };
        let a = angle_rad + l as f64 * v * increment_rad;
        // The central ray's angle is the beam's own (bit for bit, then reuse its direction).
        let dir = if a.to_bits() == angle_rad.to_bits() { *beam } else { base.direction(a) };
        let near = if k == 0 { incoming } else { central_block };
        if let Some(s) = near.and_then(|near| blocked_near(near, &dir)) {
            if k == 0 {
                central_block = Some(s);
            }
            continue;
        }
        let ray = base.cast_dir(origin, &dir, len);
        if k == 0 && matches!(ray.stop, RayStop::Occupied | RayStop::Unknown) {
            central_block = Some(ray.range_m);
        }
        if truncated && ray.stop == RayStop::MaxRange {
            continue; // z_e > z + D_th: too far whatever the angle.
        }
        let (s, c) = (dir.sin(), dir.cos());
        let expected = Point2::new(origin.x + ray.range_m * c, origin.y + ray.range_m * s);
        if expected.distance_sq(hit) <= d_th_sq {
            *stop_hint = central_block;
            return false;
        }
    }
    *stop_hint = central_block;
    true
}

impl BeamClassifier {
    /// A classifier with empty scratch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Classifies every beam of `scans` (all lidars of one step) against `base` = `M_{i-1}` with
    /// the robot at `robot_in_map`.
    pub fn classify(
        &mut self,
        base: &RayCaster,
        robot_in_map: &Pose2,
        scans: &[LaserScan],
        params: &UpdaterParams,
    ) -> ClassCounts {
        self.beams.clear();
        self.lidars.clear();
        let mut counts = ClassCounts::default();
        for scan in scans {
            if scan.validate().is_err() || !robot_in_map.is_finite() {
                counts.invalid_scans += 1;
                counts.n_invalid += scan.len();
                continue;
            }
            let lidar_in_map = scan.lidar_in_map(robot_in_map);
            let origin = lidar_in_map.position();
            let lidar = self.lidars.len() as u32;
            self.lidars.push(LidarFrame {
                origin,
                first_beam: self.beams.len(),
                beam_count: scan.len(),
                angle0_rad: lidar_in_map.yaw + scan.angle_min_rad,
                increment_rad: scan.angle_increment_rad,
            });
            let max_range_m = params.max_range_m.min(scan.range_max_m as f64);
            let (n_e, v) = virtual_rays(params, scan.angle_increment_rad);
            // Where the previous beam's central ray stopped: a hint for the next one's.
            let mut hint = None;
            for (i, &r) in scan.ranges_m.iter().enumerate() {
                let angle_rad = lidar_in_map.yaw + scan.beam_angle(i as f64);
                let z = r as f64;
                let valid = scan.validity_of(r) == BeamValidity::Valid && z < params.max_range_m;
                if !valid {
                    counts.n_invalid += 1;
                    self.beams.push(Beam {
                        lidar,
                        range_m: 0.0,
                        angle_rad,
                        hit: origin,
                        class: BeamClass::Invalid,
                        near_buffer_m: f64::INFINITY,
                    });
                    continue;
                }
                counts.n_valid += 1;
                let dir = base.direction(angle_rad);
                let (s, c) = (dir.sin(), dir.cos());
                let hit = Point2::new(origin.x + z * c, origin.y + z * s);
                let d_th = params.change_distance_m(z);
                let changed = detects_change_dir(
                    base,
                    origin,
                    &dir,
                    scan.angle_increment_rad,
                    hit,
                    z,
                    n_e,
                    v,
                    max_range_m,
                    d_th,
                    &mut hint,
                );
                let class = if changed { BeamClass::Changed } else { BeamClass::Unchanged };
                self.beams.push(Beam { lidar, range_m: z, angle_rad, hit, class, near_buffer_m: f64::INFINITY });
            }
        }
        self.filter_outliers(params.min_change_run as usize);
        self.mark_near_changes(params.skip_near_changes_beams as usize);
        counts.n_dc = self.beams.iter().filter(|b| b.class == BeamClass::Changed).count();
        counts
    }

    /// Marks the beams whose direction crosses one of the squares (lower-left cell, side in
    /// cells) of `tiles` in `grid`'s geometry; the others cannot reach a buffered cell.
    pub fn mark_near(
        &mut self,
        geometry: &mapkeeper_grid::GridGeometry,
        tiles: impl Iterator<Item = CellCoord> + Clone,
        side: i32,
    ) {
        use std::f64::consts::{PI, TAU};
        for b in &mut self.beams {
            b.near_buffer_m = f64::INFINITY;
        }
        let tile_m = side as f64 * geometry.resolution_m();
        for f in &self.lidars {
            let beams = &mut self.beams[f.first_beam..f.first_beam + f.beam_count];
            let inc = f.increment_rad.abs();
            if beams.is_empty() || inc.is_nan() || inc <= 0.0 {
                continue;
            }
            for t in tiles.clone() {
                let corners = [(0, 0), (side, 0), (0, side), (side, side)]
                    .map(|(dx, dy)| geometry.grid_to_world((t.ix + dx) as f64, (t.iy + dy) as f64));
                let centre = geometry.grid_to_world(t.ix as f64 + side as f64 / 2.0, t.iy as f64 + side as f64 / 2.0);
                if centre.distance(f.origin) <= tile_m {
                    beams.iter_mut().for_each(|b| b.near_buffer_m = 0.0);
                    break;
                }
                // Distance from the lidar to the tile's square (grid coordinates, then metres).
                let (u, v) = geometry.world_to_grid(f.origin);
                let (x0, y0) = (t.ix as f64, t.iy as f64);
                let (x1, y1) = (x0 + side as f64, y0 + side as f64);
                let du = (x0 - u).max(u - x1).max(0.0);
                let dv = (y0 - v).max(v - y1).max(0.0);
                let dist_m = (du * du + dv * dv).sqrt() * geometry.resolution_m();
                let mut near = |b: &mut Beam| b.near_buffer_m = b.near_buffer_m.min(dist_m);
                let ac = (centre.y - f.origin.y).atan2(centre.x - f.origin.x);
                let half = corners
                    .iter()
                    .map(|c| mapkeeper_grid::angle_diff((c.y - f.origin.y).atan2(c.x - f.origin.x), ac).abs())
                    .fold(0.0, f64::max)
                    + inc;
                // Offset of the tile's direction from beam 0, along the scan's sweep, in [0, 2π).
                let off = if f.increment_rad > 0.0 {
                    (ac - f.angle0_rad).rem_euclid(TAU)
                } else {
                    (f.angle0_rad - ac).rem_euclid(TAU)
                };
                for shift in [-TAU, 0.0, TAU] {
                    let lo = ((off + shift - half) / inc).ceil().max(0.0);
                    let hi = ((off + shift + half) / inc).floor().min(beams.len() as f64 - 1.0);
                    if lo <= hi && half < PI {
                        beams[lo as usize..=hi as usize].iter_mut().for_each(&mut near);
                    } else if half >= PI {
                        beams.iter_mut().for_each(&mut near);
                    }
                }
            }
        }
    }

    /// Reference outlier filter: detected changes survive only in runs of ≥ `min_run` adjacent
    /// beams of one lidar.
    fn filter_outliers(&mut self, min_run: usize) {
        if min_run <= 1 {
            return;
        }
        for f in &self.lidars {
            let beams = &mut self.beams[f.first_beam..f.first_beam + f.beam_count];
            let mut i = 0;
            while i < beams.len() {
                if beams[i].class != BeamClass::Changed {
                    i += 1;
                    continue;
                }
                let start = i;
                while i < beams.len() && beams[i].class == BeamClass::Changed {
                    i += 1;
                }
                if i - start < min_run {
                    beams[start..i].iter_mut().for_each(|b| b.class = BeamClass::Outlier);
                }
            }
        }
    }

    /// Reference rule: unchanged beams within ±`k` of a detected change are not evaluated.
    fn mark_near_changes(&mut self, k: usize) {
        if k == 0 {
            return;
        }
        for f in &self.lidars {
            let beams = &mut self.beams[f.first_beam..f.first_beam + f.beam_count];
            for i in 0..beams.len() {
                if beams[i].class != BeamClass::Changed {
                    continue;
                }
                let lo = i.saturating_sub(k);
                let hi = (i + k).min(beams.len() - 1);
                for b in &mut beams[lo..=hi] {
                    if b.class == BeamClass::Unchanged {
                        b.class = BeamClass::NearChange;
                    }
                }
            }
        }
    }
}
