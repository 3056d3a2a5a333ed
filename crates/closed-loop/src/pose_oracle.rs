//! Where the updater's pose comes from in an experiment ([`UpdaterPoses`],
//! `RunnerParams::updater_poses`; `validate --poses`, `run --poses`): the chain localiser's
//! estimate (the paper, the default), the simulator's true pose, or the true pose plus a noise
//! model ([`PoseNoise`]: white Gaussian noise in x, y and yaw and a slow yaw bias, a first-order
//! Gauss–Markov process). Measures the updater's sensitivity to pose error directly.
//!
//! Truth reaches the session only through an explicit experiment control, [`PoseOracle`]: before
//! each step it hands the session the pose the updater is to be given on that step
//! (`Session::set_updater_pose_override`). The chain localiser runs on untouched (its error is
//! still scored, the baseline too); a pose error hold (`RunnerParams::pose_error`) still offsets
//! the pose the updater is given, now the oracle's; a kidnap of the estimate and the Lost policy
//! still act on the chain localiser only (a recovered pose re-initialises it and becomes the
//! updater's reference pose, and the oracle's pose feeds the updater again from the next step).
//! [`GivenPoseError`] scores the poses the updater was given against the truth.
//!
//! ```
//! use mapkeeper_closed_loop::pose_oracle::{PoseNoise, UpdaterPoses};
//! let mut poses: UpdaterPoses = "true+noise".parse().unwrap();
//! if let UpdaterPoses::TrueNoise(n) = &mut poses {
//!     n.sigma_xy_m = 0.05;
//! }
//! assert!(poses.validate().is_ok());
//! assert_eq!(poses.name(), "true+noise");
//! assert_eq!(UpdaterPoses::default(), UpdaterPoses::Localiser);
//! assert!(UpdaterPoses::TrueNoise(PoseNoise { yaw_bias_tau_s: 0.0, ..PoseNoise::default() }).validate().is_err());
//! ```

use crate::ExperimentError;
use mapkeeper_common::ParamError;
use mapkeeper_grid::{Pose2, angle_diff, wrap_angle};
use mapkeeper_harness::{Control, HarnessError, Observer, RobotControl, Session, SessionStep, Step};
use mapkeeper_sim::seeds::stream_rng;
use rand::rngs::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// The pose source names, as the command line and the parameter files spell them.
pub const UPDATER_POSE_SOURCES: [&str; 3] = ["localiser", "true", "true+noise"];

/// Where the pose the updater is given comes from (`RunnerParams::updater_poses`). In a
/// parameter file: `source = "localiser" | "true" | "true+noise"`, with the [`PoseNoise`]
/// fields beside it for `true+noise`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "source")]
pub enum UpdaterPoses {
    /// The chain localiser's estimate (the paper's setting; the default).
    #[default]
    #[serde(rename = "localiser")]
    Localiser,
    /// The simulator's true pose at each step (an oracle).
    #[serde(rename = "true")]
    True,
    /// The true pose plus [`PoseNoise`].
    #[serde(rename = "true+noise")]
    TrueNoise(PoseNoise),
}

impl UpdaterPoses {
    /// The source's name (one of [`UPDATER_POSE_SOURCES`]).
    pub fn name(&self) -> &'static str {
        match self {
            UpdaterPoses::Localiser => UPDATER_POSE_SOURCES[0],
            UpdaterPoses::True => UPDATER_POSE_SOURCES[1],
            UpdaterPoses::TrueNoise(_) => UPDATER_POSE_SOURCES[2],
        }
    }

    /// Whether this is the default, the chain localiser (not written to parameter files then).
    pub fn is_localiser(&self) -> bool {
        *self == UpdaterPoses::Localiser
    }

    /// Checks the noise model (with `true+noise`).
    pub fn validate(&self) -> Result<(), ExperimentError> {
        match self {
            UpdaterPoses::TrueNoise(n) => n.validate(),
            _ => Ok(()),
        }
    }

    /// One sentence for the reports: which pose fed the updater.
    pub fn describe(&self) -> String {
        match self {
            UpdaterPoses::Localiser => {
                "the chain localiser's estimate (`--poses localiser`, the paper's setting)".into()
            }
            UpdaterPoses::True => "the simulator's true pose at every step (`--poses true`, an oracle)".into(),
            UpdaterPoses::TrueNoise(n) => format!(
                "the simulator's true pose plus noise (`--poses true+noise`): white Gaussian noise of σ {} m in x \
                 and in y and σ {:.3}° in yaw at every step, plus a yaw bias (first-order Gauss–Markov) of \
                 stationary σ {:.3}° and time constant {} s",
                n.sigma_xy_m,
                n.sigma_yaw_rad.to_degrees(),
                n.yaw_bias_sigma_rad.to_degrees(),
                n.yaw_bias_tau_s
            ),
        }
    }
}

