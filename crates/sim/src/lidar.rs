//! 2D lidars: parameters (with SICK S300 and Hokuyo UST-20LX presets), the noise model, and the
//! scan, cast against the simulator's own exact geometry (`raycast.rs`, checked beam for beam
//! against rapier's `cast_ray` in the tests).

use crate::error::{SimError, params_err};
use crate::raycast::{StaticCaster, cast_shape};
use crate::realism::{PoseHistory, SensorRealism};
use crate::seeds::{SimRng, stream_rng};
use crate::shape::Shape;
use mapkeeper_common::ParamError;
use mapkeeper_grid::Point2;
use mapkeeper_grid::Pose2;
use mapkeeper_sensor::{LaserScan, SweepTiming};
use rand::RngExt;
use rand_distr::{Distribution, Normal};
#[cfg(test)]
use rapier2d::prelude::{QueryPipeline, Ray, Vector};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The noise terms of a lidar. Each term draws from its own random stream
/// (`lidar/<id>/gauss`, `/dropout`, `/spurious`), so switching one off leaves the others' numbers
/// unchanged.
///
/// ```
/// use mapkeeper_sim::LidarNoise;
/// let mut n = LidarNoise::default();
/// n.sigma_m = 0.05;
/// assert!(n.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarNoise {
    /// Standard deviation of the Gaussian range noise, metres (default 0.03, the S300's).
    pub sigma_m: f64,
    /// Ranges are rounded to multiples of this, metres; 0 disables (default 0.01).
    pub quantisation_m: f64,
    /// Probability that a beam returns nothing (reported as +inf) (default 0.002).
    pub dropout_probability: f64,
    /// Probability of a short spurious return, uniform in `[range_min, min(true range,
    /// spurious_max_m)]` (default 0.0005).
    pub spurious_probability: f64,
    /// Farthest spurious return, metres (default 2.0).
    pub spurious_max_m: f64,
}

impl Default for LidarNoise {
    fn default() -> Self {
        Self {
            sigma_m: 0.03,
            quantisation_m: 0.01,
            dropout_probability: 0.002,
            spurious_probability: 0.0005,
            spurious_max_m: 2.0,
        }
    }
}

impl LidarNoise {
    /// No noise at all (exact ranges; no-return beams still +inf).
    pub fn none() -> Self {
        Self {
            sigma_m: 0.0,
            quantisation_m: 0.0,
            dropout_probability: 0.0,
            spurious_probability: 0.0,
            spurious_max_m: 2.0,
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        let nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(ParamError::new(name, v, "must be finite and ≥ 0")) }
        };
        nonneg("sigma_m", self.sigma_m)?;
        nonneg("quantisation_m", self.quantisation_m)?;
        nonneg("spurious_max_m", self.spurious_max_m)?;
        for (name, p) in
            [("dropout_probability", self.dropout_probability), ("spurious_probability", self.spurious_probability)]
        {
            if !(0.0..=1.0).contains(&p) {
                return Err(ParamError::new(name, p, "must be in [0, 1]"));
            }
        }
        Ok(())
    }
}

