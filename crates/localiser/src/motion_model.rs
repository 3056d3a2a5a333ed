//! Sample-based odometry motion models (Thrun, Burgard & Fox, *Probabilistic Robotics*, table
//! 5.6, `sample_motion_model_odometry`) for differential/skid-steer and omnidirectional bases,
//! with the *corrected* variance forms: the alphas multiply variances, so every standard
//! deviation is `sqrt(alpha_a·a² + alpha_b·b²)`.

use crate::params::{Kinematics, MotionParams};
use mapkeeper_grid::{Pose2, wrap_angle};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// Below this translation (metres) the differential model takes the first rotation as zero:
/// the bearing of a tiny translation is noise (AMCL uses the same threshold).
const MIN_TRANS_FOR_BEARING_M: f64 = 0.01;

/// The odometry increment between two readings, decomposed for the motion models.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryDelta {
    /// Straight-line distance travelled, metres.
    pub trans_m: f64,
    /// Heading change, radians.
    pub rot_rad: f64,
    /// Bearing of the translation in the robot frame at the start, radians.
    pub bearing_rad: f64,
}

impl OdometryDelta {
    /// The increment from `old_in_odom` to `new_in_odom`.
    pub fn between(old_in_odom: &Pose2, new_in_odom: &Pose2) -> Self {
        let d = old_in_odom.between(new_in_odom);
        let trans_m = d.x.hypot(d.y);
        let bearing_rad = if trans_m < MIN_TRANS_FOR_BEARING_M { 0.0 } else { d.y.atan2(d.x) };
        Self { trans_m, rot_rad: d.yaw, bearing_rad }
    }

    /// The same motion at most `max` long: its translation at most `max` metres, its turn and
    /// its bearing each at most `max` radians (so the differential model's second rotation, the
    /// turn less the bearing, at most `2 max`). For a noise that stops growing with the motion.
    pub fn shortened_to(&self, max: f64) -> Self {
        Self {
            trans_m: self.trans_m.min(max),
            rot_rad: self.rot_rad.clamp(-max, max),
            bearing_rad: self.bearing_rad.clamp(-max, max),
        }
    }

    /// The differential decomposition `(rot1, trans, rot2)`: turn towards the bearing, drive,
    /// turn to the final heading.
    pub fn rot_trans_rot(&self) -> (f64, f64, f64) {
        let rot1 = self.bearing_rad;
        (rot1, self.trans_m, wrap_angle(self.rot_rad - rot1))
    }
}

/// Standard deviations of the differential model's three motions, `(σ_rot1, σ_trans, σ_rot2)`:
/// `σ_rot1² = a1·rot1² + a2·trans²`, `σ_trans² = a3·trans² + a4·(rot1² + rot2²)`,
/// `σ_rot2² = a1·rot2² + a2·trans²`. As in AMCL, a backwards drive is not a half turn: the
/// rotations' noise uses the smaller of `rot` and `π − |rot|`.
pub fn differential_sigmas(delta: &OdometryDelta, a: &MotionParams) -> (f64, f64, f64) {
    let (rot1, trans, rot2) = delta.rot_trans_rot();
    let fold = |r: f64| r.abs().min(std::f64::consts::PI - r.abs());
    let (r1, r2) = (fold(rot1), fold(rot2));
    let t2 = trans * trans;
    (
        (a.alpha1 * r1 * r1 + a.alpha2 * t2).sqrt(),
        (a.alpha3 * t2 + a.alpha4 * (r1 * r1 + r2 * r2)).sqrt(),
        (a.alpha1 * r2 * r2 + a.alpha2 * t2).sqrt(),
    )
}

