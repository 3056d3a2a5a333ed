//! Beam classifier (§4.1, eq. 2-5, Appendix A.1).
//!
//! For each valid beam, the hit point p_i (eq. 2, with the lidar's mounting pose) is compared
//! with the expected hit points of N = 2n_e + 1 rays cast in `M_{i-1}` from the same lidar at
//! angle offsets l·v·Δθ (eq. 3-4), unknown cells counting as occupied. The beam is a "detected
//! change" iff the smallest distance exceeds D_th(z) = min(m_th·z + q_th, D_max) (eq. 5).
//!
//! Exact shortcuts keep it fast, each giving the verdict the full casts would give: the rays are
//! tried central first and the search stops at the first expected point within D_th (the
//! minimum is then ≤ D_th whatever the others are); no ray is cast further than z + D_th,
//! because an expected point at range z_e is at least |z_e − z| from p_i whatever the angle
//! offset; and rays whose outcome is certain from the clearance field of `M_{i-1}` are not cast
//! at all (no blocking cell within D_th of p_i: a change; the central ray certainly stopped
//! within D_th of z: no change; a ray certainly blocked more than D_th short of z: no match).
//! What one beam learnt (where its central ray stopped, free discs along it) is handed to the
//! next beam of the scan ([`ScanHints`]).

use crate::UpdaterParams;
use crate::support::step_tolerance::StepTolerance;
use mapkeeper_grid::{CellCoord, CellState, FreeDiscs, Point2, Pose2, RayCaster, RayDir, RayStop};
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
    /// before the unchanged evaluator, which skips beams at +∞).
    pub near_buffer_m: f64,
    /// The same for the bounding boxes of the buffered cells of each tile: the unchanged
    /// evaluator walks the beam only from about there (+∞: not at all).
    pub walk_from_m: f64,
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
    /// Valid scans whose lidar lies in a non-free cell of `M_{i-1}` (the robot stands where a
    /// removed obstacle was mapped): every ray would start inside an obstacle and be a
    /// change, so the scan is not used this step (its beams count as invalid).
    pub occluded_scans: usize,
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
    /// What each beam leaves for the next one of its scan.
    pub hints: ScanHints,
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

/// What the 1-to-N comparison (eq. 4-5) needs of one scan: the same for all of its beams.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScanRays {
    /// Where every ray of the scan starts: its lidar's position in the map.
    pub origin: Point2,
    /// Δθ: the angle between consecutive beams, radians.
    pub increment_rad: f64,
    /// n_e: virtual rays on each side of a beam.
    pub each_side: i32,
    /// v: their spacing, in units of Δθ.
    pub spacing_beams: f64,
    /// No ray is cast further than this (the lidar's maximum, or `max_range_m` if smaller),
    /// metres.
    pub max_range_m: f64,
}

impl ScanRays {
    /// The comparison of `params` for a scan from `origin` with beam increment `increment_rad`
    /// and maximum range `range_max_m`.
    pub fn new(origin: Point2, increment_rad: f64, range_max_m: f64, params: &UpdaterParams) -> Self {
        let (each_side, spacing_beams) = virtual_rays(params, increment_rad);
        Self { origin, increment_rad, each_side, spacing_beams, max_range_m: params.max_range_m.min(range_max_m) }
    }

    /// The angular half-window these rays cover, radians.
    pub fn window_rad(&self) -> f64 {
        self.each_side as f64 * self.spacing_beams * self.increment_rad.abs()
    }

    /// The same rays widened to cover at least `window_rad` each side (same spacing).
    pub fn widened(&self, window_rad: f64) -> Self {
        let step = self.spacing_beams * self.increment_rad.abs();
        if step.is_nan() || step <= 0.0 || window_rad <= self.window_rad() {
            return *self;
        }
        let n = (window_rad / step - 1e-9).ceil().clamp(0.0, 1024.0) as i32;
        Self { each_side: n.max(self.each_side), ..*self }
    }
}

/// One beam to classify: its direction (prepared by the caster, whose sine and cosine gave the
/// hit point), its hit point p_i, its range z_i and the change distance D_th(z_i).
#[derive(Clone, Copy, Debug)]
pub struct BeamToClassify {
    /// The beam's direction in the map frame.
    pub dir: RayDir,
    /// p_i, map frame.
    pub hit: Point2,
    /// z_i, metres.
    pub range_m: f64,
    /// D_th(z_i), metres.
    pub d_th_m: f64,
}