/// One lidar's configuration. Beam `i` points at `angle_min_rad + i · angle_increment_rad` in
/// the lidar's frame, which sits at `lidar_in_robot` in the robot's base frame.
///
/// ```
/// use mapkeeper_sim::LidarParams;
/// let mut front = LidarParams::sick_s300_front();
/// front.beams = 271; // 1° resolution
/// front.angle_increment_rad = 1f64.to_radians();
/// assert!(front.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LidarParams {
    /// Mounting pose in the robot base frame (metres, radians). An upside-down mounting is folded
    /// into this pose (scans are expressed z-up). Default: the S300 front mount.
    pub lidar_in_robot: Pose2,
    /// Angle of the first beam, radians (default −135°).
    pub angle_min_rad: f64,
    /// Angle between beams, radians (default 0.5°).
    pub angle_increment_rad: f64,
    /// Number of beams (default 541).
    pub beams: usize,
    /// Shortest valid range, metres (default 0.10).
    pub range_min_m: f64,
    /// Farthest range; anything at or beyond is "no return", +inf (default 30).
    pub range_max_m: f64,
    /// Scan rate, Hz (default 12.5).
    pub rate_hz: f64,
    /// Time of the first scan after the start, seconds, on top of one physics tick (default 0).
    pub phase_offset_s: f64,
    /// Noise model.
    pub noise: LidarNoise,
    /// Mounted upside down: rolled by π about its own x axis, whose heading in the base frame
    /// is `lidar_in_robot.yaw`. Beam `i` then points at `−(angle_min_rad + i · angle_increment_rad)`
    /// in the z-up frame, and the scans carry the mirror as a driver plus TF deliver it:
    /// negated `angle_min_rad` and `angle_increment_rad` (a negative increment), ranges in the
    /// scanner's own order. Default false (not written when false).
    #[serde(default, skip_serializing_if = "is_false")]
    pub upside_down: bool,
}

// serde's skip_serializing_if passes a reference.
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_false(v: &bool) -> bool {
    !*v
}

/// The latest first scan a lidar may be given, seconds after the run starts (an hour).
pub const MAX_PHASE_OFFSET_S: f64 = 3600.0;

/// The lidar models known by name: `sick_s300` ([`LidarParams::sick_s300`]) and
/// `hokuyo_ust20lx` ([`LidarParams::hokuyo_ust20lx`]).
pub const LIDAR_MODELS: &[&str] = &["sick_s300", "hokuyo_ust20lx"];

impl Default for LidarParams {
    fn default() -> Self {
        Self::sick_s300_front()
    }
}

impl LidarParams {
    /// SICK S300 (270°, 541 beams at 0.5°, 0.10-30 m, 12.5 Hz, σ 0.03 m) at `lidar_in_robot`.
    pub fn sick_s300(lidar_in_robot: Pose2) -> Self {
        Self {
            lidar_in_robot,
            angle_min_rad: -135f64.to_radians(),
            angle_increment_rad: 0.5f64.to_radians(),
            beams: 541,
            range_min_m: 0.10,
            range_max_m: 30.0,
            rate_hz: 12.5,
            phase_offset_s: 0.0,
            noise: LidarNoise::default(),
            upside_down: false,
        }
    }

    /// The Summit-XL Steel's front S300: at (0.2865, −0.2089) m facing −45°.
    pub fn sick_s300_front() -> Self {
        Self::sick_s300(Pose2::new(0.2865, -0.2089, -PI / 4.0))
    }

    /// The Summit-XL Steel's rear S300: at (−0.2865, 0.2089) m facing +135°.
    pub fn sick_s300_rear() -> Self {
        Self::sick_s300(Pose2::new(-0.2865, 0.2089, 3.0 * PI / 4.0))
    }

    /// Hokuyo UST-20LX at `lidar_in_robot`, from its data sheet: 270° field of view, 0.25°
    /// angular resolution (1081 beams), 0.06-20 m range, 40 Hz (25 ms per scan), accuracy
    /// ±40 mm, here σ = 0.01 m (the ±40 mm tolerance taken as a bound of about 4σ, as the
    /// project's spec sets it) and 1 mm steps.
    pub fn hokuyo_ust20lx(lidar_in_robot: Pose2) -> Self {
        Self {
            lidar_in_robot,
            angle_min_rad: -135f64.to_radians(),
            angle_increment_rad: 0.25f64.to_radians(),
            beams: 1081,
            range_min_m: 0.06,
            range_max_m: 20.0,
            rate_hz: 40.0,
            phase_offset_s: 0.0,
            noise: LidarNoise {
                sigma_m: 0.01,
                quantisation_m: 0.001,
                dropout_probability: 0.001,
                spurious_probability: 0.0005,
                spurious_max_m: 2.0,
            },
            upside_down: false,
        }
    }

