//! The filter's parameters: one struct, [`FilterParams`], with the odometry noise model nested in
//! it as [`MotionParams`]. Four named presets ([`LOCALISER_PRESETS`], [`FilterParams::preset`]):
//! `mapkeeper` (the default: Robotnik's Summit-XL AMCL values plus this project's extras), `amcl`
//! (ROS / Nav2 `amcl`'s choices, none of the extras), `amcl-joint` (the second release's `amcl`)
//! and `mapkeeper-real` (for recorded logs: `mapkeeper` with the scan-matching front end).

use crate::LocaliserError;
use crate::scan_match::ScanMatchParams;
use mapkeeper_common::ParamError;
use serde::{Deserialize, Serialize};

/// The largest particle count accepted (guards against absurd allocations from a bad file).
pub const MAX_PARTICLES_LIMIT: usize = 1_000_000;

/// The robot base's kinematics, which selects the odometry motion model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kinematics {
    /// Omnidirectional (mecanum) base: translation along any bearing plus an independent
    /// sideways ("strafe") noise term (`alpha5`). The Summit-XL Steel's default.
    #[default]
    Omni,
    /// Differential or skid-steer base: rotate, translate, rotate (Thrun et al. table 5.6).
    Differential,
}

/// Odometry noise: how much variance each kind of motion adds, AMCL's `alpha1`..`alpha5`.
///
/// The alphas multiply *variances* (the corrected forms), e.g. for the differential model
/// `σ_rot1 = sqrt(alpha1·rot1² + alpha2·trans²)`, never the legacy `alpha1·|rot1| + ...` that
/// treats a variance as a standard deviation. Rotations in radians, translations in metres.
///
/// ```
/// use mapkeeper_localiser::MotionParams;
/// let mut m = MotionParams::default();
/// assert_eq!((m.alpha1, m.alpha2, m.alpha3, m.alpha4, m.alpha5), (0.2, 0.2, 0.8, 0.2, 0.1));
/// m.alpha3 = 0.1;
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MotionParams {
    /// Rotation variance per squared rotation, rad²/rad². Default 0.2.
    pub alpha1: f64,
    /// Rotation variance per squared translation, rad²/m². Default 0.2.
    pub alpha2: f64,
    /// Translation variance per squared translation, m²/m². Default 0.8.
    pub alpha3: f64,
    /// Translation variance per squared rotation, m²/rad². Default 0.2.
    pub alpha4: f64,
    /// Sideways (strafe) variance per squared translation, m²/m², omni model only. Default 0.1.
    pub alpha5: f64,
}

impl Default for MotionParams {
    fn default() -> Self {
        Self { alpha1: 0.2, alpha2: 0.2, alpha3: 0.8, alpha4: 0.2, alpha5: 0.1 }
    }
}

/// What the likelihood field assigns to a beam that ends in an *unknown* cell inside the map.
/// (Beams ending outside the map always get the likelihood of `likelihood_max_dist_m`.)
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UnknownCells {
    /// The distance to the nearest occupied cell, as for free cells (AMCL's behaviour). Unknown
    /// cells are mostly obstacle interiors, so this is the penetration depth: a beam that
    /// overshoots a box surface by 3 cm of range noise is scored 3 cm off, not as a miss.
    #[default]
    NearestOccupied,
    /// As far as possible (`likelihood_max_dist_m`): only known structure supports a pose.
    MaxDistance,
}

/// How the beams' likelihoods `p(z)` combine into a particle's weight factor.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BeamCombination {
    /// The tempered product `Π p(z)^e` (`e = likelihood_exponent`), computed as
    /// `e · Σ ln p(z)`. The `mapkeeper` preset's choice.
    #[default]
    Product,
    /// ROS amcl's ad-hoc combination (`amcl_laser.cpp`, likelihood-field model): per lidar
    /// `1 + Σ p(z)³`, and the lidars' factors multiplied. Not a likelihood; it makes the weights
    /// very flat, so a filter corrects an initial error slowly. `likelihood_exponent` is not used.
    AmclCubeSum,
}

