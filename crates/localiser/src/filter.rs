//! The particle filter: odometry-driven prediction, likelihood-field weighting (all lidars at
//! once, or one sensor update per lidar as AMCL), KLD-sampling resampling (complete systematic
//! rounds, or AMCL's sequential multinomial draws) with optional augmented-MCL recovery, and the
//! clustered estimate.

use crate::LocaliserError;
use crate::cluster::{ClusterScratch, best_cluster};
use crate::kld::{BinKey, Bins, count_bins, kld_bound};
use crate::likelihood_field::{BeamSet, LikelihoodField, ParticleFrames};
use crate::motion_model::{OdometryDelta, sample_motion_with_noise_of};
use crate::params::{BeamSelection, EstimateFrom, FilterParams, LidarUpdates, Resampler, UpdateGate};
use crate::resample::{multinomial_draw, systematic_resample};
use crate::scan_match::{COARSE_YAW_STEP_RAD, Match, ScanMatcher};
use mapkeeper_grid::{CellState, GridGeometry, OccupancyGrid, Pose2, wrap_angle};
use mapkeeper_sensor::LaserScan;
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rand::rngs::ChaCha8Rng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

mod state;
pub use state::FilterState;

/// A 3×3 covariance of (x m, y m, yaw rad), row-major.
pub type Covariance3 = [[f64; 3]; 3];

/// The filter's pose estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Weighted mean of the heaviest particle cluster, extrapolated by odometry to the time of
    /// the latest [`Localiser::update`] call.
    pub pose_in_map: Pose2,
    /// Covariance of (x, y, yaw) within that cluster at the last filter update (m², m·rad, rad²).
    pub covariance: Covariance3,
    /// Share of the particle weight in that cluster, in [0, 1].
    pub cluster_weight: f64,
    /// Number of particle clusters at the last filter update.
    pub clusters: usize,
}

impl Estimate {
    /// Trace of the position block (x, y), m².
    pub fn position_variance_m2(&self) -> f64 {
        self.covariance[0][0] + self.covariance[1][1]
    }

    /// Largest eigenvalue of the full 3×3 covariance (mixed units, as in AMCL's diagnostics).
    pub fn lambda_max(&self) -> f64 {
        let m = Matrix3::from_fn(|r, c| self.covariance[r][c]);
        SymmetricEigen::new(m).eigenvalues.max()
    }
}

/// How the weights degenerated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Degeneracy {
    /// Every particle's likelihood underflowed to zero (the scan fits no particle).
    AllWeightsZero,
    /// Every weight is zero or NaN, at least one NaN.
    NonFiniteWeights {
        /// Particles whose weight was NaN.
        nan_count: usize,
    },
}

/// What the filter did about a degeneracy.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Recovery {
    /// The scan was ignored for weighting: the moved particles keep uniform weights and no
    /// resampling happens, so the next scans can re-concentrate them. (With augmented MCL
    /// enabled, the next resampling injects random particles as usual.)
    UniformWeights,
}

/// What one [`Localiser::update`] call did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateOutcome {
    /// Motion and sensor update ran.
    Updated,
    /// The odometry moved less than `update_min_d_m` and `update_min_a_rad` since the last
    /// filter update: particles untouched, estimate extrapolated by odometry.
    Gated,
    /// No scan had a usable beam: particles untouched, the motion is kept for the next update.
    NoUsableBeams,
    /// The odometry pose was not finite: the call was ignored.
    InvalidOdometry,
    /// The weights degenerated and were recovered as described.
    Degenerate {
        /// What went wrong.
        kind: Degeneracy,
        /// What was done about it.
        recovery: Recovery,
    },
}

/// The result of one [`Localiser::update`] call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateReport {
    /// What happened.
    pub outcome: UpdateOutcome,
    /// Whether the sensor update (weighting) ran: `Updated` or `Degenerate`.
    pub sensor_update: bool,
    /// Whether the particles were resampled.
    pub resampled: bool,
    /// The estimate after the call.
    pub estimate: Estimate,
    /// Effective sample size `1 / Σ wᵢ²` of the weighted set (before resampling) at the last
    /// sensor update.
    pub ess: f64,
    /// Particle count after the call.
    pub particles: usize,
    /// Beams used by the sensor update (all lidars), 0 if none ran.
    pub beams: usize,
    /// Scans skipped because their header is invalid or they have no usable beam.
    pub scans_skipped: usize,
    /// Probability with which resampling replaced a particle by a random one (augmented MCL).
    pub random_injection_prob: f64,
    /// The scan-matching front end's match at this update, if it ran
    /// ([`crate::ScanMatchParams`]); the particles moved by it when it was accepted.
    pub scan_match: Option<Match>,
}