/// Eq. 3-5 for one beam: whether the smallest distance from `hit` (at range `z` along
/// `angle_rad` from the scan's origin) to the expected hit points of the 2n_e + 1 rays cast in
/// `base` at `angle_rad + l·v·Δθ` exceeds `d_th`. Unknown cells block the rays.
pub fn detects_change(base: &RayCaster, scan: &ScanRays, angle_rad: f64, hit: Point2, z: f64, d_th: f64) -> bool {
    let mut hints = ScanHints::new(scan.origin);
    let beam = BeamToClassify { dir: base.direction(angle_rad), hit, range_m: z, d_th_m: d_th };
    detects_change_dir(base, scan, &beam, &mut hints)
}

/// What one beam's classification leaves for the next beam of the same scan (reset per scan):
/// they are close, so where one stopped and the free space around it help the next.
#[derive(Clone, Debug, Default)]
pub struct ScanHints {
    /// Where the previous beam's central ray stopped at a blocking cell (or a bound for it).
    pub stop_m: Option<f64>,
    /// Free discs along the previous rays ([`RayCaster::stops_between`]).
    pub discs: FreeDiscs,
}

impl ScanHints {
    /// No hints yet, for rays from `origin`.
    pub fn new(origin: Point2) -> Self {
        let mut h = Self::default();
        h.reset(origin);
        h
    }

    /// Forgets the hints, for the rays of a new scan from `origin`.
    pub fn reset(&mut self, origin: Point2) {
        self.stop_m = None;
        self.discs.reset(origin);
    }
}

/// [`detects_change`] with the beam's direction prepared by `base` (its sine and cosine are
/// reused for the central ray; bit for bit the same answer). `hints` (reset for each scan with
/// the scan's origin): what the previous beams left, updated for the next; any hints give the
/// same answer, good ones save casts.
pub fn detects_change_dir(base: &RayCaster, scan: &ScanRays, beam: &BeamToClassify, hints: &mut ScanHints) -> bool {
    let (origin, increment_rad, n_e, v) = (scan.origin, scan.increment_rad, scan.each_side, scan.spacing_beams);
    let (hit, z, d_th, max_range_m) = (beam.hit, beam.range_m, beam.d_th_m, scan.max_range_m);
    let beam = &beam.dir;
    let incoming = hints.stop_m.take();
    let angle_rad = beam.angle();
    let cast_len = z + d_th + 1e-6;
    let (len, truncated) = if cast_len >= max_range_m { (max_range_m, false) } else { (cast_len, true) };
    // Exact shortcut: an expected point is on a blocking cell (or the ray's start inside one),
    // on the grid's border, or — only for a cast that is not truncated — at the maximum range.
    // With no blocking cell and no border within D_th of p_i (plus a margin far above the
    // rounding of the expected points), none of them can match: a change, without casting.
    if truncated && base.free_radius_m(hit) > d_th + EXPECTED_POINT_SLACK_M {
        hints.stop_m = incoming;
        return true;
    }
    // Exact shortcut: the central ray certainly stops at a blocking cell entered within
    // D_th − slack of z (and before the cast's length): its expected point is then within D_th
    // of p_i (same direction), the beam agrees with the map, without casting.
    let (lo, hi) = (z - d_th + EXPECTED_POINT_SLACK_M, (z + d_th - EXPECTED_POINT_SLACK_M).min(len));
    if base.stops_between(&mut hints.discs, beam, lo, hi, z) {
        hints.stop_m = Some(z);
        return false;
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
            hints.stop_m = central_block;
            return false;
        }
    }
    hints.stop_m = central_block;
    true
}

impl BeamClassifier {
    /// A classifier with empty scratch.
    pub fn new() -> Self {
        Self::default()
    }