/// Standard deviations of the omni model's motions, `(σ_trans, σ_strafe, σ_rot)`:
/// `σ_trans² = a3·trans² + a4·rot²`, `σ_strafe² = a5·trans² + a4·rot²`,
/// `σ_rot² = a1·rot² + a2·trans²`.
///
/// AMCL's omni code uses `alpha1` where its documentation (and its differential model) use
/// `alpha4` and vice versa; this follows the documented meaning. With the default alphas
/// (`alpha1 = alpha4`) both read the same.
pub fn omni_sigmas(delta: &OdometryDelta, a: &MotionParams) -> (f64, f64, f64) {
    let (t2, r2) = (delta.trans_m * delta.trans_m, delta.rot_rad * delta.rot_rad);
    (
        (a.alpha3 * t2 + a.alpha4 * r2).sqrt(),
        (a.alpha5 * t2 + a.alpha4 * r2).sqrt(),
        (a.alpha1 * r2 + a.alpha2 * t2).sqrt(),
    )
}

/// A zero-mean Gaussian sample with standard deviation `sigma`. It always draws one normal, even
/// for `sigma = 0`, so the random stream stays aligned whatever the motion.
#[inline]
fn gaussian<R: Rng + ?Sized>(rng: &mut R, sigma: f64) -> f64 {
    let z: f64 = StandardNormal.sample(rng);
    sigma * z
}

/// The noisy increment sampled for one particle, in the particle's own frame at the start of the
/// motion: `(dx, dy, dyaw)`.
pub fn sample_increment<R: Rng + ?Sized>(
    kinematics: Kinematics,
    delta: &OdometryDelta,
    alphas: &MotionParams,
    rng: &mut R,
) -> Pose2 {
    sample_increment_with_noise_of(kinematics, delta, delta, alphas, rng)
}

/// [`sample_increment`] of `delta` with the noise the model gives `noise` (the same random
/// draws; `noise = delta` is `sample_increment`).
pub fn sample_increment_with_noise_of<R: Rng + ?Sized>(
    kinematics: Kinematics,
    delta: &OdometryDelta,
    noise: &OdometryDelta,
    alphas: &MotionParams,
    rng: &mut R,
) -> Pose2 {
    match kinematics {
        Kinematics::Differential => {
            let (rot1, trans, rot2) = delta.rot_trans_rot();
            let (s1, st, s2) = differential_sigmas(noise, alphas);
            let rot1_hat = rot1 + gaussian(rng, s1);
            let trans_hat = trans + gaussian(rng, st);
            let rot2_hat = rot2 + gaussian(rng, s2);
            let (s, c) = rot1_hat.sin_cos();
            Pose2::new(trans_hat * c, trans_hat * s, wrap_angle(rot1_hat + rot2_hat))
        }
        Kinematics::Omni => {
            let (st, ss, sr) = omni_sigmas(noise, alphas);
            let trans_hat = delta.trans_m + gaussian(rng, st);
            let strafe_hat = gaussian(rng, ss);
            let rot_hat = delta.rot_rad + gaussian(rng, sr);
            let (s, c) = delta.bearing_rad.sin_cos();
            // Along the bearing, plus a sideways term perpendicular to it (to its right, as AMCL).
            Pose2::new(trans_hat * c + strafe_hat * s, trans_hat * s - strafe_hat * c, wrap_angle(rot_hat))
        }
    }
}

/// Moves `pose_in_map` by one sampled increment of `delta` with the noise of `noise`
/// ([`sample_increment_with_noise_of`]).
#[inline]
pub fn sample_motion_with_noise_of<R: Rng + ?Sized>(
    kinematics: Kinematics,
    delta: &OdometryDelta,
    noise: &OdometryDelta,
    alphas: &MotionParams,
    pose_in_map: &Pose2,
    rng: &mut R,
) -> Pose2 {
    pose_in_map.compose(&sample_increment_with_noise_of(kinematics, delta, noise, alphas, rng))
}