/// What one sensor update did (one per lidar with [`LidarUpdates::PerLidar`]).
struct Correction {
    outcome: UpdateOutcome,
    beams: usize,
    resampled: bool,
    inject: f64,
}

/// The bins filled while drawing (only their count is read, so the order of a hash set does not
/// matter; the hasher is fixed).
type FilledBins = rustc_hash::FxHashSet<BinKey>;

/// The particle-filter localiser. Owns its map model, its particles and its `ChaCha8Rng`.
#[derive(Debug)]
pub struct Localiser {
    params: FilterParams,
    rng: ChaCha8Rng,
    field: LikelihoodField,
    geometry: GridGeometry,
    free_cells: Vec<u32>,
    bins: Bins,
    particles: Vec<Pose2>,
    weights: Vec<f64>,
    odom_at_filter: Option<Pose2>,
    last_odom: Option<Pose2>,
    force_update: bool,
    sensor_updates_since_resample: u32,
    ln_w_slow: f64,
    ln_w_fast: f64,
    filter_estimate: Estimate,
    ess: f64,
    // Scratch, reused between updates.
    beams: BeamSet,
    frames: ParticleFrames,
    log_w: Vec<f64>,
    next: Vec<Pose2>,
    indices: Vec<usize>,
    keys: Vec<BinKey>,
    cumulative: Vec<f64>,
    filled: FilledBins,
    cluster: ClusterScratch,
    /// The scan-matching front end (when enabled) and its beams.
    matcher: Option<ScanMatcher>,
    match_beams: BeamSet,
    last_match: Option<Match>,
}

fn free_cells(map: &OccupancyGrid) -> Vec<u32> {
    map.cells().iter().enumerate().filter(|(_, s)| **s == CellState::Free).map(|(i, _)| i as u32).collect()
}

/// `ln(eᵃ + eᵇ)` without overflow.
fn log_add_exp(a: f64, b: f64) -> f64 {
    let m = a.max(b);
    if m == f64::NEG_INFINITY { m } else { m + ((a - m).exp() + (b - m).exp()).ln() }
}

/// Normalises log-weights into `weights` (log-sum-exp, no underflow); NaN entries count as zero
/// weight. Returns the effective sample size `1 / Σ wᵢ²` and `ln Σ exp(log_w)`, or the
/// degeneracy if no weight is positive.
pub(crate) fn normalise_log_weights(log_w: &[f64], weights: &mut Vec<f64>) -> Result<(f64, f64), Degeneracy> {
    let nan_count = log_w.iter().filter(|v| v.is_nan()).count();
    let max = log_w.iter().copied().filter(|v| !v.is_nan()).fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        // All −∞/NaN (or +∞, which only a broken table could produce).
        return Err(if nan_count > 0 {
            Degeneracy::NonFiniteWeights { nan_count }
        } else {
            Degeneracy::AllWeightsZero
        });
    }
    weights.clear();
    weights.extend(log_w.iter().map(|&lw| if lw.is_nan() { 0.0 } else { (lw - max).exp() }));
    let sum: f64 = weights.iter().sum();
    let mut sum_sq = 0.0;
    for w in weights.iter_mut() {
        *w /= sum;
        sum_sq += *w * *w;
    }
    Ok((1.0 / sum_sq, max + sum.ln()))
}

