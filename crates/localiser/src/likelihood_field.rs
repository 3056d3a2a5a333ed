//! The likelihood-field sensor model (Thrun et al. §6.4): a beam's endpoint is scored by its
//! distance `d` to the nearest occupied cell,
//! `p(z) = z_hit · exp(−d² / (2 σ_hit²)) + z_rand / laser_max_range`, and the beams' `p(z)`
//! combine into a particle's log-weight increment as `beam_combination` says: the tempered
//! product `e · Σ ln p(z)` ([`BeamCombination::Product`]) or ROS amcl's per-lidar
//! `ln(1 + Σ p(z)³)` ([`BeamCombination::AmclCubeSum`]).
//!
//! The per-beam term (`e · ln p`, or `p³`) is precomputed once per map for every cell from the
//! exact distance transform ([`mapkeeper_grid::DistanceField`], capped at
//! `likelihood_max_dist_m`) and stored as `f32`, so scoring one beam is a rotation, a floor and
//! one table read. Endpoints outside the map get the value of `likelihood_max_dist_m`; endpoints
//! in unknown cells follow [`UnknownCells`](crate::UnknownCells). As in AMCL, the Gaussian is not
//! normalised (its peak is `z_hit`), so `z_hit` and `z_rand` are directly the mixture's relative
//! weights at a hit.

use crate::params::{BeamCombination, BeamSelection, FilterParams, UnknownCells};
use mapkeeper_grid::{CellState, DistanceField, OccupancyGrid, Point2, Pose2, PreparedPose};
use mapkeeper_sensor::{BeamValidity, LaserScan};

/// Offset that makes a truncating cast act as `floor` for every coordinate of interest (grid
/// sides are at most 2^20 cells): anything below `−OFFSET` lands off the map anyway.
const FLOOR_OFFSET: f64 = (1u64 << 21) as f64;

/// Per-cell term of a beam endpoint, for one map: `e · ln p(z)` or `p(z)³`.
#[derive(Clone, Debug)]
pub struct LikelihoodField {
    width: usize,
    height: usize,
    inv_resolution: f64,
    /// The map frame in the grid's frame, its sine and cosine computed once.
    map_in_grid: PreparedPose,
    combination: BeamCombination,
    values: Vec<f32>,
    off_map_value: f32,
}

/// A beam's likelihood at distance `d_m` from the nearest obstacle:
/// `p(z) = z_hit · exp(−d² / (2 σ_hit²)) + z_rand / laser_max_range_m`.
pub fn beam_likelihood(params: &FilterParams, d_m: f64) -> f64 {
    let s = params.sigma_hit_m;
    params.z_hit * (-(d_m * d_m) / (2.0 * s * s)).exp() + params.z_rand / params.laser_max_range_m
}

/// A beam's score at distance `d_m` from the nearest obstacle under the product combination:
/// `likelihood_exponent · ln p(z)`.
pub fn beam_log_likelihood(params: &FilterParams, d_m: f64) -> f64 {
    params.likelihood_exponent * beam_likelihood(params, d_m).ln()
}

/// The per-beam term stored in the table: `e · ln p(z)` (product) or `p(z)³` (AMCL cube sum).
pub fn beam_term(params: &FilterParams, d_m: f64) -> f64 {
    match params.beam_combination {
        BeamCombination::Product => beam_log_likelihood(params, d_m),
        BeamCombination::AmclCubeSum => beam_likelihood(params, d_m).powi(3),
    }
}

impl LikelihoodField {
    /// Builds the table for `map` (one exact distance transform plus one [`beam_term`] per cell).
    pub fn new(map: &OccupancyGrid, params: &FilterParams) -> Self {
        let geometry = map.geometry();
        let max_d = params.likelihood_max_dist_m;
        let df = DistanceField::to_occupied(map, max_d);
        let far = beam_term(params, max_d) as f32;
        let values = df
            .distances_m()
            .iter()
            .zip(map.cells())
            .map(|(&d, &state)| match (state, params.unknown_cells) {
                (CellState::Unknown, UnknownCells::MaxDistance) => far,
                _ => beam_term(params, d as f64) as f32,
            })
            .collect();
        Self {
            width: geometry.width(),
            height: geometry.height(),
            inv_resolution: 1.0 / geometry.resolution_m(),
            map_in_grid: geometry.origin().inverse().prepare(),
            combination: params.beam_combination,
            values,
            off_map_value: far,
        }
    }

