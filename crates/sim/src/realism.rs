//! Sensor realism beyond the per-beam noise model: mixed pixels, range-dependent noise, motion
//! distortion, unsynchronised lidars, an extrinsic calibration error, latency and jitter, and
//! people seen as two legs. Each effect is its own switch and draws from its own random streams
//! (`lidar/<id>/mixed`, `/range_noise`, `/phase`, `/extrinsic`, `/jitter`; `agent/<id>/gait`),
//! so turning one on does not change the numbers another draws. All off
//! ([`SensorRealism::default`], the `ideal` profile) is the simulator as it was before them,
//! bit for bit.

use mapkeeper_common::ParamError;
use mapkeeper_grid::{Point2, Pose2, angle_diff};
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;

/// One effect of [`SensorRealism`], by its command-line name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SensorEffect {
    /// `mixed-pixels`: a beam on a depth edge returns a range between the near and the far
    /// surface.
    MixedPixels,
    /// `range-noise`: Gaussian noise growing with the range.
    RangeNoise,
    /// `motion-distortion`: the beams are cast over the sweep while the robot moves.
    MotionDistortion,
    /// `unsync`: each lidar starts at a seeded phase of its period.
    Unsync,
    /// `extrinsic-error`: the simulator casts from a perturbed mount; the scans carry the
    /// nominal one.
    ExtrinsicError,
    /// `latency`: a scan describes the world as it was a latency (plus a jitter) before its
    /// stamp.
    Latency,
    /// `legs`: people are two legs, not a disc, to the lidars.
    Legs,
}

impl SensorEffect {
    /// Every effect, in the order of [`SensorEffect::name`]'s list.
    pub const ALL: [SensorEffect; 7] = [
        SensorEffect::MixedPixels,
        SensorEffect::RangeNoise,
        SensorEffect::MotionDistortion,
        SensorEffect::Unsync,
        SensorEffect::ExtrinsicError,
        SensorEffect::Latency,
        SensorEffect::Legs,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            SensorEffect::MixedPixels => "mixed-pixels",
            SensorEffect::RangeNoise => "range-noise",
            SensorEffect::MotionDistortion => "motion-distortion",
            SensorEffect::Unsync => "unsync",
            SensorEffect::ExtrinsicError => "extrinsic-error",
            SensorEffect::Latency => "latency",
            SensorEffect::Legs => "legs",
        }
    }

    /// The effect called `name`.
    pub fn parse(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|e| e.name() == name).ok_or_else(|| {
            let known: Vec<&str> = Self::ALL.iter().map(|e| e.name()).collect();
            format!("unknown sensor effect '{name}' (known: {})", known.join(", "))
        })
    }
}

/// The switches and magnitudes of the sensor-realism effects. Every switch is off by default;
/// the magnitudes default to the values of the `realistic` profile.
///
/// ```
/// use mapkeeper_sim::{SensorEffect, SensorRealism};
/// let r = SensorRealism::with_effects(&[SensorEffect::MixedPixels, SensorEffect::Legs]);
/// assert!(r.mixed_pixels && r.legs && !r.latency);
/// assert!(r.validate().is_ok());
/// assert!(SensorRealism::default().is_ideal());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorRealism {
    /// Mixed pixels at depth edges (default off).
    pub mixed_pixels: bool,
    /// Chance that the far beam of a depth edge reads a mixed range, uniform between the near
    /// and the far surface (default 0.5).
    pub mixed_pixel_probability: f64,
    /// Smallest range jump between neighbouring beams that counts as a depth edge, metres
    /// (default 0.3).
    pub mixed_pixel_min_jump_m: f64,
    /// Range-dependent noise (default off).
    pub range_noise: bool,
    /// Its standard deviation per metre of range, on top of `sigma_m` (default 0.002: 2 cm at
    /// 10 m).
    pub range_noise_sigma_per_m: f64,
    /// Motion distortion: beam `i` of `n` is cast `(n − 1 − i) · period · |increment| / 2π`
    /// before the scan's stamp (a mirror turning once per period; the stamp is the last beam's
    /// time), from the robot's true pose then (default off).
    pub motion_distortion: bool,
    /// Unsynchronised lidars: each lidar's first scan comes a seeded uniform fraction of its
    /// period later, on top of `phase_offset_s` (default off).
    pub unsync: bool,
    /// Extrinsic calibration error: each lidar is cast from its mount displaced by seeded
    /// N(0, σ) in x, y and yaw, drawn once per run; the scans carry the nominal mount (default
    /// off).
    pub extrinsic_error: bool,
    /// σ of the mount's x and y error, metres (default 0.01).
    pub extrinsic_sigma_xy_m: f64,
    /// σ of the mount's yaw error, radians (default 0.00873: 0.5°).
    pub extrinsic_sigma_yaw_rad: f64,
    /// Latency and jitter: a scan stamped at t shows the world at t − `latency_s` − U(0,
    /// `jitter_s`) (a driver stamping on receipt), drawn per scan (default off).
    pub latency: bool,
    /// Fixed latency, seconds (default 0.015).
    pub latency_s: f64,
    /// Largest extra random delay, seconds (default 0.01).
    pub jitter_s: f64,
    /// People as two legs to the lidars: a person's disc becomes two circles beside each
    /// other across its heading that swing back and forth as it walks (its body for physics
    /// and for the follower stays the disc) (default off).
    pub legs: bool,
    /// Radius of a leg, metres (default 0.06).
    pub leg_radius_m: f64,
    /// Distance between the legs' centres across the heading, metres (default 0.22).
    pub leg_separation_m: f64,
    /// Distance walked in one gait cycle (two steps), metres (default 1.2); each leg swings
    /// ± a quarter of it along the heading.
    pub stride_m: f64,
}