impl Localiser {
    /// A filter on `map`, its random stream seeded from `rng_seed`. Parameters are validated
    /// here (and only here). The filter starts globally initialised (`max_particles` uniform over
    /// the map's free cells); call [`Localiser::init_pose`] to track from a known pose.
    ///
    /// Fails on invalid parameters or a map without free cells.
    pub fn new(map: &OccupancyGrid, params: FilterParams, rng_seed: u64) -> Result<Self, LocaliserError> {
        params.validate()?;
        let mut l = Self {
            params,
            rng: ChaCha8Rng::seed_from_u64(rng_seed),
            field: LikelihoodField::new(map, &params),
            geometry: *map.geometry(),
            free_cells: free_cells(map),
            bins: Bins::new(params.kld_bin_xy_m, params.kld_bin_yaw_rad),
            particles: Vec::with_capacity(params.max_particles),
            weights: Vec::with_capacity(params.max_particles),
            odom_at_filter: None,
            last_odom: None,
            force_update: true,
            sensor_updates_since_resample: 0,
            ln_w_slow: f64::NEG_INFINITY,
            ln_w_fast: f64::NEG_INFINITY,
            filter_estimate: Estimate {
                pose_in_map: Pose2::IDENTITY,
                covariance: [[0.0; 3]; 3],
                cluster_weight: 0.0,
                clusters: 0,
            },
            ess: 0.0,
            beams: BeamSet::new(),
            frames: ParticleFrames::new(),
            log_w: Vec::new(),
            next: Vec::new(),
            indices: Vec::new(),
            keys: Vec::new(),
            cumulative: Vec::new(),
            filled: FilledBins::default(),
            cluster: ClusterScratch::default(),
            matcher: params.scan_match.enabled.then(|| ScanMatcher::new(map, params.scan_match)),
            match_beams: BeamSet::new(),
            last_match: None,
        };
        l.init_global()?;
        Ok(l)
    }

    /// The parameters in use.
    pub fn params(&self) -> &FilterParams {
        &self.params
    }

    /// The particles' poses in the map frame.
    pub fn particles(&self) -> &[Pose2] {
        &self.particles
    }

    /// The particles' normalised weights.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The current estimate: the heaviest cluster's mean at the last filter update, moved by the
    /// odometry since then.
    pub fn estimate(&self) -> Estimate {
        let mut e = self.filter_estimate;
        if let (Some(at), Some(now)) = (self.odom_at_filter, self.last_odom) {
            e.pose_in_map = e.pose_in_map.compose(&at.between(&now));
        }
        e
    }

    /// Whether [`Localiser::update`] with odometry `robot_in_odom` would run a sensor update
    /// (the update gates open, or an update forced by an initialisation) rather than only
    /// move the estimate by the odometry. Changes nothing.
    pub fn would_update(&self, robot_in_odom: &Pose2) -> bool {
        if !robot_in_odom.is_finite() {
            return false;
        }
        let reference = self.odom_at_filter.unwrap_or(*robot_in_odom);
        let odometry = OdometryDelta::between(&reference, robot_in_odom);
        self.sensor_update_due(&reference, robot_in_odom, &odometry)
    }

    /// Re-initialises at `pose_in_map` with a Gaussian of covariance `covariance` (x m, y m, yaw
    /// rad; symmetric positive semi-definite), `max_particles` particles, uniform weights. The
    /// pose refers to the time of the latest `update` call; the next update always runs.
    pub fn init_pose(&mut self, pose_in_map: Pose2, covariance: Covariance3) -> Result<(), LocaliserError> {
        if !pose_in_map.is_finite() {
            return Err(LocaliserError::NonFinitePose(pose_in_map));
        }
        let m = Matrix3::from_fn(|r, c| covariance[r][c]);
        if m.iter().any(|v| !v.is_finite()) {
            return Err(LocaliserError::BadCovariance("has a non-finite entry"));
        }
        let scale = m.abs().max().max(1e-300);
        if (m - m.transpose()).abs().max() > 1e-9 * scale {
            return Err(LocaliserError::BadCovariance("is not symmetric"));
        }
        let eig = SymmetricEigen::new(m);
        if eig.eigenvalues.min() < -1e-9 * scale {
            return Err(LocaliserError::BadCovariance("is not positive semi-definite"));
        }
        let sqrt_l = eig.eigenvalues.map(|l| l.max(0.0).sqrt());
        let l = eig.eigenvectors * Matrix3::from_diagonal(&sqrt_l);
        self.particles.clear();
        for _ in 0..self.params.max_particles {
            let z = Vector3::from_fn(|_, _| StandardNormal.sample(&mut self.rng));
            let d = l * z;
            self.particles.push(Pose2::new(
                pose_in_map.x + d[0],
                pose_in_map.y + d[1],
                wrap_angle(pose_in_map.yaw + d[2]),
            ));
        }
        self.reset_after_init();
        Ok(())
    }