    /// The per-beam term ([`beam_term`]) of an endpoint at a map-frame point.
    pub fn value_at(&self, p_in_map: Point2) -> f32 {
        let g = self.map_in_grid.transform_point(p_in_map);
        self.lookup(g.x * self.inv_resolution, g.y * self.inv_resolution)
    }

    /// The term given to endpoints outside the map.
    pub fn off_map_value(&self) -> f32 {
        self.off_map_value
    }

    #[inline(always)]
    fn lookup(&self, u: f64, v: f64) -> f32 {
        // Truncation after the offset is floor for u, v ≥ −OFFSET; NaN casts to 0 → off map.
        let iu = (u + FLOOR_OFFSET) as i64 - FLOOR_OFFSET as i64;
        let iv = (v + FLOOR_OFFSET) as i64 - FLOOR_OFFSET as i64;
        if (iu as u64) < self.width as u64 && (iv as u64) < self.height as u64 {
            let i = iv as usize * self.width + iu as usize;
            self.values.get(i).copied().unwrap_or(self.off_map_value)
        } else {
            self.off_map_value
        }
    }

    /// The log-weight increment for the robot at `robot_in_map`: `e · Σ ln p` over all beams
    /// (product), or `Σ_lidars ln(1 + Σ_its beams p³)` (AMCL cube sum). No allocation; one
    /// `sin_cos` per call and a handful of flops plus one table read per beam.
    #[inline]
    pub fn log_likelihood(&self, robot_in_map: &Pose2, beams: &BeamSet) -> f64 {
        let frame = self.grid_frame(robot_in_map);
        let sum = |ends: &[[f64; 2]]| {
            let mut sum = 0.0f64;
            for &[ex, ey] in ends {
                sum += self.term(frame, ex, ey);
            }
            sum
        };
        match self.combination {
            BeamCombination::Product => sum(&beams.endpoints_in_robot),
            BeamCombination::AmclCubeSum => beams.groups().map(|g| (1.0 + sum(g)).ln()).sum(),
        }
    }

    /// [`LikelihoodField::log_likelihood`] of every pose in `poses`, into `out` (cleared first),
    /// bit for bit the same values. The sums run beam by beam over all poses rather than pose by
    /// pose: a converged cloud's endpoints of one beam fall in a few cells, so the table reads
    /// hit the cache; each pose's terms are still added in the same order. `frames` is scratch
    /// space kept between calls (no allocation after warm-up).
    pub fn log_likelihoods(&self, poses: &[Pose2], beams: &BeamSet, frames: &mut ParticleFrames, out: &mut Vec<f64>) {
        frames.set(poses, self);
        out.clear();
        match self.combination {
            BeamCombination::Product => {
                out.resize(poses.len(), 0.0);
                self.add_terms(frames, &beams.endpoints_in_robot, out);
            }
            BeamCombination::AmclCubeSum => {
                // `Iterator::sum` of f64 folds from −0.0; every term here is ≥ +0.0 anyway.
                out.resize(poses.len(), -0.0);
                let mut partial = std::mem::take(&mut frames.partial);
                for group in beams.groups() {
                    partial.clear();
                    partial.resize(poses.len(), 0.0);
                    self.add_terms(frames, group, &mut partial);
                    for (total, &s) in out.iter_mut().zip(&partial) {
                        *total += (1.0 + s).ln();
                    }
                }
                frames.partial = partial;
            }
        }
    }

    /// Adds each endpoint's term to each pose's sum, endpoint by endpoint.
    #[inline]
    fn add_terms(&self, frames: &ParticleFrames, ends: &[[f64; 2]], sums: &mut [f64]) {
        for &[ex, ey] in ends {
            for (sum, &frame) in sums.iter_mut().zip(&frames.frames) {
                *sum += self.term(frame, ex, ey);
            }
        }
    }