impl std::str::FromStr for UpdaterPoses {
    type Err = String;

    /// A source by name; `true+noise` with [`PoseNoise::default`].
    fn from_str(s: &str) -> Result<Self, String> {
        match s.trim() {
            "localiser" => Ok(UpdaterPoses::Localiser),
            "true" => Ok(UpdaterPoses::True),
            "true+noise" => Ok(UpdaterPoses::TrueNoise(PoseNoise::default())),
            _ => Err(format!("unknown pose source '{s}': expected {}", UPDATER_POSE_SOURCES.join(", "))),
        }
    }
}

/// The noise added to the true pose with [`UpdaterPoses::TrueNoise`]: at every step, white
/// Gaussian noise in x and in y (map frame, independent) and in yaw, plus a yaw bias `b` that
/// is a first-order Gauss–Markov process, discretised exactly with each step's `dt`:
/// `b_k = φ b_{k-1} + σ_b √(1 − φ²) w_k`, `φ = exp(−dt/τ)`, `b_0 ~ N(0, σ_b²)` (stationary from
/// the start). The defaults are a well-localised robot's error.
///
/// ```
/// use mapkeeper_closed_loop::pose_oracle::PoseNoise;
/// let noise = PoseNoise { sigma_xy_m: 0.05, ..PoseNoise::default() };
/// assert_eq!(noise.yaw_bias_tau_s, 20.0);
/// assert!(noise.validate().is_ok());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoseNoise {
    /// Standard deviation of the white noise in x and in y, metres. Default 0.02.
    pub sigma_xy_m: f64,
    /// Standard deviation of the white noise in yaw, radians. Default 0.5° (0.008727).
    pub sigma_yaw_rad: f64,
    /// Stationary standard deviation of the yaw bias, radians. Default 0.3° (0.005236).
    pub yaw_bias_sigma_rad: f64,
    /// Time constant of the yaw bias, seconds (> 0). Default 20.
    pub yaw_bias_tau_s: f64,
}

impl Default for PoseNoise {
    fn default() -> Self {
        Self {
            sigma_xy_m: 0.02,
            sigma_yaw_rad: 0.5f64.to_radians(),
            yaw_bias_sigma_rad: 0.3f64.to_radians(),
            yaw_bias_tau_s: 20.0,
        }
    }
}

impl PoseNoise {
    /// Checks every field: finite standard deviations ≥ 0, a finite time constant > 0.
    pub fn validate(&self) -> Result<(), ExperimentError> {
        for (name, v) in [
            ("updater_poses.sigma_xy_m", self.sigma_xy_m),
            ("updater_poses.sigma_yaw_rad", self.sigma_yaw_rad),
            ("updater_poses.yaw_bias_sigma_rad", self.yaw_bias_sigma_rad),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ExperimentError::InvalidParam(ParamError::new(name, v, "must be finite and ≥ 0")));
            }
        }
        let tau = self.yaw_bias_tau_s;
        if !(tau.is_finite() && tau > 0.0) {
            return Err(ExperimentError::InvalidParam(ParamError::new(
                "updater_poses.yaw_bias_tau_s",
                tau,
                "must be finite and > 0 s",
            )));
        }
        Ok(())
    }
}