impl Default for SensorRealism {
    fn default() -> Self {
        Self {
            mixed_pixels: false,
            mixed_pixel_probability: 0.5,
            mixed_pixel_min_jump_m: 0.3,
            range_noise: false,
            range_noise_sigma_per_m: 0.002,
            motion_distortion: false,
            unsync: false,
            extrinsic_error: false,
            extrinsic_sigma_xy_m: 0.01,
            extrinsic_sigma_yaw_rad: 0.5f64.to_radians(),
            latency: false,
            latency_s: 0.015,
            jitter_s: 0.01,
            legs: false,
            leg_radius_m: 0.06,
            leg_separation_m: 0.22,
            stride_m: 1.2,
        }
    }
}

impl SensorRealism {
    /// The `ideal` profile: every effect off (the default).
    pub fn ideal() -> Self {
        Self::default()
    }

    /// The `realistic` profile: every effect on, default magnitudes.
    pub fn realistic() -> Self {
        Self::with_effects(&SensorEffect::ALL)
    }

    /// The profile called `name`: `ideal` or `realistic`.
    pub fn profile(name: &str) -> Result<Self, String> {
        match name {
            "ideal" => Ok(Self::ideal()),
            "realistic" => Ok(Self::realistic()),
            _ => Err(format!("unknown sensor profile '{name}' (known: ideal, realistic)")),
        }
    }

    /// Default magnitudes with exactly `effects` on.
    pub fn with_effects(effects: &[SensorEffect]) -> Self {
        let mut r = Self::default();
        for e in effects {
            r.set(*e, true);
        }
        r
    }

    /// Turns `effect` on or off.
    pub fn set(&mut self, effect: SensorEffect, on: bool) {
        let flag = match effect {
            SensorEffect::MixedPixels => &mut self.mixed_pixels,
            SensorEffect::RangeNoise => &mut self.range_noise,
            SensorEffect::MotionDistortion => &mut self.motion_distortion,
            SensorEffect::Unsync => &mut self.unsync,
            SensorEffect::ExtrinsicError => &mut self.extrinsic_error,
            SensorEffect::Latency => &mut self.latency,
            SensorEffect::Legs => &mut self.legs,
        };
        *flag = on;
    }

    /// The effects that are on.
    pub fn effects(&self) -> Vec<SensorEffect> {
        let on = [
            self.mixed_pixels,
            self.range_noise,
            self.motion_distortion,
            self.unsync,
            self.extrinsic_error,
            self.latency,
            self.legs,
        ];
        SensorEffect::ALL.into_iter().zip(on).filter(|(_, on)| *on).map(|(e, _)| e).collect()
    }

    /// Whether this is the default (every effect off, default magnitudes): not written to
    /// parameter files then.
    pub fn is_ideal(&self) -> bool {
        *self == Self::default()
    }

    /// Whether the scans need the robot's pose at earlier times.
    pub(crate) fn needs_history(&self) -> bool {
        self.motion_distortion || self.latency
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        if !(0.0..=1.0).contains(&self.mixed_pixel_probability) {
            return Err(ParamError::new("mixed_pixel_probability", self.mixed_pixel_probability, "must be in [0, 1]"));
        }
        for (name, v, hi) in [
            ("mixed_pixel_min_jump_m", self.mixed_pixel_min_jump_m, 100.0),
            ("range_noise_sigma_per_m", self.range_noise_sigma_per_m, 1.0),
            ("extrinsic_sigma_xy_m", self.extrinsic_sigma_xy_m, 1.0),
            ("extrinsic_sigma_yaw_rad", self.extrinsic_sigma_yaw_rad, 1.0),
            ("latency_s", self.latency_s, 1.0),
            ("jitter_s", self.jitter_s, 1.0),
        ] {
            if !(v.is_finite() && (0.0..=hi).contains(&v)) {
                return Err(ParamError::new(name, v, format!("must be in [0, {hi}]")));
            }
        }
        for (name, v) in [
            ("leg_radius_m", self.leg_radius_m),
            ("leg_separation_m", self.leg_separation_m),
            ("stride_m", self.stride_m),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 10.0) {
                return Err(ParamError::new(name, v, "must be in (0, 10]"));
            }
        }
        Ok(())
    }

    /// The two legs of a person whose body is a disc of radius `radius` at `center` (map
    /// frame), heading `yaw`, having walked `walked_m`: `(center, radius)` of each.
    pub(crate) fn legs_of(&self, center: Point2, yaw: f64, walked_m: f64) -> [(Point2, f64); 2] {
        let r = self.leg_radius_m;
        let half = self.leg_separation_m / 2.0;
        let swing = self.stride_m / 4.0 * (std::f64::consts::TAU * walked_m / self.stride_m).sin();
        let (s, c) = yaw.sin_cos();
        let at =
            |along: f64, across: f64| Point2::new(center.x + along * c - across * s, center.y + along * s + across * c);
        [(at(swing, half), r), (at(-swing, -half), r)]
    }
}