/// Which beams of a scan the sensor update uses (at most about `max_beams` per lidar).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BeamSelection {
    /// `max_beams` beams evenly spaced over the scan's *usable* readings (first and last
    /// included), so a scan with invalid readings still gives `max_beams` beams. The `mapkeeper`
    /// preset's choice.
    #[default]
    EvenlyOverValid,
    /// ROS amcl's: every `step`-th reading over *all* readings, `step = (n − 1) / (max_beams − 1)`
    /// (integer division, at least 1), skipping unusable ones (NaN, below `range_min`, at or beyond
    /// the range limit). A 541-beam scan with `max_beams` 30 gives step 18 and up to 31 beams.
    AmclStride,
}

/// When the odometry has moved enough for a filter update (`update_min_d_m`, `update_min_a_rad`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UpdateGate {
    /// The travelled distance `√(dx² + dy²)` reaches `update_min_d_m`, or the turn reaches
    /// `update_min_a_rad`. The `mapkeeper` preset's choice.
    #[default]
    Distance,
    /// ROS / Nav2 amcl's test (`amcl_node.cpp`): `|dx| > update_min_d_m` or `|dy| >
    /// update_min_d_m` or `|dyaw| > update_min_a_rad`, each a difference of odometry-frame
    /// coordinates since the last filter update. Diagonal travel waits up to √2 × longer.
    AmclPerAxis,
}

/// How the scans of several lidars taken at one step enter the filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LidarUpdates {
    /// All lidars' beams in one sensor update, then one resampling. The `mapkeeper` preset's
    /// choice.
    #[default]
    Joint,
    /// ROS / Nav2 amcl's: each laser's scan is a sensor update of its own, followed by its own
    /// resampling (every `resample_interval` sensor updates), in lidar order; the motion update
    /// runs once, before the first.
    PerLidar,
}

/// How the particles are resampled with KLD sampling.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Resampler {
    /// Complete systematic (low-variance) rounds, each grown until the KLD bound holds: a
    /// particle of weight `w` gets `⌊nw⌋` or `⌈nw⌉` copies. The `mapkeeper` preset's choice.
    #[default]
    SystematicKld,
    /// ROS / Nav2 amcl's (`pf_update_resample`): independent multinomial draws one at a time,
    /// each added to the bin histogram, stopping as soon as the count exceeds the KLD bound of
    /// the bins filled so far (at least `min_particles`, at most `max_particles`). Drawn by
    /// binary search over the cumulative weights, O(N log M), not AMCL's linear scan.
    MultinomialKld,
}

/// Which particle set the cluster estimate is taken from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EstimateFrom {
    /// The weighted set, right after the sensor update. The `mapkeeper` preset's choice.
    #[default]
    WeightedSet,
    /// ROS / Nav2 amcl's: the resampled set (`pf_cluster_stats` at the end of
    /// `pf_update_resample`), uniform weights; the weighted set when no resampling ran.
    ResampledSet,
}

/// The names [`FilterParams::preset`] accepts, the default first.
pub const LOCALISER_PRESETS: [&str; 4] = ["mapkeeper", "amcl", "amcl-joint", "mapkeeper-real"];