/// The noise process of [`PoseNoise`] on its own random stream. Each call of
/// [`PoseNoiseProcess::apply`] draws four standard normals, in the order x, y, yaw, bias (also
/// when a standard deviation is 0), so the numbers a run sees depend only on the seed and the
/// number of steps.
#[derive(Debug)]
pub struct PoseNoiseProcess {
    noise: PoseNoise,
    rng: ChaCha8Rng,
    bias_rad: f64,
    last_stamp_ns: Option<u64>,
}

impl PoseNoiseProcess {
    /// The process of `noise` drawing from `rng` (a stream of its own, e.g.
    /// `stream_rng(seed, "poses/W002")`).
    pub fn new(noise: PoseNoise, rng: ChaCha8Rng) -> Self {
        Self { noise, rng, bias_rad: 0.0, last_stamp_ns: None }
    }

    /// The yaw bias now, radians (0 before the first step).
    pub fn bias_rad(&self) -> f64 {
        self.bias_rad
    }

    /// Advances the process to `stamp_ns` (`dt` from the previous call; 0 if the stamps go
    /// back) and returns `truth` with the noise added.
    pub fn apply(&mut self, truth: Pose2, stamp_ns: u64) -> Pose2 {
        let mut z = || -> f64 { StandardNormal.sample(&mut self.rng) };
        let (zx, zy, zyaw, zb) = (z(), z(), z(), z());
        let n = self.noise;
        self.bias_rad = match self.last_stamp_ns {
            None => n.yaw_bias_sigma_rad * zb,
            Some(last) => {
                let dt_s = stamp_ns.saturating_sub(last) as f64 / 1e9;
                let phi = (-dt_s / n.yaw_bias_tau_s).exp();
                // 1 − φ² without cancellation for dt ≪ τ.
                let innovation = (-(-2.0 * dt_s / n.yaw_bias_tau_s).exp_m1()).max(0.0).sqrt();
                phi * self.bias_rad + n.yaw_bias_sigma_rad * innovation * zb
            }
        };
        self.last_stamp_ns = Some(stamp_ns);
        Pose2::new(
            truth.x + n.sigma_xy_m * zx,
            truth.y + n.sigma_xy_m * zy,
            wrap_angle(truth.yaw + n.sigma_yaw_rad * zyaw + self.bias_rad),
        )
    }
}

/// The experiment control that feeds the updater the true pose (plus noise): before each step
/// it sets the session's updater pose override from the step's truth. A step without truth is an
/// error (the oracle needs a source that knows the truth, e.g. the simulator).
#[derive(Debug)]
pub struct PoseOracle {
    noise: Option<PoseNoiseProcess>,
}

impl PoseOracle {
    /// The oracle of `poses` for the run seeded `seed` in the world `label` (the noise's stream
    /// is `poses/<label>`); `None` with [`UpdaterPoses::Localiser`] (nothing to do).
    pub fn new(poses: &UpdaterPoses, seed: u64, label: &str) -> Option<Self> {
        match poses {
            UpdaterPoses::Localiser => None,
            UpdaterPoses::True => Some(Self { noise: None }),
            UpdaterPoses::TrueNoise(n) => {
                Some(Self { noise: Some(PoseNoiseProcess::new(*n, stream_rng(seed, &format!("poses/{label}")))) })
            }
        }
    }
}

impl Control for PoseOracle {
    fn before_step(
        &mut self,
        step: &Step,
        session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let Some(truth) = step.truth else {
            return Err(HarnessError::Unsupported(
                "true poses for the updater need a source that knows the truth (a simulator)".into(),
            ));
        };
        let pose = match self.noise.as_mut() {
            Some(p) => p.apply(truth.pose_in_map, step.frame.stamp_ns),
            None => truth.pose_in_map,
        };
        session.set_updater_pose_override(Some(pose));
        Ok(())
    }
}

/// The error of the poses the updater was given over a run, at every step it was given one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GivenPoseStats {
    /// Steps at which the updater was given a pose.
    pub steps: u64,
    /// Root mean square position error, metres.
    pub rmse_m: f64,
    /// Largest position error, metres.
    pub max_error_m: f64,
    /// Root mean square yaw error, radians.
    pub yaw_rmse_rad: f64,
}