    /// Classifies every beam of `scans` (all lidars of one step) against `base` = `M_{i-1}` with
    /// the robot at `robot_in_map`, allowing for the step's pose uncertainty `tol`
    /// ([`StepTolerance::NONE`]: the preset's fixed window and D_th).
    pub fn classify(
        &mut self,
        base: &RayCaster,
        robot_in_map: &Pose2,
        scans: &[LaserScan],
        params: &UpdaterParams,
        tol: &StepTolerance,
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
            let map = base.map();
            if map.geometry().world_to_cell(origin).and_then(|c| map.get(c)) != Some(CellState::Free) {
                counts.occluded_scans += 1;
                counts.n_invalid += scan.len();
                continue;
            }
            let lidar = self.lidars.len() as u32;
            self.lidars.push(LidarFrame {
                origin,
                first_beam: self.beams.len(),
                beam_count: scan.len(),
                angle0_rad: lidar_in_map.yaw + scan.angle_min_rad,
                increment_rad: scan.angle_increment_rad,
            });
            let rays = ScanRays::new(origin, scan.angle_increment_rad, scan.range_max_m as f64, params);
            self.hints.reset(origin);
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
                        walk_from_m: f64::INFINITY,
                    });
                    continue;
                }
                counts.n_valid += 1;
                let dir = base.direction(angle_rad);
                let (s, c) = (dir.sin(), dir.cos());
                let hit = Point2::new(origin.x + z * c, origin.y + z * s);
                let d_th_m = params.change_distance_m(z) + tol.change_distance_margin_m();
                let beam = BeamToClassify { dir, hit, range_m: z, d_th_m };
                let changed = if tol.is_none() {
                    detects_change_dir(base, &rays, &beam, &mut self.hints)
                } else {
                    let wide = rays.widened(tol.window_rad(z, rays.window_rad()));
                    detects_change_dir(base, &wide, &beam, &mut self.hints)
                };
                let class = if changed { BeamClass::Changed } else { BeamClass::Unchanged };
                self.beams.push(Beam {
                    lidar,
                    range_m: z,
                    angle_rad,
                    hit,
                    class,
                    near_buffer_m: f64::INFINITY,
                    walk_from_m: f64::INFINITY,
                });
            }
        }
        self.filter_outliers(params.min_change_run as usize);
        self.mark_near_changes(params.skip_near_changes_beams as usize);
        counts.n_dc = self.beams.iter().filter(|b| b.class == BeamClass::Changed).count();
        counts
    }

    /// Marks the beams whose direction crosses one of the squares (lower-left cell, side in
    /// cells) of `tiles` in `grid`'s geometry (`near_buffer_m`; the others cannot reach a
    /// buffered cell), and those whose direction crosses one of the `boxes` (lowest and highest
    /// cell, inclusive: the buffered cells of each tile) (`walk_from_m`; only their walks can
    /// meet a buffered cell).
    pub fn mark_near(
        &mut self,
        geometry: &mapkeeper_grid::GridGeometry,
        tiles: impl Iterator<Item = CellCoord> + Clone,
        side: i32,
        boxes: impl Iterator<Item = (CellCoord, CellCoord)> + Clone,
    ) {
        for b in &mut self.beams {
            b.near_buffer_m = f64::INFINITY;
            b.walk_from_m = f64::INFINITY;
        }
        let r = geometry.resolution_m();
        let tile_m = side as f64 * r;
        for f in &self.lidars {
            let beams = &mut self.beams[f.first_beam..f.first_beam + f.beam_count];
            let inc = f.increment_rad.abs();
            if beams.is_empty() || inc.is_nan() || inc <= 0.0 {
                continue;
            }
            for t in tiles.clone() {
                let (lo, hi) = ((t.ix as f64, t.iy as f64), ((t.ix + side) as f64, (t.iy + side) as f64));
                if mark_square(geometry, f, beams, lo, hi, tile_m, |b, d| b.near_buffer_m = b.near_buffer_m.min(d)) {
                    break;
                }
            }
            for (c0, c1) in boxes.clone() {
                let (lo, hi) = ((c0.ix as f64, c0.iy as f64), ((c1.ix + 1) as f64, (c1.iy + 1) as f64));
                let size_m = (hi.0 - lo.0).max(hi.1 - lo.1) * r;
                mark_square(geometry, f, beams, lo, hi, size_m, |b, d| b.walk_from_m = b.walk_from_m.min(d));
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

/// Calls `mark(beam, distance)` for every beam of lidar frame `f` whose direction may cross the
/// square `[lo.0, hi.0] × [lo.1, hi.1]` (grid coordinates), with the lidar's distance to the
/// square, metres: the beams within the angular span of its corners, widened by one beam
/// increment (far above rounding). If the lidar is within `near_m` of the square's centre,
/// every beam is marked with distance 0 and `true` is returned.
fn mark_square(
    geometry: &mapkeeper_grid::GridGeometry,
    f: &LidarFrame,
    beams: &mut [Beam],
    lo: (f64, f64),
    hi: (f64, f64),
    near_m: f64,
    mut mark: impl FnMut(&mut Beam, f64),
) -> bool {
    use std::f64::consts::{PI, TAU};
    let inc = f.increment_rad.abs();
    let corners = [(lo.0, lo.1), (hi.0, lo.1), (lo.0, hi.1), (hi.0, hi.1)].map(|(u, v)| geometry.grid_to_world(u, v));
    let centre = geometry.grid_to_world((lo.0 + hi.0) / 2.0, (lo.1 + hi.1) / 2.0);
    if centre.distance(f.origin) <= near_m {
        beams.iter_mut().for_each(|b| mark(b, 0.0));
        return true;
    }
    // Distance from the lidar to the square (grid coordinates, then metres).
    let (u, v) = geometry.world_to_grid(f.origin);
    let du = (lo.0 - u).max(u - hi.0).max(0.0);
    let dv = (lo.1 - v).max(v - hi.1).max(0.0);
    let dist_m = (du * du + dv * dv).sqrt() * geometry.resolution_m();
    let ac = (centre.y - f.origin.y).atan2(centre.x - f.origin.x);
    let half = corners
        .iter()
        .map(|c| mapkeeper_grid::angle_diff((c.y - f.origin.y).atan2(c.x - f.origin.x), ac).abs())
        .fold(0.0, f64::max)
        + inc;
    // Offset of the square's direction from beam 0, along the scan's sweep, in [0, 2π).
    let off =
        if f.increment_rad > 0.0 { (ac - f.angle0_rad).rem_euclid(TAU) } else { (f.angle0_rad - ac).rem_euclid(TAU) };
    for shift in [-TAU, 0.0, TAU] {
        let lo = ((off + shift - half) / inc).ceil().max(0.0);
        let hi = ((off + shift + half) / inc).floor().min(beams.len() as f64 - 1.0);
        if lo <= hi && half < PI {
            beams[lo as usize..=hi as usize].iter_mut().for_each(|b| mark(b, dist_m));
        } else if half >= PI {
            beams.iter_mut().for_each(|b| mark(b, dist_m));
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::support::cell_buffers::CellBuffers;
    use mapkeeper_grid::{GridGeometry, traverse};
    use std::ops::ControlFlow;

    /// Every beam whose walk meets a buffered cell is marked, no farther than that cell.
    #[test]
    fn marks_every_beam_whose_walk_meets_a_buffer() {
        for yaw in [0.0, 0.35] {
            let g = GridGeometry::new(240, 200, 0.05, Pose2::new(-2.0, 1.0, yaw)).unwrap();
            let mut buffers = CellBuffers::new();
            let mut state = 0x9e37_79b9_7f4a_7c15u64;
            let mut next = move || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state
            };
            for (cx, cy) in [(60, 50), (150, 120), (200, 40), (90, 170), (121, 101)] {
                for _ in 0..25 {
                    let c = CellCoord::new(cx + (next() % 9) as i32 - 4, cy + (next() % 9) as i32 - 4);
                    buffers.ensure(g.index(c).unwrap() as u32, c);
                }
            }
            for origin_cell in [(120.3, 100.7), (30.5, 20.2), (123.9, 99.1)] {
                let origin = g.grid_to_world(origin_cell.0, origin_cell.1);
                let inc = 0.5f64.to_radians();
                let angle0 = 0.3;
                let mut c = BeamClassifier::new();
                c.lidars.push(LidarFrame {
                    origin,
                    first_beam: 0,
                    beam_count: 720,
                    angle0_rad: angle0,
                    increment_rad: inc,
                });
                for i in 0..720 {
                    let a = angle0 + i as f64 * inc;
                    let z = 9.0;
                    let hit = Point2::new(origin.x + z * a.cos(), origin.y + z * a.sin());
                    c.beams.push(Beam {
                        lidar: 0,
                        range_m: z,
                        angle_rad: a,
                        hit,
                        class: BeamClass::Unchanged,
                        near_buffer_m: 0.0,
                        walk_from_m: 0.0,
                    });
                }
                c.mark_near(&g, buffers.tile_origins(), CellBuffers::TILE_CELLS, buffers.tile_boxes());
                let mut met = 0;
                for b in &c.beams {
                    let mut first = None;
                    let _ = traverse(&g, origin, b.hit, |cell| {
                        if buffers.probe().contains(cell) {
                            first = Some(cell);
                            return ControlFlow::Break(());
                        }
                        ControlFlow::Continue(())
                    });
                    if let Some(cell) = first {
                        met += 1;
                        // Distance to the cell's square.
                        let (u, v) = g.world_to_grid(origin);
                        let du = (cell.ix as f64 - u).max(u - cell.ix as f64 - 1.0).max(0.0);
                        let dv = (cell.iy as f64 - v).max(v - cell.iy as f64 - 1.0).max(0.0);
                        let d = du.hypot(dv) * g.resolution_m() + 1e-9;
                        assert!(b.near_buffer_m <= d, "beam at {}: near {} > {d}", b.angle_rad, b.near_buffer_m);
                        assert!(b.walk_from_m <= d, "beam at {}: walk from {} > {d}", b.angle_rad, b.walk_from_m);
                    }
                }
                assert!(met > 20, "{met} beams meet a buffer");
                // Away from the buffers, boxes are tighter than tiles: some beams near a tile never walk.
                if origin_cell.0 < 100.0 {
                    assert!(c.beams.iter().any(|b| b.near_buffer_m.is_finite() && b.walk_from_m.is_infinite()));
                }
            }
        }
    }
}