    /// The default pair: front and rear S300.
    pub fn summit_xl_pair() -> Vec<LidarParams> {
        vec![Self::sick_s300_front(), Self::sick_s300_rear()]
    }

    /// A lidar model by name ([`LIDAR_MODELS`]) at `lidar_in_robot`, upright.
    pub fn model(name: &str, lidar_in_robot: Pose2) -> Option<Self> {
        match name {
            "sick_s300" => Some(Self::sick_s300(lidar_in_robot)),
            "hokuyo_ust20lx" => Some(Self::hokuyo_ust20lx(lidar_in_robot)),
            _ => None,
        }
    }

    /// Direction of beam `i` in the z-up lidar frame (before the mount's yaw), radians: the
    /// scanner's own angle, negated when the lidar is upside down.
    pub fn beam_direction_rad(&self, i: usize) -> f64 {
        let a = self.angle_min_rad + i as f64 * self.angle_increment_rad;
        if self.upside_down { -a } else { a }
    }

    /// `(angle_min_rad, angle_increment_rad)` as the scans report them (z-up frame): negated
    /// when the lidar is upside down.
    pub fn scan_angles(&self) -> (f64, f64) {
        if self.upside_down {
            (-self.angle_min_rad, -self.angle_increment_rad)
        } else {
            (self.angle_min_rad, self.angle_increment_rad)
        }
    }

    /// Checks every field; the noise's are named `noise.…`.
    pub fn validate(&self) -> Result<(), ParamError> {
        if !self.lidar_in_robot.is_finite() {
            return Err(ParamError::new("lidar_in_robot", format!("{:?}", self.lidar_in_robot), "must be finite"));
        }
        if !self.angle_min_rad.is_finite() {
            return Err(ParamError::new("angle_min_rad", self.angle_min_rad, "must be finite"));
        }
        if !(self.angle_increment_rad.is_finite() && self.angle_increment_rad != 0.0) {
            return Err(ParamError::new(
                "angle_increment_rad",
                self.angle_increment_rad,
                "must be finite and non-zero",
            ));
        }
        if self.beams == 0 || self.beams > mapkeeper_sensor::MAX_BEAMS {
            return Err(ParamError::new(
                "beams",
                self.beams,
                format!("must be in 1..={}", mapkeeper_sensor::MAX_BEAMS),
            ));
        }
        if self.angle_increment_rad.abs() * (self.beams - 1) as f64 > 2.0 * PI + 1e-6 {
            let value = format!("{} beams at {} rad", self.beams, self.angle_increment_rad);
            return Err(ParamError::new("beams", value, "must span at most a full turn"));
        }
        if !(self.range_min_m.is_finite()
            && self.range_max_m.is_finite()
            && self.range_min_m >= 0.0
            && self.range_min_m < self.range_max_m)
        {
            let value = format!("{} and {}", self.range_min_m, self.range_max_m);
            return Err(ParamError::new("range limits", value, "must satisfy 0 ≤ range_min_m < range_max_m"));
        }
        if !(self.rate_hz.is_finite() && (0.01..=1000.0).contains(&self.rate_hz)) {
            return Err(ParamError::new("rate_hz", self.rate_hz, "must be in [0.01, 1000]"));
        }
        if !(self.phase_offset_s.is_finite() && (0.0..=MAX_PHASE_OFFSET_S).contains(&self.phase_offset_s)) {
            let requirement = format!("must be in [0, {MAX_PHASE_OFFSET_S}] s");
            return Err(ParamError::new("phase_offset_s", self.phase_offset_s, requirement));
        }
        self.noise.validate().map_err(|e| e.within("noise"))
    }

    /// The scan period, nanoseconds (rounded).
    pub fn period_ns(&self) -> u64 {
        (1e9 / self.rate_hz).round() as u64
    }
}

/// The random streams of one lidar's noise.
#[derive(Clone)]
pub(crate) struct NoiseStreams {
    gauss: SimRng,
    dropout: SimRng,
    spurious: SimRng,
    normal: Option<Normal<f64>>,
}