    /// Re-initialises with `max_particles` particles uniform over the map's free cells (uniform
    /// yaw). Fails if the map has no free cell (the particles are then left as they were).
    pub fn init_global(&mut self) -> Result<(), LocaliserError> {
        if self.free_cells.is_empty() {
            return Err(LocaliserError::NoFreeSpace);
        }
        self.particles.clear();
        for _ in 0..self.params.max_particles {
            if let Some(p) = self.random_free_pose() {
                self.particles.push(p);
            }
        }
        self.reset_after_init();
        Ok(())
    }

    /// Replaces the map (the likelihood table and the free space are rebuilt; O(cells)). The
    /// particles and their weights are kept: the robot has not moved.
    pub fn set_map(&mut self, map: &OccupancyGrid) {
        self.field = LikelihoodField::new(map, &self.params);
        if self.params.scan_match.enabled {
            self.matcher = Some(ScanMatcher::new(map, self.params.scan_match));
        }
        self.geometry = *map.geometry();
        self.free_cells = free_cells(map);
    }

    fn reset_after_init(&mut self) {
        let n = self.particles.len();
        self.weights.clear();
        self.weights.resize(n, 1.0 / n as f64);
        self.odom_at_filter = self.last_odom;
        self.force_update = true;
        self.sensor_updates_since_resample = 0;
        self.ln_w_slow = f64::NEG_INFINITY;
        self.ln_w_fast = f64::NEG_INFINITY;
        self.ess = n as f64;
        self.refresh_estimate();
    }

    fn refresh_estimate(&mut self) {
        let st = best_cluster(&self.particles, &self.weights, &self.bins, &mut self.cluster);
        self.filter_estimate = Estimate {
            pose_in_map: st.mean,
            covariance: st.covariance,
            cluster_weight: st.weight,
            clusters: st.clusters,
        };
    }

    fn random_free_pose(&mut self) -> Option<Pose2> {
        if self.free_cells.is_empty() {
            return None;
        }
        let i = self.free_cells[self.rng.random_range(0..self.free_cells.len())] as usize;
        let c = self.geometry.coord(i);
        let u = c.ix as f64 + self.rng.random::<f64>();
        let v = c.iy as f64 + self.rng.random::<f64>();
        let p = self.geometry.grid_to_world(u, v);
        let yaw = wrap_angle(self.rng.random_range(-PI..PI));
        Some(Pose2::new(p.x, p.y, yaw))
    }

    fn report(
        &self,
        outcome: UpdateOutcome,
        beams: usize,
        scans_skipped: usize,
        resampled: bool,
        inject: f64,
    ) -> UpdateReport {
        let sensor_update = matches!(outcome, UpdateOutcome::Updated | UpdateOutcome::Degenerate { .. });
        UpdateReport {
            outcome,
            sensor_update,
            resampled,
            estimate: self.estimate(),
            ess: self.ess,
            particles: self.particles.len(),
            beams,
            scans_skipped,
            random_injection_prob: inject,
            scan_match: self.last_match,
        }
    }