impl GivenPoseStats {
    /// The statistics of several runs pooled (weighted by their steps).
    pub fn pool<'a>(all: impl Iterator<Item = &'a GivenPoseStats>) -> GivenPoseStats {
        let (mut steps, mut e2, mut yaw2, mut max) = (0u64, 0.0, 0.0, 0.0f64);
        for s in all {
            let n = s.steps as f64;
            steps += s.steps;
            e2 += n * s.rmse_m * s.rmse_m;
            yaw2 += n * s.yaw_rmse_rad * s.yaw_rmse_rad;
            max = max.max(s.max_error_m);
        }
        let n = steps.max(1) as f64;
        GivenPoseStats { steps, rmse_m: (e2 / n).sqrt(), max_error_m: max, yaw_rmse_rad: (yaw2 / n).sqrt() }
    }
}

/// Scores the pose the updater was given (`SessionStep::pose_in_map` of the steps with an
/// updater call) against the truth.
#[derive(Clone, Debug, Default)]
pub struct GivenPoseError {
    steps: u64,
    sum_e2: f64,
    sum_yaw2: f64,
    max_e: f64,
}

impl GivenPoseError {
    /// The statistics so far (zeros before the first step).
    pub fn stats(&self) -> GivenPoseStats {
        let n = self.steps.max(1) as f64;
        GivenPoseStats {
            steps: self.steps,
            rmse_m: (self.sum_e2 / n).sqrt(),
            max_error_m: self.max_e,
            yaw_rmse_rad: (self.sum_yaw2 / n).sqrt(),
        }
    }
}