    /// The robot's frame in grid cells: its position, and its yaw's cosine and sine scaled by
    /// the inverse resolution (one `sin_cos`).
    #[inline]
    fn grid_frame(&self, robot_in_map: &Pose2) -> [f64; 4] {
        let g = self.map_in_grid.compose(robot_in_map);
        let (s, c) = g.yaw.sin_cos();
        let k = self.inv_resolution;
        [g.x * k, g.y * k, c * k, s * k]
    }

    /// The term of the endpoint `(ex, ey)` (robot frame) for the robot at `frame`.
    #[inline(always)]
    fn term(&self, [px, py, c, s]: [f64; 4], ex: f64, ey: f64) -> f64 {
        self.lookup(px + c * ex - s * ey, py + s * ex + c * ey) as f64
    }
}

/// Scratch space of [`LikelihoodField::log_likelihoods`]: each pose's frame in grid cells, and
/// the partial sums of one group of beams.
#[derive(Clone, Debug, Default)]
pub struct ParticleFrames {
    frames: Vec<[f64; 4]>,
    partial: Vec<f64>,
}

impl ParticleFrames {
    /// Empty scratch space.
    pub fn new() -> Self {
        Self::default()
    }

    /// The frames of `poses` in `field`'s grid.
    fn set(&mut self, poses: &[Pose2], field: &LikelihoodField) {
        self.frames.clear();
        self.frames.extend(poses.iter().map(|p| field.grid_frame(p)));
    }
}

/// The beam endpoints of one update, in the robot frame (lidar extrinsics applied once per
/// update, not per particle). Reused between updates: no allocation after warm-up.
#[derive(Clone, Debug, Default)]
pub struct BeamSet {
    endpoints_in_robot: Vec<[f64; 2]>,
    /// End index of each closed group (one group per scan).
    group_ends: Vec<usize>,
}