/// Every parameter of the filter. Units are in the names; each field's doc gives its default.
///
/// ```
/// use mapkeeper_localiser::{FilterParams, Kinematics};
/// let mut p = FilterParams::default();
/// assert_eq!((p.min_particles, p.max_particles, p.max_beams), (500, 5000, 30));
/// p.kinematics = Kinematics::Differential;
/// p.max_beams = 60;
/// assert!(p.validate().is_ok());
/// p.sigma_hit_m = -1.0;
/// assert!(p.validate().is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FilterParams {
    /// Motion model. Default [`Kinematics::Omni`].
    pub kinematics: Kinematics,
    /// Odometry noise (`alpha1`..`alpha5`). Default 0.2 / 0.2 / 0.8 / 0.2 / 0.1.
    pub motion: MotionParams,
    /// Fewest particles KLD sampling may keep. Default 500.
    pub min_particles: usize,
    /// Most particles KLD sampling may keep (and the count used for any initialisation).
    /// Default 5000.
    pub max_particles: usize,
    /// KLD sampling: maximum error ε between the true and the estimated distribution.
    /// Default 0.05.
    pub kld_err: f64,
    /// KLD sampling: the upper standard normal quantile z used in Fox's bound, given directly
    /// as in AMCL's `kld_z` (0.99, not a probability). Default 0.99.
    pub kld_z: f64,
    /// KLD histogram (and clustering) bin side in x and y, metres. Default 0.5 m.
    pub kld_bin_xy_m: f64,
    /// KLD histogram (and clustering) bin width in yaw, radians. Default 10° (0.1745 rad).
    pub kld_bin_yaw_rad: f64,
    /// Beams used per lidar and update, chosen as `beam_selection` says. Default 30.
    pub max_beams: usize,
    /// How the beams are chosen. Default [`BeamSelection::EvenlyOverValid`] (`amcl`:
    /// [`BeamSelection::AmclStride`]).
    pub beam_selection: BeamSelection,
    /// How the beams' likelihoods combine. Default [`BeamCombination::Product`] (`amcl`:
    /// [`BeamCombination::AmclCubeSum`]).
    pub beam_combination: BeamCombination,
    /// Weight of the Gaussian "hit" term of the likelihood field. Default 0.5.
    pub z_hit: f64,
    /// Weight of the uniform "random" term (spread over `laser_max_range_m`). Default 0.5.
    pub z_rand: f64,
    /// Standard deviation of the hit term, metres. Default 0.2 m.
    pub sigma_hit_m: f64,
    /// Distances to the nearest obstacle are capped here; off-map endpoints get this distance,
    /// metres. Default 2.0 m.
    pub likelihood_max_dist_m: f64,
    /// Range over which the random term is spread, and beams at or beyond it are not used,
    /// metres. Default 30 m (SICK S300).
    pub laser_max_range_m: f64,
    /// Exponent applied to each beam's likelihood, i.e. the factor on `Σ ln p(z)` (1 treats the
    /// beams as independent). Neighbouring beams are strongly correlated, and the plain product
    /// of 60 beams makes the weights so peaked that one particle takes everything (effective
    /// sample size 1) and global localisation locks onto the first plausible pose. Used only
    /// with [`BeamCombination::Product`]. Default 0.1 (`amcl`: 1, unused).
    pub likelihood_exponent: f64,
    /// How endpoints in unknown cells are scored. Default [`UnknownCells::NearestOccupied`].
    pub unknown_cells: UnknownCells,
    /// The filter updates only after the odometry has moved this far since the last update,
    /// metres. Default 0.2 m.
    pub update_min_d_m: f64,
    /// ... or turned this much, radians. Default 0.5 rad.
    pub update_min_a_rad: f64,
    /// Resample after every this many sensor updates (≥ 1). Default 1.
    pub resample_interval: u32,
    /// How the update gates are tested. Default [`UpdateGate::Distance`] (`amcl`:
    /// [`UpdateGate::AmclPerAxis`]).
    pub update_gate: UpdateGate,
    /// How several lidars' scans enter. Default [`LidarUpdates::Joint`] (`amcl`:
    /// [`LidarUpdates::PerLidar`]).
    pub lidar_updates: LidarUpdates,
    /// The resampler. Default [`Resampler::SystematicKld`] (`amcl`: [`Resampler::MultinomialKld`]).
    pub resampler: Resampler,
    /// Where the estimate is read. Default [`EstimateFrom::WeightedSet`] (`amcl`:
    /// [`EstimateFrom::ResampledSet`]).
    pub estimate_from: EstimateFrom,
    /// Augmented MCL: decay rate of the slow average likelihood (0 disables recovery).
    /// Default 0.
    pub recovery_alpha_slow: f64,
    /// Augmented MCL: decay rate of the fast average likelihood (0 disables recovery).
    /// Default 0.
    pub recovery_alpha_fast: f64,
    /// Variance in x of the particle cloud when the filter is started at a pose without a
    /// covariance of its own (`mapkeeper localise`, `mapkeeper converge`), m². Default 0.25
    /// (AMCL's `initial_cov_xx`, σ 0.5 m).
    pub initial_cov_xx_m2: f64,
    /// ... in y, m². Default 0.25 (`initial_cov_yy`).
    pub initial_cov_yy_m2: f64,
    /// ... in yaw, rad². Default (π/12)² = 0.0685 (`initial_cov_aa`).
    pub initial_cov_aa_rad2: f64,
    /// The scan-matching front end (this project's): the particles move by the scan's match
    /// against the map instead of the odometry where the match is accepted
    /// ([`ScanMatchParams`]). Default off; on in `mapkeeper-real`.
    pub scan_match: ScanMatchParams,
}

impl Default for FilterParams {
    fn default() -> Self {
        Self::mapkeeper()
    }
}