impl NoiseStreams {
    pub(crate) fn new(run_seed: u64, lidar_id: usize, noise: &LidarNoise) -> Self {
        Self {
            gauss: SimRng::stream(run_seed, &format!("lidar/{lidar_id}/gauss")),
            dropout: SimRng::stream(run_seed, &format!("lidar/{lidar_id}/dropout")),
            spurious: SimRng::stream(run_seed, &format!("lidar/{lidar_id}/spurious")),
            normal: (noise.sigma_m > 0.0).then(|| Normal::new(0.0, noise.sigma_m).ok()).flatten(),
        }
    }

    /// The reported range of a beam whose true range is `truth` (`None`: nothing within
    /// `range_max_m`). Order of terms: dropout, spurious return, Gaussian noise, quantisation,
    /// then anything at or beyond `range_max_m` becomes +inf.
    pub(crate) fn reading(&mut self, truth: Option<f64>, p: &LidarParams) -> f32 {
        self.reading_with(truth, p, 0.0)
    }

    /// [`NoiseStreams::reading`] with `extra` metres of noise added to a true return (the
    /// range-dependent noise of [`SensorRealism`]; 0 adds nothing).
    pub(crate) fn reading_with(&mut self, truth: Option<f64>, p: &LidarParams, extra: f64) -> f32 {
        let n = &p.noise;
        if n.dropout_probability > 0.0 && self.dropout.random::<f64>() < n.dropout_probability {
            return f32::INFINITY;
        }
        let mut r = if n.spurious_probability > 0.0 && self.spurious.random::<f64>() < n.spurious_probability {
            let hi = truth.unwrap_or(p.range_max_m).min(n.spurious_max_m).max(p.range_min_m);
            p.range_min_m + self.spurious.random::<f64>() * (hi - p.range_min_m)
        } else {
            match truth {
                None => return f32::INFINITY,
                Some(t) if extra == 0.0 => t + self.normal.as_ref().map_or(0.0, |d| d.sample(&mut self.gauss)),
                Some(t) => t + self.normal.as_ref().map_or(0.0, |d| d.sample(&mut self.gauss)) + extra,
            }
        };
        if n.quantisation_m > 0.0 {
            r = (r / n.quantisation_m).round() * n.quantisation_m;
        }
        if r >= p.range_max_m { f32::INFINITY } else { r as f32 }
    }
}

/// A lidar in a running simulation: its parameters, schedule, beam directions and noise streams.
#[derive(Clone)]
pub(crate) struct LidarSim {
    pub(crate) id: u32,
    pub(crate) params: LidarParams,
    pub(crate) next_fire_ns: u64,
    /// Whether it fires at the current tick.
    pub(crate) fire_now: bool,
    period_ns: u64,
    /// Beam directions in the z-up lidar frame (cos, sin).
    dirs: Vec<(f64, f64)>,
    noise: NoiseStreams,
    /// The mount the rays are cast from: `params.lidar_in_robot` unless the extrinsic error is
    /// on (the scans always carry `params.lidar_in_robot`).
    pub(crate) cast_mount: Pose2,
    /// The realism effects that act on the scans (none: the ideal lidar).
    realism: Option<Box<LidarRealism>>,
}

/// The per-scan realism effects of one lidar and their random streams.
#[derive(Clone)]
struct LidarRealism {
    cfg: SensorRealism,
    mixed: SimRng,
    range_noise: SimRng,
    jitter: SimRng,
    /// Time between two beams of the sweep, nanoseconds.
    beam_dt_ns: f64,
}