impl BeamSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Removes every beam (keeps the capacity).
    pub fn clear(&mut self) {
        self.endpoints_in_robot.clear();
        self.group_ends.clear();
    }

    /// Closes the current group of beams (the beams pushed since the last close): each scan's
    /// beams form one group, which the AMCL cube sum scores as one sensor. An empty group is
    /// not recorded.
    pub fn end_group(&mut self) {
        let n = self.endpoints_in_robot.len();
        if self.group_ends.last().copied().unwrap_or(0) < n {
            self.group_ends.push(n);
        }
    }

    /// The groups' endpoints, in order; beams pushed after the last [`BeamSet::end_group`] form
    /// a last group.
    fn groups(&self) -> impl Iterator<Item = &[[f64; 2]]> {
        let n = self.endpoints_in_robot.len();
        let open = self.group_ends.last().copied().unwrap_or(0) < n;
        let ends = self.group_ends.iter().copied().chain(open.then_some(n));
        let mut start = 0;
        ends.map(move |end| {
            let g = &self.endpoints_in_robot[start..end];
            start = end;
            g
        })
    }

    /// Number of beams.
    pub fn len(&self) -> usize {
        self.endpoints_in_robot.len()
    }

    /// Whether the set is empty.
    pub fn is_empty(&self) -> bool {
        self.endpoints_in_robot.is_empty()
    }

    /// Every beam endpoint in the robot frame, `[x, y]` metres, in the order added.
    pub fn endpoints(&self) -> &[[f64; 2]] {
        &self.endpoints_in_robot
    }

    /// Adds one endpoint given in the robot frame.
    pub fn push(&mut self, endpoint_in_robot: Point2) {
        self.endpoints_in_robot.push([endpoint_in_robot.x, endpoint_in_robot.y]);
    }

    /// Adds the beams of `scan` chosen by `selection` (about `max_beams`, readings at or beyond
    /// `max_range_m` and invalid ones skipped) as one group. Returns how many were added. The
    /// scan's header must be valid ([`LaserScan::validate`]).
    pub fn add_scan(
        &mut self,
        scan: &LaserScan,
        max_beams: usize,
        max_range_m: f64,
        selection: BeamSelection,
    ) -> usize {
        let before = self.len();
        match selection {
            BeamSelection::EvenlyOverValid => self.add_evenly(scan, max_beams, max_range_m),
            BeamSelection::AmclStride => self.add_stride(scan, max_beams, max_range_m),
        }
        self.end_group();
        self.len() - before
    }

    fn push_beam(&mut self, scan: &LaserScan, i: usize, r: f32) {
        let a = scan.beam_angle(i as f64);
        let p = Point2::new(r as f64 * a.cos(), r as f64 * a.sin());
        self.push(scan.lidar_in_robot.transform_point(p));
    }

    /// `max_beams` beams evenly spaced over the usable readings (first and last included).
    fn add_evenly(&mut self, scan: &LaserScan, max_beams: usize, max_range_m: f64) {
        let usable = |r: f32| scan.validity_of(r) == BeamValidity::Valid && (r as f64) < max_range_m;
        let count = scan.ranges_m.iter().filter(|&&r| usable(r)).count();
        let take = count.min(max_beams);
        if take == 0 {
            return;
        }
        let target = |j: usize| if take == 1 { (count - 1) / 2 } else { j * (count - 1) / (take - 1) };
        let (mut valid_seen, mut j) = (0usize, 0usize);
        for (i, &r) in scan.ranges_m.iter().enumerate() {
            if !usable(r) {
                continue;
            }
            if valid_seen == target(j) {
                self.push_beam(scan, i, r);
                j += 1;
                if j == take {
                    break;
                }
            }
            valid_seen += 1;
        }
    }

    /// AMCL's stride `(n − 1) / (max_beams − 1)` over all readings, unusable ones skipped.
    fn add_stride(&mut self, scan: &LaserScan, max_beams: usize, max_range_m: f64) {
        let n = scan.ranges_m.len();
        let step = if max_beams <= 1 { n.max(1) } else { ((n.saturating_sub(1)) / (max_beams - 1)).max(1) };
        for i in (0..n).step_by(step) {
            let r = scan.ranges_m[i];
            if scan.validity_of(r) == BeamValidity::Valid && (r as f64) < max_range_m {
                self.push_beam(scan, i, r);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mapkeeper_grid::{CellCoord, GridGeometry};

    fn room() -> OccupancyGrid {
        // 2 m × 1 m at 0.1 m, wall column at ix = 15 (x ∈ [1.5, 1.6)), unknown block beyond.
        let g = GridGeometry::new(20, 10, 0.1, Pose2::new(-1.0, 0.0, 0.0)).unwrap();
        let mut m = OccupancyGrid::filled(g, CellState::Free);
        for iy in 0..10 {
            m.set(CellCoord::new(15, iy), CellState::Occupied);
            for ix in 16..20 {
                m.set(CellCoord::new(ix, iy), CellState::Unknown);
            }
        }
        m
    }

    #[test]
    fn table_matches_the_formula() {
        let p = FilterParams::default();
        let f = LikelihoodField::new(&room(), &p);
        // The wall cell in the map frame is x ∈ [0.5, 0.6).
        let hit = (0.1 * (0.5f64 + 0.5 / 30.0).ln()) as f32;
        assert!((f.value_at(Point2::new(0.55, 0.45)) - hit).abs() < 1e-6);
        // Three cells left of the wall: d = 0.3 m.
        let want = beam_log_likelihood(&p, 0.3) as f32;
        assert!((f.value_at(Point2::new(0.25, 0.45)) - want).abs() < 1e-6);
        // Off the map: the capped distance.
        let far = beam_log_likelihood(&p, 2.0) as f32;
        assert_eq!(f.value_at(Point2::new(-1.01, 0.5)), far);
        assert_eq!(f.value_at(Point2::new(f64::NAN, 0.5)), far);
        // Unknown cell two cells past the wall: nearest occupied by default, far otherwise.
        let u = Point2::new(0.75, 0.45);
        assert!((f.value_at(u) - beam_log_likelihood(&p, 0.2) as f32).abs() < 1e-6);
        let q = FilterParams { unknown_cells: UnknownCells::MaxDistance, ..p };
        assert_eq!(LikelihoodField::new(&room(), &q).value_at(u), far);
    }

    #[test]
    fn pose_score_uses_extrinsics_and_frames() {
        let p = FilterParams::default();
        let f = LikelihoodField::new(&room(), &p);
        let scan = LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::new(0.1, 0.0, std::f64::consts::FRAC_PI_2),
            angle_min_rad: -std::f64::consts::FRAC_PI_2,
            angle_increment_rad: 0.1,
            range_min_m: 0.05,
            range_max_m: 10.0,
            ranges_m: vec![0.45],
            sweep: None,
        };
        let mut beams = BeamSet::new();
        assert_eq!(beams.add_scan(&scan, 30, 30.0, BeamSelection::EvenlyOverValid), 1);
        // Robot at x = 0, so the lidar at x = 0.1 looks along +x and the endpoint is x = 0.55.
        let robot = Pose2::new(0.0, 0.45, 0.0);
        let want = f.value_at(Point2::new(0.55, 0.45)) as f64;
        assert!((f.log_likelihood(&robot, &beams) - want).abs() < 1e-12);
    }

    #[test]
    fn beam_subsampling_is_even_and_skips_invalid() {
        let mut ranges = vec![1.0f32; 11];
        ranges[3] = f32::NAN;
        ranges[7] = 50.0; // beyond range_max
        let scan = LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: 0.0,
            angle_increment_rad: 0.1,
            range_min_m: 0.05,
            range_max_m: 30.0,
            ranges_m: ranges,
            sweep: None,
        };
        let mut beams = BeamSet::new();
        // 9 valid beams (0,1,2,4,5,6,8,9,10); 3 evenly spaced: valid ranks 0, 4, 8 = beams 0, 5, 10.
        assert_eq!(beams.add_scan(&scan, 3, 30.0, BeamSelection::EvenlyOverValid), 3);
        let angles: Vec<f64> = beams.endpoints_in_robot.iter().map(|e| e[1].atan2(e[0])).collect();
        for (a, want) in angles.iter().zip([0.0, 0.5, 1.0]) {
            assert!((a - want).abs() < 1e-9, "{angles:?}");
        }
        beams.clear();
        assert_eq!(beams.add_scan(&scan, 100, 30.0, BeamSelection::EvenlyOverValid), 9);
        beams.clear();
        assert_eq!(beams.add_scan(&scan, 100, 0.5, BeamSelection::EvenlyOverValid), 0);
    }

    #[test]
    fn amcl_stride_takes_every_step_th_reading_over_all_readings() {
        let mut ranges = vec![1.0f32; 11];
        ranges[5] = f32::NAN;
        ranges[8] = 0.01; // below range_min
        let scan = LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: 0.0,
            angle_increment_rad: 0.1,
            range_min_m: 0.05,
            range_max_m: 30.0,
            ranges_m: ranges,
            sweep: None,
        };
        let mut beams = BeamSet::new();
        // step = (11 − 1) / (4 − 1) = 3: readings 0, 3, 6, 9 (none invalid).
        assert_eq!(beams.add_scan(&scan, 4, 30.0, BeamSelection::AmclStride), 4);
        // step = 10 / 5 = 2: readings 0, 2, 4, 6, 8, 10; 8 is below range_min: 5 beams.
        beams.clear();
        assert_eq!(beams.add_scan(&scan, 6, 30.0, BeamSelection::AmclStride), 5);
        let angles: Vec<f64> = beams.endpoints_in_robot.iter().map(|e| e[1].atan2(e[0])).collect();
        for (a, want) in angles.iter().zip([0.0, 0.2, 0.4, 0.6, 1.0]) {
            assert!((a - want).abs() < 1e-9, "{angles:?}");
        }
        // step = 10 / 2 = 5: readings 0, 5, 10; 5 is NaN.
        beams.clear();
        assert_eq!(beams.add_scan(&scan, 3, 30.0, BeamSelection::AmclStride), 2);
        // 541 readings, 30 beams: step 18, 31 beams (AMCL's own count).
        let s300 = LaserScan { ranges_m: vec![2.0; 541], angle_increment_rad: 0.005, ..scan };
        beams.clear();
        assert_eq!(beams.add_scan(&s300, 30, 30.0, BeamSelection::AmclStride), 31);
        beams.clear();
        assert_eq!(beams.add_scan(&s300, 1, 30.0, BeamSelection::AmclStride), 1);
    }

    #[test]
    fn the_batch_gives_each_pose_s_score_bit_for_bit() {
        // Poses on and off the map, yaws all round, two lidars' groups and an open last group.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move |lo: f64, hi: f64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            lo + (hi - lo) * (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let poses: Vec<Pose2> =
            (0..300).map(|_| Pose2::new(next(-1.5, 1.5), next(-0.5, 1.5), next(-4.0, 4.0))).collect();
        let mut beams = BeamSet::new();
        for group in [7, 12, 5] {
            for _ in 0..group {
                beams.push(Point2::new(next(-3.0, 3.0), next(-3.0, 3.0)));
            }
            if group != 5 {
                beams.end_group();
            }
        }
        let (mut frames, mut out) = (ParticleFrames::new(), vec![1.0; 3]);
        for params in [FilterParams::amcl(), FilterParams::mapkeeper(), FilterParams::default()] {
            let f = LikelihoodField::new(&room(), &params);
            for n in [0, 1, poses.len()] {
                f.log_likelihoods(&poses[..n], &beams, &mut frames, &mut out);
                let want: Vec<u64> = poses[..n].iter().map(|p| f.log_likelihood(p, &beams).to_bits()).collect();
                let got: Vec<u64> = out.iter().map(|v| v.to_bits()).collect();
                assert_eq!(got, want, "{:?}, {n} poses", params.beam_combination);
            }
        }
        // No beams: every pose scores zero, as one at a time.
        scores_without_beams(&poses);
    }

    fn scores_without_beams(poses: &[Pose2]) {
        let f = LikelihoodField::new(&room(), &FilterParams::amcl());
        let (mut frames, mut out) = (ParticleFrames::new(), Vec::new());
        f.log_likelihoods(poses, &BeamSet::new(), &mut frames, &mut out);
        assert_eq!(out.len(), poses.len());
        for (p, v) in poses.iter().zip(&out) {
            assert_eq!(v.to_bits(), f.log_likelihood(p, &BeamSet::new()).to_bits());
        }
    }

    #[test]
    fn cube_sum_matches_a_hand_computation() {
        // Three beams of one lidar ending 0.0 m, 0.1 m and 0.3 m in front of the wall (x = 0.5),
        // and one beam of a second lidar ending off the map.
        let p = FilterParams::amcl();
        let f = LikelihoodField::new(&room(), &p);
        let mut beams = BeamSet::new();
        for x in [0.55, 0.45, 0.25] {
            beams.push(Point2::new(x, 0.0));
        }
        beams.end_group();
        let robot = Pose2::new(0.0, 0.45, 0.0);
        // By hand: pz = 0.5·exp(−d²/(2·0.2²)) + 0.5/30, d = 0, 0.1, 0.3 (cell centres 0.05 m off
        // are in the wall cell, 0.1 m and 0.3 m from it).
        let pz = |d: f64| 0.5 * (-(d * d) / 0.08).exp() + 0.5 / 30.0;
        let want = 1.0 + pz(0.0).powi(3) + pz(0.1).powi(3) + pz(0.3).powi(3);
        assert!((pz(0.0) - 0.516_666_666_7).abs() < 1e-9);
        let got = f.log_likelihood(&robot, &beams);
        assert!((got - want.ln()).abs() < 1e-6, "{got} vs {}", want.ln());
        // A second group multiplies its own 1 + Σ p³: off the map, d = max distance 2 m.
        beams.push(Point2::new(-5.0, 0.0));
        beams.end_group();
        let want2 = want.ln() + (1.0 + pz(2.0).powi(3)).ln();
        assert!((f.log_likelihood(&robot, &beams) - want2).abs() < 1e-6);
        // The product combination of the same beams is the sum of e·ln p.
        let q = FilterParams::mapkeeper();
        let g = LikelihoodField::new(&room(), &q);
        let prod: f64 = [0.0, 0.1, 0.3, 2.0].iter().map(|&d| 0.1 * pz(d).ln()).sum();
        assert!((g.log_likelihood(&robot, &beams) - prod).abs() < 1e-5);
    }
}