impl FilterParams {
    /// The preset called `name` (one of [`LOCALISER_PRESETS`]).
    ///
    /// ```
    /// use mapkeeper_localiser::{BeamCombination, FilterParams};
    /// assert_eq!(FilterParams::preset("mapkeeper").unwrap(), FilterParams::default());
    /// assert_eq!(FilterParams::preset("amcl").unwrap().beam_combination, BeamCombination::AmclCubeSum);
    /// let e = FilterParams::preset("nope").unwrap_err().to_string();
    /// assert!(e.contains("nope") && e.contains("mapkeeper, amcl"), "{e}");
    /// ```
    pub fn preset(name: &str) -> Result<Self, LocaliserError> {
        match name {
            "mapkeeper" => Ok(Self::mapkeeper()),
            "amcl" => Ok(Self::amcl()),
            "amcl-joint" => Ok(Self::amcl_joint()),
            "mapkeeper-real" => Ok(Self::mapkeeper_real()),
            _ => Err(LocaliserError::UnknownPreset { name: name.to_string(), known: LOCALISER_PRESETS.join(", ") }),
        }
    }

    /// ROS1 / Nav2 `amcl` with Robotnik's Summit-XL configuration: the
    /// [`FilterParams::mapkeeper`] values, but AMCL's beam selection ([`BeamSelection::AmclStride`])
    /// and cube-sum weighting ([`BeamCombination::AmclCubeSum`]) instead of the tempered product,
    /// its per-axis update gate, one sensor update and resampling per lidar, its multinomial KLD
    /// resampler and its estimate read from the resampled set. What still differs from ROS amcl
    /// (the corrected motion model, the heaviest cluster's covariance, one seeded random stream)
    /// is listed in `docs/localiser.md`, with the comparison against Nav2's AMCL.
    pub fn amcl() -> Self {
        Self {
            beam_selection: BeamSelection::AmclStride,
            beam_combination: BeamCombination::AmclCubeSum,
            likelihood_exponent: 1.0,
            update_gate: UpdateGate::AmclPerAxis,
            lidar_updates: LidarUpdates::PerLidar,
            resampler: Resampler::MultinomialKld,
            estimate_from: EstimateFrom::ResampledSet,
            ..Self::mapkeeper()
        }
    }

    /// The `amcl` preset as it was before the comparison with Nav2's AMCL (issue 27 item 7):
    /// AMCL's weighting and beam selection, but this project's distance gate, both lidars in one
    /// update, the systematic resampler and the estimate of the weighted set. Kept so that the
    /// second release's figures can be reproduced (`--localiser amcl-joint`).
    pub fn amcl_joint() -> Self {
        Self {
            update_gate: UpdateGate::Distance,
            lidar_updates: LidarUpdates::Joint,
            resampler: Resampler::SystematicKld,
            estimate_from: EstimateFrom::WeightedSet,
            ..Self::amcl()
        }
    }

    /// This project's configuration for recorded logs of real robots (issue 30): the
    /// scan-matching front end on ([`ScanMatchParams`]), so the particles move by the scan's match
    /// against the map and the odometry noise can be small everywhere (alphas 0.005 / 0.005 /
    /// 0.02 / 0.005 / 0.005); 180 beams per lidar in a sharp likelihood (σ_hit 0.05 m, exponent
    /// 0.3); a filter update every 0.05 m or 0.05 rad, so the odometry error between two matches
    /// stays inside the match's window; 500-5,000 particles. For logs whose scans are far apart
    /// (issue 57: a metre, a half turn), the match's yaw window widens with the odometry's motion
    /// since the last update (0.12 rad per metre travelled plus per radian turned, Intel's 99th
    /// percentile of odometry yaw error), and an accepted match's increment is noised as one of at
    /// most 0.5 m / 0.5 rad. The second search for a match the window refused, clipped or fitted
    /// weakly (`refused_window_xy_per_m`) is off: it held Freiburg 079 thinned to 0.25 m on 3 of 5
    /// seeds but raised the dense log's largest error. Tuned on the Intel CARMEN log
    /// (`docs/real-data.md`, where the held-out logs' figures are).
    pub fn mapkeeper_real() -> Self {
        Self {
            max_beams: 180,
            min_particles: 500,
            sigma_hit_m: 0.05,
            likelihood_exponent: 0.3,
            update_min_d_m: 0.05,
            update_min_a_rad: 0.05,
            motion: MotionParams { alpha1: 0.005, alpha2: 0.005, alpha3: 0.02, alpha4: 0.005, alpha5: 0.005 },
            scan_match: ScanMatchParams {
                enabled: true,
                window_yaw_per_motion: 0.12,
                matched_noise_max_motion: Some(0.5),
                ..ScanMatchParams::default()
            },
            ..Self::mapkeeper()
        }
    }