impl LidarSim {
    pub(crate) fn new(
        id: usize,
        params: &LidarParams,
        run_seed: u64,
        tick_ns: u64,
        realism: &SensorRealism,
    ) -> Result<Self, SimError> {
        params.validate().map_err(|e| params_err(format!("lidars[{id}]"), e))?;
        let dirs = (0..params.beams)
            .map(|i| {
                let a = params.beam_direction_rad(i);
                (a.cos(), a.sin())
            })
            .collect();
        let period_ns = params.period_ns().max(1);
        let mut next_fire_ns = tick_ns.saturating_add((params.phase_offset_s * 1e9).round() as u64);
        if realism.unsync {
            let u: f64 = stream_rng(run_seed, &format!("lidar/{id}/phase")).random();
            next_fire_ns = next_fire_ns.saturating_add((u * period_ns as f64).round() as u64);
        }
        let mut cast_mount = params.lidar_in_robot;
        if realism.extrinsic_error {
            let mut rng = stream_rng(run_seed, &format!("lidar/{id}/extrinsic"));
            let mut n = |sigma: f64| Normal::new(0.0, sigma).map_or(0.0, |d| d.sample(&mut rng));
            let (dx, dy, dyaw) =
                (n(realism.extrinsic_sigma_xy_m), n(realism.extrinsic_sigma_xy_m), n(realism.extrinsic_sigma_yaw_rad));
            cast_mount = Pose2::new(cast_mount.x + dx, cast_mount.y + dy, cast_mount.yaw + dyaw);
        }
        let acts = realism.mixed_pixels || realism.range_noise || realism.needs_history();
        let lidar_realism = acts.then(|| {
            Box::new(LidarRealism {
                cfg: realism.clone(),
                mixed: SimRng::stream(run_seed, &format!("lidar/{id}/mixed")),
                range_noise: SimRng::stream(run_seed, &format!("lidar/{id}/range_noise")),
                jitter: SimRng::stream(run_seed, &format!("lidar/{id}/jitter")),
                beam_dt_ns: period_ns as f64 * params.angle_increment_rad.abs() / (2.0 * PI),
            })
        });
        Ok(Self {
            id: id as u32,
            params: params.clone(),
            next_fire_ns,
            fire_now: false,
            period_ns,
            dirs,
            noise: NoiseStreams::new(run_seed, id, &params.noise),
            cast_mount,
            realism: lidar_realism,
        })
    }

    /// Whether the lidar fires at time `t_ns`; advances its schedule if so.
    pub(crate) fn due(&mut self, t_ns: u64) -> bool {
        if t_ns < self.next_fire_ns {
            return false;
        }
        while self.next_fire_ns <= t_ns {
            // Saturating: at u64::MAX ns (584 years) the lidar simply stops firing.
            self.next_fire_ns = self.next_fire_ns.saturating_add(self.period_ns);
            if self.next_fire_ns == u64::MAX {
                break;
            }
        }
        true
    }

    /// The longest look back into the robot's past poses a scan of this lidar needs,
    /// nanoseconds.
    pub(crate) fn lookback_ns(&self) -> u64 {
        let Some(r) = &self.realism else { return 0 };
        let sweep = if r.cfg.motion_distortion { r.beam_dt_ns * self.dirs.len() as f64 } else { 0.0 };
        let delay = if r.cfg.latency { (r.cfg.latency_s + r.cfg.jitter_s) * 1e9 } else { 0.0 };
        (sweep + delay).ceil() as u64
    }

    /// Exact distances of every beam from the robot at `robot_in_map` (`None`: nothing within
    /// range), written into `out`.
    pub(crate) fn true_ranges(&self, scene: &Scene<'_>, robot_in_map: &Pose2, out: &mut Vec<Option<f64>>) {
        let lidar = robot_in_map.compose(&self.cast_mount);
        let (s, c) = lidar.yaw.sin_cos();
        out.clear();
        if scene.statics.inside(lidar.position()) {
            out.resize(self.dirs.len(), Some(0.0));
            return;
        }
        for &(dc, ds) in &self.dirs {
            out.push(self.cast_beam(scene, &lidar, (c * dc - s * ds, s * dc + c * ds)));
        }
    }