/// The robot's true poses at the last ticks, for casts at earlier times.
#[derive(Clone, Debug, Default)]
pub(crate) struct PoseHistory {
    poses: VecDeque<(u64, Pose2)>,
    keep_ns: u64,
}

impl PoseHistory {
    pub(crate) fn new(keep_ns: u64) -> Self {
        Self { poses: VecDeque::new(), keep_ns }
    }

    pub(crate) fn keep_ns(&self) -> u64 {
        self.keep_ns
    }

    /// Records the pose at `t_ns` (non-decreasing) and forgets poses older than needed.
    pub(crate) fn push(&mut self, t_ns: u64, pose: Pose2) {
        self.poses.push_back((t_ns, pose));
        while self.poses.len() > 2 && self.poses[1].0 + self.keep_ns < t_ns {
            self.poses.pop_front();
        }
    }

    /// The pose at `t_ns` (may be fractional), interpolated between the recorded ticks;
    /// before the first record, the first.
    pub(crate) fn at(&self, t_ns: f64) -> Option<Pose2> {
        let last = *self.poses.back()?;
        if t_ns >= last.0 as f64 {
            return Some(last.1);
        }
        for k in (1..self.poses.len()).rev() {
            let (t0, p0) = self.poses[k - 1];
            let (t1, p1) = self.poses[k];
            if t_ns >= t0 as f64 {
                let f = if t1 > t0 { (t_ns - t0 as f64) / (t1 - t0) as f64 } else { 1.0 };
                return Some(Pose2::new(
                    p0.x + f * (p1.x - p0.x),
                    p0.y + f * (p1.y - p0.y),
                    p0.yaw + f * angle_diff(p1.yaw, p0.yaw),
                ));
            }
        }
        self.poses.front().map(|p| p.1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn effect_names_round_trip_and_unknown_is_named() {
        for e in SensorEffect::ALL {
            assert_eq!(SensorEffect::parse(e.name()), Ok(e));
        }
        let err = SensorEffect::parse("blur").unwrap_err();
        assert!(err.contains("'blur'") && err.contains("mixed-pixels"), "{err}");
        assert_eq!(SensorRealism::realistic().effects(), SensorEffect::ALL.to_vec());
        assert!(SensorRealism::profile("ideal").unwrap().is_ideal());
        assert!(SensorRealism::profile("foggy").unwrap_err().contains("foggy"));
    }

    #[test]
    fn validation_names_the_field() {
        let mut r = SensorRealism::realistic();
        r.jitter_s = f64::NAN;
        assert_eq!(r.validate().unwrap_err(), ParamError::new("jitter_s", "NaN", "must be in [0, 1]"));
        let mut r = SensorRealism::realistic();
        r.mixed_pixel_probability = 2.0;
        assert_eq!(r.validate().unwrap_err().name, "mixed_pixel_probability");
        let mut r = SensorRealism::realistic();
        r.stride_m = 0.0;
        assert_eq!(r.validate().unwrap_err().to_string(), "stride_m must be in (0, 10], got 0");
    }

    #[test]
    fn history_interpolates_between_ticks() {
        let mut h = PoseHistory::new(100);
        assert!(h.at(0.0).is_none());
        h.push(0, Pose2::new(0.0, 0.0, 3.0));
        h.push(20, Pose2::new(2.0, 0.0, -3.0));
        let p = h.at(5.0).unwrap();
        assert!((p.x - 0.5).abs() < 1e-12);
        // The yaw goes the short way round through ±π.
        assert!(angle_diff(p.yaw, 3.0 + 0.25 * (std::f64::consts::TAU - 6.0)).abs() < 1e-9, "{}", p.yaw);
        assert_eq!(h.at(30.0).unwrap().x, 2.0);
        assert_eq!(h.at(-5.0).unwrap().x, 0.0);
        for t in 1..20 {
            h.push(20 + t * 20, Pose2::new(0.0, 0.0, 0.0));
        }
        assert!(h.poses.len() <= 8, "old poses are forgotten: {}", h.poses.len());
    }

    #[test]
    fn legs_stand_apart_and_swing() {
        let r = SensorRealism::realistic();
        let [a, b] = r.legs_of(Point2::new(1.0, 1.0), 0.0, 0.0);
        assert!((a.0.distance(b.0) - 0.22).abs() < 1e-12 && (a.0.x - 1.0).abs() < 1e-12);
        let [a, b] = r.legs_of(Point2::new(1.0, 1.0), 0.0, 0.3);
        // A quarter cycle: the legs are a half stride apart along the heading.
        assert!((a.0.x - b.0.x - 0.6).abs() < 1e-12, "{:?} {:?}", a, b);
    }
}