    /// Robotnik's Summit-XL AMCL configuration, as [`FilterParams::mapkeeper`].
    pub fn summit_xl() -> Self {
        Self::mapkeeper()
    }

    /// The default: Robotnik's Summit-XL AMCL values with an omnidirectional base, plus this
    /// project's extras (tempered product of the beams with exponent 0.1, beams evenly spaced
    /// over the valid readings).
    pub fn mapkeeper() -> Self {
        Self {
            kinematics: Kinematics::Omni,
            motion: MotionParams::default(),
            min_particles: 500,
            max_particles: 5000,
            kld_err: 0.05,
            kld_z: 0.99,
            kld_bin_xy_m: 0.5,
            kld_bin_yaw_rad: 10f64.to_radians(),
            max_beams: 30,
            beam_selection: BeamSelection::EvenlyOverValid,
            beam_combination: BeamCombination::Product,
            z_hit: 0.5,
            z_rand: 0.5,
            sigma_hit_m: 0.2,
            likelihood_max_dist_m: 2.0,
            laser_max_range_m: 30.0,
            likelihood_exponent: 0.1,
            unknown_cells: UnknownCells::NearestOccupied,
            update_min_d_m: 0.2,
            update_min_a_rad: 0.5,
            resample_interval: 1,
            update_gate: UpdateGate::Distance,
            lidar_updates: LidarUpdates::Joint,
            resampler: Resampler::SystematicKld,
            estimate_from: EstimateFrom::WeightedSet,
            recovery_alpha_slow: 0.0,
            recovery_alpha_fast: 0.0,
            initial_cov_xx_m2: 0.25,
            initial_cov_yy_m2: 0.25,
            initial_cov_aa_rad2: (std::f64::consts::PI / 12.0).powi(2),
            scan_match: ScanMatchParams::default(),
        }
    }

    /// The initial covariance (x, y, yaw) from `initial_cov_*`.
    pub fn initial_covariance(&self) -> [[f64; 3]; 3] {
        let mut c = [[0.0; 3]; 3];
        c[0][0] = self.initial_cov_xx_m2;
        c[1][1] = self.initial_cov_yy_m2;
        c[2][2] = self.initial_cov_aa_rad2;
        c
    }

    /// Whether augmented-MCL recovery is enabled (both alphas non-zero).
    pub fn recovery_enabled(&self) -> bool {
        self.recovery_alpha_slow > 0.0 && self.recovery_alpha_fast > 0.0
    }