    /// As [`LidarSim::true_ranges`], beam `i` cast from the robot at `robot_at(i)`.
    fn true_ranges_moving(&self, scene: &Scene<'_>, robot_at: impl Fn(usize) -> Pose2, out: &mut Vec<Option<f64>>) {
        out.clear();
        let n = self.dirs.len();
        if scene.statics.inside(robot_at(n - 1).compose(&self.cast_mount).position()) {
            out.resize(n, Some(0.0));
            return;
        }
        for (i, &(dc, ds)) in self.dirs.iter().enumerate() {
            let lidar = robot_at(i).compose(&self.cast_mount);
            let (s, c) = lidar.yaw.sin_cos();
            out.push(self.cast_beam(scene, &lidar, (c * dc - s * ds, s * dc + c * ds)));
        }
    }

    /// The true range of one beam from `lidar` (map frame) along the unit vector `d`.
    #[inline]
    fn cast_beam(&self, scene: &Scene<'_>, lidar: &Pose2, d: (f64, f64)) -> Option<f64> {
        let max = self.params.range_max_m;
        let (dx, dy) = d;
        let mut best = scene.statics.cast(lidar.x, lidar.y, dx, dy, max);
        for (shape, center, radius) in scene.agents {
            // Skip agents the ray passes wide of (or that lie behind it).
            let (rx, ry) = (center.x - lidar.x, center.y - lidar.y);
            let along = rx * dx + ry * dy;
            if (rx * dy - ry * dx).abs() > *radius || along < -radius {
                continue;
            }
            if let Some(t) = cast_shape(shape, lidar.x, lidar.y, dx, dy)
                && best.is_none_or(|b| t < b)
                && t <= max
            {
                best = Some(t);
            }
        }
        best.filter(|&t| t < max)
    }

    /// True ranges through rapier's query pipeline (the reference the fast caster is checked
    /// against).
    #[cfg(test)]
    pub(crate) fn true_ranges_rapier(&self, query: &QueryPipeline<'_>, robot_in_map: &Pose2) -> Vec<Option<f64>> {
        let p = &self.params;
        let lidar = robot_in_map.compose(&self.cast_mount);
        let (s, c) = lidar.yaw.sin_cos();
        let origin = Vector::new(lidar.x as f32, lidar.y as f32);
        self.dirs
            .iter()
            .map(|&(dc, ds)| {
                let dir = Vector::new((c * dc - s * ds) as f32, (s * dc + c * ds) as f32);
                query
                    .cast_ray(&Ray::new(origin, dir), p.range_max_m as f32, true)
                    .map(|(_, toi)| f64::from(toi))
                    .filter(|&t| t < p.range_max_m)
            })
            .collect()
    }

    /// The true ranges of a scan stamped `stamp_ns` with the realism effects that move the
    /// rays (latency, motion distortion) applied, `history` holding the robot's past poses.
    fn realistic_true_ranges(
        &mut self,
        scene: &Scene<'_>,
        robot_in_map: &Pose2,
        stamp_ns: u64,
        history: Option<&PoseHistory>,
        scratch: &mut Vec<Option<f64>>,
    ) {
        let (Some(r), Some(h)) = (self.realism.as_mut(), history) else {
            return self.true_ranges(scene, robot_in_map, scratch);
        };
        let delay_ns =
            if r.cfg.latency { (r.cfg.latency_s + r.jitter.random::<f64>() * r.cfg.jitter_s) * 1e9 } else { 0.0 };
        let t_end = stamp_ns as f64 - delay_ns;
        let n = self.dirs.len();
        if r.cfg.motion_distortion {
            let dt = r.beam_dt_ns;
            self.true_ranges_moving(scene, |i| h.at(t_end - (n - 1 - i) as f64 * dt).unwrap_or(*robot_in_map), scratch);
        } else if r.cfg.latency {
            self.true_ranges(scene, &h.at(t_end).unwrap_or(*robot_in_map), scratch);
        } else {
            self.true_ranges(scene, robot_in_map, scratch);
        }
    }