    /// One filter step: the robot's odometry pose now and the scans taken now (any number of
    /// lidars, each with its `lidar_in_robot`). The particles move by the odometry increment
    /// since the last filter update, are weighted by the scans and resampled, unless the
    /// increment is below the update gates (`update_min_d_m`, `update_min_a_rad`). The first
    /// call, and the first after any initialisation, always updates.
    pub fn update(&mut self, robot_in_odom: Pose2, scans: &[LaserScan]) -> UpdateReport {
        if !robot_in_odom.is_finite() {
            return self.report(UpdateOutcome::InvalidOdometry, 0, 0, false, 0.0);
        }
        self.last_odom = Some(robot_in_odom);
        self.last_match = None;
        let reference = self.odom_at_filter.unwrap_or(robot_in_odom);
        let odometry = OdometryDelta::between(&reference, &robot_in_odom);
        if !self.sensor_update_due(&reference, &robot_in_odom, &odometry) {
            return self.report(UpdateOutcome::Gated, 0, 0, false, 0.0);
        }

        // Beams of every lidar, in the robot frame.
        let skipped = self.collect_beams(scans.iter());
        if self.beams.is_empty() {
            return self.report(UpdateOutcome::NoUsableBeams, 0, skipped, false, 0.0);
        }

        // Prediction, by the scan's match against the map where one is accepted (its noise that
        // of an increment at most `matched_noise_max_motion` long); where a second, wider search
        // found another fit as good, every other particle moves by that one instead, and the
        // scans' likelihood below decides between them.
        let (matched, alternative) = match self.matched_motion(&reference.between(&robot_in_odom), scans) {
            Some((d, alt)) => (Some(d), alt),
            None => (None, None),
        };
        let delta = matched.unwrap_or(odometry);
        let noise_of = |d: OdometryDelta| match (matched, self.params.scan_match.matched_noise_max_motion) {
            (Some(_), Some(max)) => d.shortened_to(max),
            _ => d,
        };
        let moves = [(delta, noise_of(delta)), alternative.map_or((delta, noise_of(delta)), |a| (a, noise_of(a)))];
        let (kin, alphas) = (self.params.kinematics, self.params.motion);
        for (k, p) in self.particles.iter_mut().enumerate() {
            let (d, noise) = &moves[k % 2];
            *p = sample_motion_with_noise_of(kin, d, noise, &alphas, p, &mut self.rng);
        }
        self.odom_at_filter = Some(robot_in_odom);
        self.force_update = false;

        match self.params.lidar_updates {
            LidarUpdates::Joint => {
                let c = self.correct();
                self.report(c.outcome, c.beams, skipped, c.resampled, c.inject)
            }
            LidarUpdates::PerLidar => {
                // One sensor update (and resampling) per scan, in order, as AMCL does for each
                // laser message; scans without usable beams are passed over.
                let mut total = Correction { outcome: UpdateOutcome::Updated, beams: 0, resampled: false, inject: 0.0 };
                for scan in scans {
                    self.collect_beams(std::iter::once(scan));
                    if self.beams.is_empty() {
                        continue;
                    }
                    let c = self.correct();
                    total.beams += c.beams;
                    total.resampled |= c.resampled;
                    total.inject = total.inject.max(c.inject);
                    if matches!(c.outcome, UpdateOutcome::Degenerate { .. }) {
                        total.outcome = c.outcome;
                    }
                }
                self.report(total.outcome, total.beams, skipped, total.resampled, total.inject)
            }
        }
    }

    /// The scan-matching front end: the increment from the last filter estimate to the scan's
    /// match around that estimate moved by `odometry` (an increment in the robot frame), when the
    /// front end is on, the filter is concentrated enough to have a pose to match from, and the
    /// match is accepted; with it, the increment to a second match where a wider search
    /// (`refused_window_xy_per_m`) found another fit that is not clearly better
    /// (`refused_min_inlier_gain`) nor the same pose. Records the match for the report.
    fn matched_motion(
        &mut self,
        odometry: &Pose2,
        scans: &[LaserScan],
    ) -> Option<(OdometryDelta, Option<OdometryDelta>)> {
        let matcher = self.matcher.as_ref()?;
        let sm = &self.params.scan_match;
        let from = self.filter_estimate;
        if from.position_variance_m2().sqrt() > sm.max_position_sd_m {
            return None;
        }
        self.match_beams.clear();
        for scan in scans.iter().filter(|s| s.validate().is_ok()) {
            self.match_beams.add_scan(
                scan,
                sm.max_beams,
                self.params.laser_max_range_m,
                BeamSelection::EvenlyOverValid,
            );
        }
        let predicted = from.pose_in_map.compose(odometry);
        let travel = odometry.x.hypot(odometry.y);
        let window = sm.window_for(travel, odometry.yaw);
        let ends = self.match_beams.endpoints();
        let mut m = matcher.match_scan_within(&predicted, ends, window)?;
        let mut alternative = None;
        let doubtful = !m.accepted || m.at_edge || m.inlier_share < sm.weak_inlier_share;
        if let Some(wide) = sm.refused_window(travel, window).filter(|_| doubtful) {
            // The odometry may have failed beyond the window (a missed reversal, a slip: the
            // match is refused, clipped by the window or weak): a second, wider search. A wider
            // search also finds more wrong fits (look-alike rooms), so its match replaces the
            // first only where the first was refused or it fits clearly better; otherwise both
            // are kept.
            if let Some(second) = matcher.match_scan_within(&predicted, ends, wide).filter(|r| r.accepted) {
                if !m.accepted || second.inlier_share >= m.inlier_share + sm.refused_min_inlier_gain {
                    m = second;
                } else if second.pose_in_map.distance(&m.pose_in_map) > matcher.resolution_m()
                    || wrap_angle(second.pose_in_map.yaw - m.pose_in_map.yaw).abs() > COARSE_YAW_STEP_RAD
                {
                    alternative = Some(OdometryDelta::between(&from.pose_in_map, &second.pose_in_map));
                }
            }
        }
        self.last_match = Some(m);
        m.accepted.then(|| (OdometryDelta::between(&from.pose_in_map, &m.pose_in_map), alternative))
    }