    /// Checks every field; the first violation is returned, nothing is adjusted.
    pub fn validate(&self) -> Result<(), LocaliserError> {
        fn check(name: &'static str, value: f64, ok: bool, requirement: &'static str) -> Result<(), LocaliserError> {
            if ok && value.is_finite() { Ok(()) } else { Err(ParamError::new(name, value, requirement).into()) }
        }
        let m = &self.motion;
        for (name, v) in [
            ("motion.alpha1", m.alpha1),
            ("motion.alpha2", m.alpha2),
            ("motion.alpha3", m.alpha3),
            ("motion.alpha4", m.alpha4),
            ("motion.alpha5", m.alpha5),
        ] {
            check(name, v, v >= 0.0, "must be finite and >= 0")?;
        }
        let (min, max) = (self.min_particles, self.max_particles);
        check("min_particles", min as f64, min >= 1, "must be >= 1")?;
        check("max_particles", max as f64, max <= MAX_PARTICLES_LIMIT, "must be <= 1000000")?;
        if min > max {
            return Err(LocaliserError::ParticleRange { min, max });
        }
        check("kld_err", self.kld_err, self.kld_err > 0.0 && self.kld_err < 1.0, "must be in (0, 1)")?;
        check("kld_z", self.kld_z, self.kld_z > 0.0, "must be finite and > 0")?;
        check("kld_bin_xy_m", self.kld_bin_xy_m, self.kld_bin_xy_m > 0.0, "must be finite and > 0")?;
        let yaw_bin = self.kld_bin_yaw_rad;
        check("kld_bin_yaw_rad", yaw_bin, yaw_bin > 0.0 && yaw_bin <= std::f64::consts::PI, "must be in (0, pi]")?;
        let beams = self.max_beams;
        check("max_beams", beams as f64, (1..=mapkeeper_sensor::MAX_BEAMS).contains(&beams), "must be in 1..=65536")?;
        check("z_hit", self.z_hit, self.z_hit >= 0.0, "must be finite and >= 0")?;
        check("z_rand", self.z_rand, self.z_rand >= 0.0, "must be finite and >= 0")?;
        let sum = self.z_hit + self.z_rand;
        check("z_hit + z_rand", sum, sum > 0.0, "must be > 0")?;
        check("sigma_hit_m", self.sigma_hit_m, self.sigma_hit_m > 0.0, "must be finite and > 0")?;
        let d = self.likelihood_max_dist_m;
        check("likelihood_max_dist_m", d, d > 0.0, "must be finite and > 0")?;
        check("laser_max_range_m", self.laser_max_range_m, self.laser_max_range_m > 0.0, "must be finite and > 0")?;
        let e = self.likelihood_exponent;
        check("likelihood_exponent", e, e > 0.0 && e <= 1.0, "must be in (0, 1]")?;
        check("update_min_d_m", self.update_min_d_m, self.update_min_d_m >= 0.0, "must be finite and >= 0")?;
        check("update_min_a_rad", self.update_min_a_rad, self.update_min_a_rad >= 0.0, "must be finite and >= 0")?;
        let ri = self.resample_interval;
        check("resample_interval", ri as f64, ri >= 1, "must be >= 1")?;
        let (slow, fast) = (self.recovery_alpha_slow, self.recovery_alpha_fast);
        check("recovery_alpha_slow", slow, (0.0..=1.0).contains(&slow), "must be in [0, 1]")?;
        check("recovery_alpha_fast", fast, (0.0..=1.0).contains(&fast), "must be in [0, 1]")?;
        for (name, v) in [
            ("initial_cov_xx_m2", self.initial_cov_xx_m2),
            ("initial_cov_yy_m2", self.initial_cov_yy_m2),
            ("initial_cov_aa_rad2", self.initial_cov_aa_rad2),
        ] {
            check(name, v, v >= 0.0, "must be finite and >= 0")?;
        }
        let both_off = slow == 0.0 && fast == 0.0;
        if !(both_off || (slow > 0.0 && slow < fast)) {
            return Err(LocaliserError::RecoveryAlphas { slow, fast });
        }
        Ok(self.scan_match.validate()?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_match_the_spec() {
        let p = FilterParams::default();
        p.validate().unwrap();
        assert_eq!(p.kld_err, 0.05);
        assert_eq!(p.kld_z, 0.99);
        assert_eq!((p.z_hit, p.z_rand, p.sigma_hit_m, p.likelihood_max_dist_m), (0.5, 0.5, 0.2, 2.0));
        assert_eq!((p.update_min_d_m, p.update_min_a_rad, p.resample_interval), (0.2, 0.5, 1));
        assert!(!p.recovery_enabled());
    }

    #[test]
    fn presets_validate_round_trip_and_differ_only_where_documented() {
        for name in LOCALISER_PRESETS {
            let p = FilterParams::preset(name).unwrap();
            p.validate().unwrap();
            let text = toml::to_string(&p).unwrap();
            assert_eq!(toml::from_str::<FilterParams>(&text).unwrap(), p, "{name}");
        }
        let (m, a) = (FilterParams::mapkeeper(), FilterParams::amcl());
        assert_eq!(m, FilterParams::default());
        assert_eq!(
            (m.beam_combination, m.beam_selection, m.likelihood_exponent),
            (BeamCombination::Product, BeamSelection::EvenlyOverValid, 0.1)
        );
        assert_eq!(
            (a.beam_combination, a.beam_selection, a.likelihood_exponent),
            (BeamCombination::AmclCubeSum, BeamSelection::AmclStride, 1.0)
        );
        assert_eq!(
            (a.update_gate, a.lidar_updates, a.resampler, a.estimate_from),
            (UpdateGate::AmclPerAxis, LidarUpdates::PerLidar, Resampler::MultinomialKld, EstimateFrom::ResampledSet)
        );
        let j = FilterParams::amcl_joint();
        assert_eq!(
            FilterParams {
                beam_combination: a.beam_combination,
                beam_selection: a.beam_selection,
                likelihood_exponent: 1.0,
                ..m
            },
            j
        );
        let same = FilterParams {
            beam_combination: m.beam_combination,
            beam_selection: m.beam_selection,
            likelihood_exponent: 0.1,
            update_gate: m.update_gate,
            lidar_updates: m.lidar_updates,
            resampler: m.resampler,
            estimate_from: m.estimate_from,
            ..a
        };
        assert_eq!(same, m);
        assert_eq!(FilterParams::preset("amcl-joint").unwrap(), j);
        // mapkeeper-real: the scan-matching front end on, and the fields its doc lists.
        let l = FilterParams::preset("mapkeeper-real").unwrap();
        assert!(l.scan_match.enabled && !m.scan_match.enabled && !a.scan_match.enabled);
        let back = FilterParams {
            max_beams: m.max_beams,
            min_particles: m.min_particles,
            sigma_hit_m: m.sigma_hit_m,
            likelihood_exponent: m.likelihood_exponent,
            update_min_d_m: m.update_min_d_m,
            update_min_a_rad: m.update_min_a_rad,
            motion: m.motion,
            scan_match: m.scan_match,
            ..l
        };
        assert_eq!(back, m);
        let text = toml::to_string(&a).unwrap();
        assert!(text.contains("\"amcl_cube_sum\"") && text.contains("\"amcl_stride\""), "{text}");
        let e = FilterParams::preset("nope").unwrap_err();
        assert!(matches!(e, LocaliserError::UnknownPreset { .. }));
        let e = refused(|p| p.initial_cov_aa_rad2 = -1.0);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "initial_cov_aa_rad2"), "{e}");
    }