impl Observer for GivenPoseError {
    fn on_step(&mut self, step: &Step, report: &SessionStep, _session: &Session<'_>) {
        let (Some(pose), Some(truth), Some(_)) = (report.pose_in_map, step.truth, report.updater.as_ref()) else {
            return;
        };
        let e = pose.distance(&truth.pose_in_map);
        let dyaw = angle_diff(pose.yaw, truth.pose_in_map.yaw);
        self.steps += 1;
        self.sum_e2 += e * e;
        self.sum_yaw2 += dyaw * dyaw;
        self.max_e = self.max_e.max(e);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sd(v: &[f64]) -> f64 {
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt()
    }

    #[test]
    fn white_noise_has_the_asked_standard_deviations() {
        let noise = PoseNoise { sigma_xy_m: 0.02, sigma_yaw_rad: 0.01, yaw_bias_sigma_rad: 0.0, yaw_bias_tau_s: 20.0 };
        let mut p = PoseNoiseProcess::new(noise, stream_rng(7, "poses/test"));
        let truth = Pose2::new(1.0, -2.0, 0.5);
        let (mut dx, mut dy, mut dyaw) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..20_000u64 {
            let q = p.apply(truth, k * 100_000_000);
            dx.push(q.x - truth.x);
            dy.push(q.y - truth.y);
            dyaw.push(angle_diff(q.yaw, truth.yaw));
        }
        for (name, v, sigma) in [("x", &dx, 0.02), ("y", &dy, 0.02), ("yaw", &dyaw, 0.01)] {
            let s = sd(v);
            assert!((s / sigma - 1.0).abs() < 0.1, "{name}: sample sd {s}, σ {sigma}");
        }
    }

    #[test]
    fn yaw_bias_is_stationary_with_autocorrelation_exp_minus_dt_over_tau() {
        let (sigma_b, tau_s, dt_s) = (0.005, 2.0, 0.1);
        let noise =
            PoseNoise { sigma_xy_m: 0.0, sigma_yaw_rad: 0.0, yaw_bias_sigma_rad: sigma_b, yaw_bias_tau_s: tau_s };
        let mut p = PoseNoiseProcess::new(noise, stream_rng(3, "poses/bias"));
        // 200 000 steps of 0.1 s: 10 000 time constants, so the sample moments are close.
        let bias: Vec<f64> = (0..200_000u64)
            .map(|k| {
                let q = p.apply(Pose2::IDENTITY, k * 100_000_000);
                assert_eq!((q.x, q.y), (0.0, 0.0), "no position noise with σ_xy 0");
                q.yaw
            })
            .collect();
        let s = sd(&bias);
        assert!((s / sigma_b - 1.0).abs() < 0.1, "stationary sd {s}, σ_b {sigma_b}");
        let m = bias.iter().sum::<f64>() / bias.len() as f64;
        let lag = 5; // 0.5 s
        let cov = bias.windows(lag + 1).map(|w| (w[0] - m) * (w[lag] - m)).sum::<f64>() / (bias.len() - lag) as f64;
        let rho = cov / (s * s);
        let want = (-(lag as f64) * dt_s / tau_s).exp();
        assert!((rho - want).abs() < 0.05, "autocorrelation at {} s: {rho}, exp(−dt/τ) = {want}", lag as f64 * dt_s);
    }

    #[test]
    fn same_seed_same_noise_and_streams_differ_by_label() {
        let run = |label: &str| {
            let mut o = PoseNoiseProcess::new(PoseNoise::default(), stream_rng(11, label));
            (0..50u64).map(|k| o.apply(Pose2::new(1.0, 2.0, 3.0), k * 50_000_000)).collect::<Vec<_>>()
        };
        assert_eq!(run("poses/W002"), run("poses/W002"));
        assert_ne!(run("poses/W002"), run("poses/W003"));
    }

    #[test]
    fn noise_parameters_are_validated_with_their_names() {
        let bad = |f: fn(&mut PoseNoise)| {
            let mut n = PoseNoise::default();
            f(&mut n);
            match UpdaterPoses::TrueNoise(n).validate() {
                Err(ExperimentError::InvalidParam(e)) => e.name,
                other => panic!("{n:?} accepted: {other:?}"),
            }
        };
        assert_eq!(bad(|n| n.sigma_xy_m = -0.1), "updater_poses.sigma_xy_m");
        assert_eq!(bad(|n| n.sigma_yaw_rad = f64::NAN), "updater_poses.sigma_yaw_rad");
        assert_eq!(bad(|n| n.yaw_bias_sigma_rad = f64::INFINITY), "updater_poses.yaw_bias_sigma_rad");
        assert_eq!(bad(|n| n.yaw_bias_tau_s = 0.0), "updater_poses.yaw_bias_tau_s");
        let zero = PoseNoise { sigma_xy_m: 0.0, sigma_yaw_rad: 0.0, yaw_bias_sigma_rad: 0.0, yaw_bias_tau_s: 1.0 };
        assert!(UpdaterPoses::TrueNoise(zero).validate().is_ok());
        assert!("foo".parse::<UpdaterPoses>().unwrap_err().contains("localiser, true, true+noise"));
    }

    #[test]
    fn sources_read_and_write_as_tagged_tables() {
        for poses in [UpdaterPoses::Localiser, UpdaterPoses::True, UpdaterPoses::TrueNoise(PoseNoise::default())] {
            let json = serde_json::to_string(&poses).unwrap();
            assert_eq!(serde_json::from_str::<UpdaterPoses>(&json).unwrap(), poses, "{json}");
            let toml = toml::to_string(&poses).unwrap();
            assert_eq!(toml::from_str::<UpdaterPoses>(&toml).unwrap(), poses, "{toml}");
            assert_eq!(poses.name().parse::<UpdaterPoses>().map(|p| p.name()), Ok(poses.name()));
        }
        let file = "source = \"true+noise\"\nsigma_xy_m = 0.1\n";
        let read: UpdaterPoses = toml::from_str(file).unwrap();
        assert_eq!(read, UpdaterPoses::TrueNoise(PoseNoise { sigma_xy_m: 0.1, ..PoseNoise::default() }));
        assert!(toml::from_str::<UpdaterPoses>("source = \"true+noise\"\nsigma_x = 0.1\n").is_err(), "unknown key");
        assert!(toml::from_str::<UpdaterPoses>("source = \"oracle\"\n").is_err(), "unknown source");
    }
}