    /// Whether a sensor update runs at odometry `now`: the gates open, or an update forced by an
    /// initialisation or the first reading.
    fn sensor_update_due(&self, reference: &Pose2, now: &Pose2, delta: &OdometryDelta) -> bool {
        self.gate_open(reference, now, delta) || self.force_update || self.odom_at_filter.is_none()
    }

    /// Whether the odometry has moved enough since the last filter update (`update_gate`).
    fn gate_open(&self, reference: &Pose2, now: &Pose2, delta: &OdometryDelta) -> bool {
        let (d, a) = (self.params.update_min_d_m, self.params.update_min_a_rad);
        match self.params.update_gate {
            UpdateGate::Distance => delta.trans_m >= d || delta.rot_rad.abs() >= a,
            UpdateGate::AmclPerAxis => {
                (now.x - reference.x).abs() > d
                    || (now.y - reference.y).abs() > d
                    || wrap_angle(now.yaw - reference.yaw).abs() > a
            }
        }
    }

    /// Fills `self.beams` with the usable beams of `scans`; returns how many scans gave none.
    fn collect_beams<'a>(&mut self, scans: impl Iterator<Item = &'a LaserScan>) -> usize {
        self.beams.clear();
        let mut skipped = 0;
        for scan in scans {
            let added = if scan.validate().is_ok() {
                let p = &self.params;
                self.beams.add_scan(scan, p.max_beams, p.laser_max_range_m, p.beam_selection)
            } else {
                0
            };
            if added == 0 {
                skipped += 1;
            }
        }
        skipped
    }

    /// One sensor update with the beams in `self.beams` (non-empty), then the resampling when
    /// `resample_interval` says so.
    fn correct(&mut self) -> Correction {
        // Correction, in the log domain: ln wᵢ ← ln wᵢ + e·Σ ln p(z | xᵢ) (product) or
        // + Σ_lidars ln(1 + Σ p³) (AMCL cube sum).
        self.field.log_likelihoods(&self.particles, &self.beams, &mut self.frames, &mut self.log_w);
        self.log_w.truncate(self.weights.len());
        for (lw, &w) in self.log_w.iter_mut().zip(&self.weights) {
            *lw += w.ln(); // IEEE addition commutes: ln w + score, bit for bit
        }
        let beams = self.beams.len();
        let (ess, ln_avg) = match normalise_log_weights(&self.log_w, &mut self.weights) {
            Ok(v) => v,
            Err(kind) => {
                // Degenerate: report, recover explicitly, do not resample.
                let n = self.particles.len();
                self.weights.clear();
                self.weights.resize(n, 1.0 / n as f64);
                self.ess = n as f64;
                self.refresh_estimate();
                let outcome = UpdateOutcome::Degenerate { kind, recovery: Recovery::UniformWeights };
                return Correction { outcome, beams, resampled: false, inject: 0.0 };
            }
        };
        self.ess = ess;
        // ln_avg: the average likelihood Σ w_prev·p(z|x) for augmented MCL, as a log.
        let mut inject = 0.0;
        if self.params.recovery_enabled() {
            if self.ln_w_slow == f64::NEG_INFINITY {
                self.ln_w_slow = ln_avg;
                self.ln_w_fast = ln_avg;
            } else {
                let (s, f) = (self.params.recovery_alpha_slow, self.params.recovery_alpha_fast);
                self.ln_w_slow = log_add_exp((1.0 - s).ln() + self.ln_w_slow, s.ln() + ln_avg);
                self.ln_w_fast = log_add_exp((1.0 - f).ln() + self.ln_w_fast, f.ln() + ln_avg);
            }
            let ratio = (self.ln_w_fast - self.ln_w_slow).exp();
            if ratio.is_finite() {
                inject = (1.0 - ratio).max(0.0);
            }
        }
        self.sensor_updates_since_resample += 1;
        let resample = self.sensor_updates_since_resample >= self.params.resample_interval;
        // The estimate of the weighted set, unless the resampled set's replaces it below (the
        // resampling reads no estimate, so skipping it changes nothing).
        if !(resample && self.params.estimate_from == EstimateFrom::ResampledSet) {
            self.refresh_estimate();
        }
        if resample {
            match self.params.resampler {
                Resampler::SystematicKld => self.resample_kld(inject),
                Resampler::MultinomialKld => self.resample_multinomial_kld(inject),
            }
            self.sensor_updates_since_resample = 0;
            if self.params.estimate_from == EstimateFrom::ResampledSet {
                self.refresh_estimate();
            }
        }
        Correction { outcome: UpdateOutcome::Updated, beams, resampled: resample, inject }
    }

    /// AMCL's KLD resampling (`pf_update_resample`): particles are drawn one at a time,
    /// independently, from the weights (replaced by a random free-space pose with probability
    /// `inject`), each added to the bin histogram; drawing stops once the count exceeds the KLD
    /// bound of the bins filled so far (clamped to `[min_particles, max_particles]`; AMCL's
    /// limit is `max_particles` while a single bin is filled) or reaches `max_particles`.
    fn resample_multinomial_kld(&mut self, inject: f64) {
        let (min, max) = (self.params.min_particles, self.params.max_particles);
        self.cumulative.clear();
        let mut run = 0.0;
        for &w in &self.weights {
            run += w;
            self.cumulative.push(run);
        }
        self.next.clear();
        self.filled.clear();
        while self.next.len() < max {
            let injected =
                if inject > 0.0 && self.rng.random::<f64>() < inject { self.random_free_pose() } else { None };
            let pose = match injected {
                Some(p) => p,
                None => self.particles[multinomial_draw(&self.cumulative, self.rng.random::<f64>())],
            };
            self.next.push(pose);
            self.filled.insert(self.bins.key(&pose));
            let k = self.filled.len();
            let limit = if k <= 1 { max } else { kld_bound(k, self.params.kld_err, self.params.kld_z).clamp(min, max) };
            if self.next.len() > limit {
                break;
            }
        }
        std::mem::swap(&mut self.particles, &mut self.next);
        let n = self.particles.len();
        self.weights.clear();
        self.weights.resize(n, 1.0 / n as f64);
    }

    /// KLD-sampling systematic resampling: starting at `min_particles`, resample `n` particles,
    /// count the histogram bins `k` they occupy and grow `n` (at least ×1.5 per round, so the
    /// total work stays O(N)) until `n ≥ kld_bound(k)` or `n = max_particles`. Each round is a
    /// complete systematic resample, hence unbiased. Random free-space particles replace
    /// resampled ones with probability `inject`.
    fn resample_kld(&mut self, inject: f64) {
        let (min, max) = (self.params.min_particles, self.params.max_particles);
        let mut n = min;
        loop {
            let u0 = self.rng.random::<f64>();
            systematic_resample(&self.weights, n, u0, &mut self.indices);
            self.next.clear();
            self.next.extend(self.indices.iter().map(|&i| self.particles[i]));
            if inject > 0.0 {
                for k in 0..self.next.len() {
                    if self.rng.random::<f64>() < inject
                        && let Some(p) = self.random_free_pose()
                    {
                        self.next[k] = p;
                    }
                }
            }
            let k = count_bins(&self.bins, self.next.iter(), &mut self.keys);
            let want = kld_bound(k, self.params.kld_err, self.params.kld_z).clamp(min, max);
            if want <= n || n >= max {
                break;
            }
            n = want.max(n + n / 2).min(max);
        }
        std::mem::swap(&mut self.particles, &mut self.next);
        let n = self.particles.len();
        self.weights.clear();
        self.weights.resize(n, 1.0 / n as f64);
    }
}

#[cfg(test)]
mod tests;