    fn refused(f: impl FnOnce(&mut FilterParams)) -> LocaliserError {
        let mut p = FilterParams::default();
        f(&mut p);
        p.validate().unwrap_err()
    }

    #[test]
    fn invalid_parameters_are_refused_not_reset() {
        let e = refused(|p| p.sigma_hit_m = 0.0);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "sigma_hit_m"), "{e}");
        let e = refused(|p| p.motion.alpha3 = f64::NAN);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "motion.alpha3"), "{e}");
        let e = refused(|p| p.min_particles = 0);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "min_particles"), "{e}");
        let e = refused(|p| p.min_particles = 6000);
        assert_eq!(e, LocaliserError::ParticleRange { min: 6000, max: 5000 });
        let e = refused(|p| p.kld_err = 0.0);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "kld_err"));
        let e = refused(|p| {
            p.z_hit = 0.0;
            p.z_rand = 0.0;
        });
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "z_hit + z_rand"));
        let e = refused(|p| p.resample_interval = 0);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "resample_interval"));
        let e = refused(|p| p.max_beams = 0);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "max_beams"));
        let e = refused(|p| p.update_min_a_rad = f64::INFINITY);
        assert!(matches!(&e, LocaliserError::InvalidParameter(p) if p.name == "update_min_a_rad"));
        let e = refused(|p| {
            p.recovery_alpha_slow = 0.1;
            p.recovery_alpha_fast = 0.001;
        });
        assert!(matches!(e, LocaliserError::RecoveryAlphas { .. }));
        let e = refused(|p| p.recovery_alpha_fast = 0.1);
        assert!(matches!(e, LocaliserError::RecoveryAlphas { .. }));
        let p = FilterParams { recovery_alpha_slow: 0.001, recovery_alpha_fast: 0.1, ..Default::default() };
        assert!(p.validate().is_ok() && p.recovery_enabled());
    }

    /// The refusal names the field, the value and the requirement; a scan-matching field is
    /// named `scan_match.…`.
    #[test]
    fn a_refusal_names_the_field_the_value_and_the_requirement() {
        let e = refused(|p| p.likelihood_exponent = 1.5);
        assert_eq!(
            e,
            LocaliserError::InvalidParameter(ParamError::new("likelihood_exponent", 1.5, "must be in (0, 1]"))
        );
        assert_eq!(e.to_string(), "parameter likelihood_exponent = 1.5 is invalid: must be in (0, 1]");
        let e = refused(|p| p.scan_match.window_xy_m = -1.0);
        assert_eq!(e.to_string(), "parameter scan_match.window_xy_m = -1 is invalid: must be in [0, 5]");
        let e = refused(|p| p.max_particles = 2_000_000);
        assert_eq!(e.to_string(), "parameter max_particles = 2000000 is invalid: must be <= 1000000");
    }
}
