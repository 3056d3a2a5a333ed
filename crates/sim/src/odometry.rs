//! Wheel odometry: the true per-step motion, corrupted by AMCL-style noise and a slow bias, and
//! integrated in the odometry frame (which starts at the identity).

use crate::seeds::SimRng;
use mapkeeper_common::ParamError;
use mapkeeper_grid::Pose2;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// Odometry noise. The four alphas follow AMCL's roles (rotation from rotation, rotation from
/// translation, translation from translation, translation from rotation) but are applied to
/// every physics step's increment as a random walk: the variance added is proportional to the
/// motion, so the drift does not depend on the step length. On top, a slow bias: a scale error
/// and a heading drift per metre, fixed for the run, with a sign drawn from the seed.
///
/// With the defaults, 10 m of straight driving drifts by about 2.5-3.5 % (see the crate's
/// odometry test).
///
/// ```
/// use mapkeeper_sim::OdometryParams;
/// let mut p = OdometryParams::default();
/// p.scale_bias_frac = 0.0; // unbiased wheels
/// assert!(p.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OdometryParams {
    /// Rotation noise from rotation: σ of the heading error after turning 1 rad, radians
    /// (default 0.02).
    pub alpha1_rad_per_sqrt_rad: f64,
    /// Rotation noise from translation: σ of the heading error after 1 m, radians (default 0.005).
    pub alpha2_rad_per_sqrt_m: f64,
    /// Translation noise from translation: σ of the position error (each axis) after 1 m,
    /// metres (default 0.01).
    pub alpha3_m_per_sqrt_m: f64,
    /// Translation noise from rotation: σ of the position error (each axis) after turning 1 rad,
    /// metres (default 0.005).
    pub alpha4_m_per_sqrt_rad: f64,
    /// Wheel scale error: measured translation = true × (1 ± this) (default 0.02).
    pub scale_bias_frac: f64,
    /// Heading drift per metre travelled, radians per metre, sign drawn per run (default 0.003).
    pub heading_bias_rad_per_m: f64,
}

impl Default for OdometryParams {
    fn default() -> Self {
        Self {
            alpha1_rad_per_sqrt_rad: 0.02,
            alpha2_rad_per_sqrt_m: 0.005,
            alpha3_m_per_sqrt_m: 0.01,
            alpha4_m_per_sqrt_rad: 0.005,
            scale_bias_frac: 0.02,
            heading_bias_rad_per_m: 0.003,
        }
    }
}

impl OdometryParams {
    /// Perfect odometry.
    pub fn perfect() -> Self {
        Self {
            alpha1_rad_per_sqrt_rad: 0.0,
            alpha2_rad_per_sqrt_m: 0.0,
            alpha3_m_per_sqrt_m: 0.0,
            alpha4_m_per_sqrt_rad: 0.0,
            scale_bias_frac: 0.0,
            heading_bias_rad_per_m: 0.0,
        }
    }

    /// Checks every field (finite, ≥ 0; scale bias < 0.5).
    pub fn validate(&self) -> Result<(), ParamError> {
        for (name, v) in [
            ("alpha1_rad_per_sqrt_rad", self.alpha1_rad_per_sqrt_rad),
            ("alpha2_rad_per_sqrt_m", self.alpha2_rad_per_sqrt_m),
            ("alpha3_m_per_sqrt_m", self.alpha3_m_per_sqrt_m),
            ("alpha4_m_per_sqrt_rad", self.alpha4_m_per_sqrt_rad),
            ("scale_bias_frac", self.scale_bias_frac),
            ("heading_bias_rad_per_m", self.heading_bias_rad_per_m),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError::new(name, v, "must be finite and ≥ 0"));
            }
        }
        if self.scale_bias_frac >= 0.5 {
            return Err(ParamError::new("scale_bias_frac", self.scale_bias_frac, "must be < 0.5"));
        }
        Ok(())
    }
}

/// Integrates noisy increments.
#[derive(Clone)]
pub(crate) struct Odometry {
    params: OdometryParams,
    rng: SimRng,
    scale: f64,
    heading_bias: f64,
    pose_in_odom: Pose2,
}

impl Odometry {
    pub(crate) fn new(params: &OdometryParams, run_seed: u64) -> Self {
        let mut rng = SimRng::stream(run_seed, "odometry");
        let sign = |b: bool| if b { 1.0 } else { -1.0 };
        let scale = 1.0 + sign(rng.random::<bool>()) * params.scale_bias_frac;
        let heading_bias = sign(rng.random::<bool>()) * params.heading_bias_rad_per_m;
        Self { params: params.clone(), rng, scale, heading_bias, pose_in_odom: Pose2::IDENTITY }
    }

    /// Adds the true increment `delta` (robot frame, from the previous step's pose).
    pub(crate) fn update(&mut self, delta: &Pose2) {
        let p = &self.params;
        let trans = delta.x.hypot(delta.y);
        let rot = delta.yaw.abs();
        if trans == 0.0 && rot == 0.0 {
            return;
        }
        let sd_t = (p.alpha3_m_per_sqrt_m.powi(2) * trans + p.alpha4_m_per_sqrt_rad.powi(2) * rot).sqrt();
        let sd_r = (p.alpha1_rad_per_sqrt_rad.powi(2) * rot + p.alpha2_rad_per_sqrt_m.powi(2) * trans).sqrt();
        let mut n = || -> f64 { StandardNormal.sample(&mut self.rng) };
        let (nx, ny, nr) = (n(), n(), n());
        let noisy = Pose2::new(
            delta.x * self.scale + sd_t * nx,
            delta.y * self.scale + sd_t * ny,
            delta.yaw + sd_r * nr + self.heading_bias * trans,
        );
        self.pose_in_odom = self.pose_in_odom.compose(&noisy);
    }

    pub(crate) fn pose(&self) -> Pose2 {
        self.pose_in_odom
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_odometry_integrates_exactly() {
        let mut o = Odometry::new(&OdometryParams::perfect(), 1);
        let d = Pose2::new(0.02, 0.0, 0.01);
        let mut truth = Pose2::IDENTITY;
        for _ in 0..100 {
            o.update(&d);
            truth = truth.compose(&d);
        }
        assert!(o.pose().distance(&truth) < 1e-12);
    }

    #[test]
    fn drift_does_not_depend_on_step_length() {
        // The spread of the end position over many runs is the same for 1 cm and 4 cm steps.
        let p = OdometryParams { scale_bias_frac: 0.0, heading_bias_rad_per_m: 0.0, ..OdometryParams::default() };
        let spread = |step: f64| {
            let runs = 400;
            let mut s2 = 0.0;
            for seed in 0..runs {
                let mut o = Odometry::new(&p, seed);
                for _ in 0..(4.0 / step).round() as usize {
                    o.update(&Pose2::new(step, 0.0, 0.0));
                }
                s2 += o.pose().y.powi(2);
            }
            (s2 / runs as f64).sqrt()
        };
        let (a, b) = (spread(0.01), spread(0.04));
        assert!((a / b - 1.0).abs() < 0.2, "{a} vs {b}");
    }
}