    /// One scan from the robot at `robot_in_map`; `scratch` is reused between scans;
    /// `history` (the robot's past poses) is needed by motion distortion and latency.
    pub(crate) fn scan(
        &mut self,
        scene: &Scene<'_>,
        robot_in_map: &Pose2,
        stamp_ns: u64,
        scratch: &mut Vec<Option<f64>>,
        history: Option<&PoseHistory>,
    ) -> LaserScan {
        let ranges: Vec<f32> = if self.realism.is_some() {
            self.realistic_true_ranges(scene, robot_in_map, stamp_ns, history, scratch);
            let Some(r) = self.realism.as_mut() else { unreachable!("checked above") };
            if r.cfg.mixed_pixels {
                mix_pixels(scratch, &r.cfg, &mut r.mixed);
            }
            let per_m = if r.cfg.range_noise { r.cfg.range_noise_sigma_per_m } else { 0.0 };
            let p = &self.params;
            scratch
                .iter()
                .map(|&t| {
                    let extra = match t {
                        Some(t) if per_m > 0.0 => {
                            Normal::new(0.0, per_m * t).map_or(0.0, |d| d.sample(&mut r.range_noise))
                        }
                        _ => 0.0,
                    };
                    self.noise.reading_with(t, p, extra)
                })
                .collect()
        } else {
            self.true_ranges(scene, robot_in_map, scratch);
            let p = &self.params;
            scratch.iter().map(|&t| self.noise.reading(t, p)).collect()
        };
        let p = &self.params;
        let (angle_min_rad, angle_increment_rad) = p.scan_angles();
        // With motion distortion the beams are measured one after the other, the last at the
        // stamp (as a driver declares it; a latency, if on, is not known to the receiver).
        let sweep = self
            .realism
            .as_ref()
            .filter(|r| r.cfg.motion_distortion)
            .map(|r| SweepTiming::ending_at_stamp(ranges.len(), r.beam_dt_ns * 1e-9));
        LaserScan {
            stamp_ns,
            lidar_id: self.id,
            lidar_in_robot: p.lidar_in_robot,
            angle_min_rad,
            angle_increment_rad,
            range_min_m: p.range_min_m as f32,
            range_max_m: p.range_max_m as f32,
            ranges_m: ranges,
            sweep,
        }
    }
}

/// Mixed pixels: where two neighbouring beams both return and their ranges differ by at least
/// `mixed_pixel_min_jump_m`, the farther one reads, with `mixed_pixel_probability`, a range
/// uniform between the two surfaces (its footprint straddles the edge). Two draws per edge.
fn mix_pixels(ranges: &mut [Option<f64>], cfg: &SensorRealism, rng: &mut SimRng) {
    for i in 0..ranges.len().saturating_sub(1) {
        let (Some(a), Some(b)) = (ranges[i], ranges[i + 1]) else { continue };
        if (a - b).abs() < cfg.mixed_pixel_min_jump_m {
            continue;
        }
        let (hit, u): (f64, f64) = (rng.random(), rng.random());
        if hit < cfg.mixed_pixel_probability {
            let (near, far_index) = if a < b { (a, i + 1) } else { (b, i) };
            let far = a.max(b);
            ranges[far_index] = Some(near + u * (far - near));
        }
    }
}