/// Moves `pose_in_map` by one sampled noisy increment.
#[inline]
pub fn sample_motion<R: Rng + ?Sized>(
    kinematics: Kinematics,
    delta: &OdometryDelta,
    alphas: &MotionParams,
    pose_in_map: &Pose2,
    rng: &mut R,
) -> Pose2 {
    pose_in_map.compose(&sample_increment(kinematics, delta, alphas, rng))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::ChaCha8Rng;

    const N: usize = 200_000;

    #[test]
    fn noise_of_a_shorter_motion_is_the_same_draws_with_smaller_sigmas() {
        let alphas = MotionParams { alpha1: 0.005, alpha2: 0.005, alpha3: 0.02, alpha4: 0.005, alpha5: 0.005 };
        let delta = OdometryDelta::between(&Pose2::IDENTITY, &Pose2::new(1.2, 0.3, 2.5));
        let short = delta.shortened_to(0.5);
        assert_eq!((short.trans_m, short.rot_rad, short.bearing_rad), (0.5, 0.5, delta.bearing_rad));
        assert_eq!(delta.shortened_to(10.0), delta, "a bound above the motion changes nothing");
        assert_eq!(OdometryDelta { rot_rad: -2.0, ..delta }.shortened_to(0.5).rot_rad, -0.5);
        // A sideways motion's bearing is bounded too: the differential model's rotations stay
        // bounded (rot1 by max, rot2 by 2 max), where keeping the bearing grew rot2.
        let sideways = OdometryDelta { trans_m: 1.0, rot_rad: 0.8, bearing_rad: 1.0 }.shortened_to(0.5);
        let (r1, _, r2) = sideways.rot_trans_rot();
        assert!(r1.abs() <= 0.5 && r2.abs() <= 1.0, "{r1} {r2}");
        for kin in [Kinematics::Omni, Kinematics::Differential] {
            // Its own noise: the same pose, bit for bit, as sample_increment.
            let (mut a, mut b) = (ChaCha8Rng::seed_from_u64(3), ChaCha8Rng::seed_from_u64(3));
            for _ in 0..100 {
                assert_eq!(
                    sample_increment(kin, &delta, &alphas, &mut a),
                    sample_increment_with_noise_of(kin, &delta, &delta, &alphas, &mut b)
                );
            }
            // A shorter motion's noise: the same mean, a smaller spread.
            let spread = |noise: &OdometryDelta| {
                let mut rng = ChaCha8Rng::seed_from_u64(4);
                let xs: Vec<f64> = (0..20_000)
                    .map(|_| sample_increment_with_noise_of(kin, &delta, noise, &alphas, &mut rng).x)
                    .collect();
                mean_var(&xs)
            };
            let (m_full, v_full) = spread(&delta);
            let (m_short, v_short) = spread(&short);
            assert!((m_full - m_short).abs() < 0.01, "{kin:?}: {m_full} vs {m_short}");
            assert!(v_short < 0.5 * v_full, "{kin:?}: {v_short} vs {v_full}");
        }
    }

    fn mean_var(v: &[f64]) -> (f64, f64) {
        let n = v.len() as f64;
        let m = v.iter().sum::<f64>() / n;
        (m, v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0))
    }

    /// Checks a sample mean and variance against the model within 5 standard errors.
    fn assert_moments(samples: &[f64], mean: f64, var: f64, what: &str) {
        let (m, v) = mean_var(samples);
        let n = samples.len() as f64;
        let se_mean = (var / n).sqrt();
        let se_var = var * (2.0 / (n - 1.0)).sqrt();
        assert!((m - mean).abs() <= 5.0 * se_mean + 1e-12, "{what}: mean {m} vs {mean}");
        assert!((v - var).abs() <= 5.0 * se_var + 1e-12, "{what}: var {v} vs {var}");
    }

    #[test]
    fn differential_moments_match_corrected_forms() {
        let a = MotionParams { alpha1: 0.05, alpha2: 0.02, alpha3: 0.1, alpha4: 0.03, alpha5: 0.0 };
        let old = Pose2::new(1.0, 2.0, 0.3);
        let motion = Pose2::new(0.4, 0.1, 0.2); // in the robot frame
        let delta = OdometryDelta::between(&old, &old.compose(&motion));
        let (rot1, trans, rot2) = delta.rot_trans_rot();
        assert!((rot1 - 0.1f64.atan2(0.4)).abs() < 1e-12 && (trans - 0.17f64.sqrt()).abs() < 1e-12);
        let want_s1 = (0.05 * rot1 * rot1 + 0.02 * trans * trans).sqrt();
        let want_st = (0.1 * trans * trans + 0.03 * (rot1 * rot1 + rot2 * rot2)).sqrt();
        let want_s2 = (0.05 * rot2 * rot2 + 0.02 * trans * trans).sqrt();
        let (s1, st, s2) = differential_sigmas(&delta, &a);
        assert!((s1 - want_s1).abs() < 1e-15 && (st - want_st).abs() < 1e-15 && (s2 - want_s2).abs() < 1e-15);

        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut dist, mut dyaw) = (Vec::with_capacity(N), Vec::with_capacity(N));
        for _ in 0..N {
            let inc = sample_increment(Kinematics::Differential, &delta, &a, &mut rng);
            // |trans_hat| is the distance travelled (trans_hat stays positive here).
            dist.push(inc.x.hypot(inc.y));
            dyaw.push(inc.yaw);
        }
        assert_moments(&dist, trans, want_st * want_st, "translation");
        assert_moments(&dyaw, rot1 + rot2, want_s1 * want_s1 + want_s2 * want_s2, "rotation");
    }

    #[test]
    fn omni_moments_match_corrected_forms() {
        let a = MotionParams { alpha1: 0.2, alpha2: 0.05, alpha3: 0.1, alpha4: 0.02, alpha5: 0.04 };
        let old = Pose2::new(-1.0, 0.5, 2.0);
        let motion = Pose2::new(0.1, 0.3, -0.25);
        let delta = OdometryDelta::between(&old, &old.compose(&motion));
        let (t, r, b) = (delta.trans_m, delta.rot_rad, delta.bearing_rad);
        let var_t = 0.1 * t * t + 0.02 * r * r;
        let var_s = 0.04 * t * t + 0.02 * r * r;
        let var_r = 0.2 * r * r + 0.05 * t * t;
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (mut along, mut across, mut dyaw) = (Vec::new(), Vec::new(), Vec::new());
        let (s, c) = b.sin_cos();
        for _ in 0..N {
            let inc = sample_increment(Kinematics::Omni, &delta, &a, &mut rng);
            along.push(inc.x * c + inc.y * s);
            across.push(inc.x * s - inc.y * c);
            dyaw.push(inc.yaw);
        }
        assert_moments(&along, t, var_t, "along the bearing");
        assert_moments(&across, 0.0, var_s, "sideways");
        assert_moments(&dyaw, r, var_r, "rotation");
    }

    #[test]
    fn noiseless_models_reproduce_odometry() {
        let a = MotionParams { alpha1: 0.0, alpha2: 0.0, alpha3: 0.0, alpha4: 0.0, alpha5: 0.0 };
        let old = Pose2::new(3.0, -2.0, -2.5);
        let new = old.compose(&Pose2::new(-0.3, 0.2, 0.7));
        let delta = OdometryDelta::between(&old, &new);
        let particle = Pose2::new(10.0, 5.0, 1.0);
        let want = particle.compose(&old.between(&new));
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for k in [Kinematics::Omni, Kinematics::Differential] {
            let got = sample_motion(k, &delta, &a, &particle, &mut rng);
            assert!(got.distance(&want) < 1e-12 && (got.yaw - want.yaw).abs() < 1e-12, "{k:?}: {got:?}");
        }
    }

    #[test]
    fn driving_backwards_is_not_a_half_turn() {
        let a = MotionParams::default();
        let old = Pose2::IDENTITY;
        let delta = OdometryDelta::between(&old, &Pose2::new(-0.5, 0.0, 0.0));
        let (s1, _, s2) = differential_sigmas(&delta, &a);
        // Rotation noise from translation only: sqrt(a2)·0.5.
        assert!((s1 - 0.2f64.sqrt() * 0.5).abs() < 1e-9 && (s2 - 0.2f64.sqrt() * 0.5).abs() < 1e-9);
    }
}