/// What the lidars see: the binned static geometry and the agents' current outlines (with a
/// bounding circle each).
pub(crate) struct Scene<'a> {
    pub(crate) statics: &'a StaticCaster,
    pub(crate) agents: &'a [(Shape, Point2, f64)],
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_validate() {
        for p in [
            LidarParams::sick_s300_front(),
            LidarParams::sick_s300_rear(),
            LidarParams::hokuyo_ust20lx(Pose2::IDENTITY),
        ] {
            assert!(p.validate().is_ok());
        }
        assert_eq!(LidarParams::sick_s300_front().period_ns(), 80_000_000);
        assert_eq!(LidarParams::hokuyo_ust20lx(Pose2::IDENTITY).period_ns(), 25_000_000);
        let mut bad = LidarParams::sick_s300_front();
        bad.range_max_m = 0.05;
        assert!(bad.validate().is_err());
        bad = LidarParams::sick_s300_front();
        bad.noise.dropout_probability = 1.5;
        let e = bad.validate().unwrap_err();
        assert_eq!(e, ParamError::new("noise.dropout_probability", 1.5, "must be in [0, 1]"));
        assert_eq!(e.to_string(), "noise.dropout_probability must be in [0, 1], got 1.5");
        bad = LidarParams::sick_s300_front();
        bad.angle_increment_rad = 0.1;
        assert_eq!(
            bad.validate().unwrap_err().to_string(),
            "beams must span at most a full turn, got 541 beams at 0.1 rad"
        );
    }

    #[test]
    fn gaussian_noise_statistics() {
        let mut p = LidarParams::sick_s300_front();
        p.noise = LidarNoise {
            quantisation_m: 0.0,
            dropout_probability: 0.0,
            spurious_probability: 0.0,
            ..LidarNoise::default()
        };
        let mut s = NoiseStreams::new(1, 0, &p.noise);
        let n = 200_000;
        let (mut sum, mut sum2) = (0.0, 0.0);
        for _ in 0..n {
            let e = f64::from(s.reading(Some(5.0), &p)) - 5.0;
            sum += e;
            sum2 += e * e;
        }
        let mean = sum / n as f64;
        let sd = (sum2 / n as f64 - mean * mean).sqrt();
        // Standard error of the mean: 0.03 / √200000 ≈ 6.7e-5; of the sd ≈ 4.7e-5 (+ f32 rounding).
        assert!(mean.abs() < 4e-4, "mean {mean}");
        assert!((sd - 0.03).abs() < 5e-4, "sd {sd}");
    }

    #[test]
    fn dropout_and_spurious_rates() {
        let mut p = LidarParams::sick_s300_front();
        p.noise = LidarNoise {
            sigma_m: 0.0,
            quantisation_m: 0.0,
            dropout_probability: 0.1,
            spurious_probability: 0.05,
            spurious_max_m: 2.0,
        };
        let mut s = NoiseStreams::new(2, 0, &p.noise);
        let n = 100_000;
        let (mut drops, mut spurious) = (0, 0);
        for _ in 0..n {
            let r = s.reading(Some(10.0), &p);
            if r.is_infinite() {
                drops += 1;
            } else if r != 10.0 {
                assert!((0.1..=2.0).contains(&r), "spurious {r}");
                spurious += 1;
            }
        }
        // Expected 10 % dropouts and 0.9 × 5 % = 4.5 % spurious; binomial sd ≈ 0.1 % and 0.07 %.
        let fd = drops as f64 / n as f64;
        let fs = spurious as f64 / n as f64;
        assert!((fd - 0.1).abs() < 0.005, "dropout fraction {fd}");
        assert!((fs - 0.045).abs() < 0.004, "spurious fraction {fs}");
    }

    #[test]
    fn quantisation_and_max_range() {
        let mut p = LidarParams::sick_s300_front();
        p.noise = LidarNoise { quantisation_m: 0.01, ..LidarNoise::none() };
        let mut s = NoiseStreams::new(3, 0, &p.noise);
        assert!((s.reading(Some(1.23456), &p) - 1.23).abs() < 1e-6);
        assert_eq!(s.reading(None, &p), f32::INFINITY);
        assert_eq!(s.reading(Some(29.999), &p), f32::INFINITY); // rounds to 30.00 = range_max
    }

    #[test]
    fn schedule_fires_at_rate() {
        let p = LidarParams::default();
        let mut l = LidarSim::new(0, &p, 0, 20_000_000, &SensorRealism::default()).unwrap();
        let fired: Vec<u64> = (1..=20u64).map(|k| k * 20_000_000).filter(|&t| l.due(t)).collect();
        assert_eq!(fired, vec![20_000_000, 100_000_000, 180_000_000, 260_000_000, 340_000_000]);
    }
}
