//! Laser scans, in the shape of ROS `sensor_msgs/LaserScan` plus the lidar's mounting pose.

use mapkeeper_common::ParamError;
use mapkeeper_grid::{Point2, Pose2};
use serde::{Deserialize, Serialize};

/// The most beams a scan may carry (guards against absurd allocations from a bad log).
pub const MAX_BEAMS: usize = 1 << 16;

/// One sweep of one 2D lidar.
///
/// Beam `i` points at `angle_min_rad + i · angle_increment_rad` in the lidar's frame. A reading
/// is valid when it is finite and `range_min_m ≤ r < range_max_m`; "no return" is reported as
/// `+inf` (REP 117), and readings at or beyond `range_max_m`, NaN, negative or below the minimum
/// are invalid and counted as such by every consumer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Acquisition time, nanoseconds since the start of the run.
    pub stamp_ns: u64,
    /// Which lidar of the robot produced the scan (index into the robot's lidar list).
    pub lidar_id: u32,
    /// Mounting pose of the lidar in the robot's base frame (extrinsics).
    pub lidar_in_robot: Pose2,
    /// Angle of the first beam in the lidar frame, radians.
    pub angle_min_rad: f64,
    /// Angle between consecutive beams, radians (may be negative for a mirrored lidar).
    pub angle_increment_rad: f64,
    /// Smallest valid range, metres.
    pub range_min_m: f32,
    /// Readings at or beyond this are invalid, metres.
    pub range_max_m: f32,
    /// One reading per beam, metres.
    pub ranges_m: Vec<f32>,
    /// When each beam was measured, if known ([`SweepTiming`]: ROS `time_increment`, the
    /// simulator's motion distortion); `None`: unknown, or every beam at the stamp. Absent from
    /// a log line when `None`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sweep: Option<SweepTiming>,
}

/// Why a beam is or is not usable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum BeamValidity {
    /// A usable reading.
    Valid,
    /// NaN or ±inf (inf = no return).
    NotFinite,
    /// Negative, zero or below the lidar's minimum range.
    BelowMin,
    /// At or beyond the maximum range.
    AtOrBeyondMax,
}

/// A scan whose header is unusable as a whole.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum ScanError {
    /// A field of the header holds an unusable value: `angle_min_rad` (finite),
    /// `angle_increment_rad` (finite and non-zero), the `range limits` (finite, 0 ≤ min < max),
    /// `lidar_in_robot` (finite) or the `sweep timing` (finite, every beam within
    /// [`crate::MAX_SWEEP_S`] of the stamp).
    #[error(transparent)]
    BadHeader(#[from] ParamError),
    /// Too many beams.
    #[error("scan has {0} beams, more than the limit of {MAX_BEAMS}")]
    TooManyBeams(usize),
    /// The beams span more than a full turn.
    #[error("{beams} beams at {increment} rad span more than a full turn")]
    SpanTooLarge {
        /// Beam count.
        beams: usize,
        /// Increment.
        increment: f64,
    },
}

impl LaserScan {
    /// Checks the header (angles, limits, mount, beam count). Individual readings are never an
    /// error: bad ones are invalid beams.
    pub fn validate(&self) -> Result<(), ScanError> {
        if !self.angle_min_rad.is_finite() {
            return Err(ParamError::new("angle_min_rad", self.angle_min_rad, "must be finite").into());
        }
        if !(self.angle_increment_rad.is_finite() && self.angle_increment_rad != 0.0) {
            let inc = self.angle_increment_rad;
            return Err(ParamError::new("angle_increment_rad", inc, "must be finite and non-zero").into());
        }
        let (min, max) = (self.range_min_m, self.range_max_m);
        if !(min.is_finite() && max.is_finite() && min >= 0.0 && min < max) {
            let requirement = "must satisfy 0 <= range_min_m < range_max_m (finite)";
            return Err(ParamError::new("range limits", format!("{min} and {max}"), requirement).into());
        }
        if !self.lidar_in_robot.is_finite() {
            return Err(
                ParamError::new("lidar_in_robot", format!("{:?}", self.lidar_in_robot), "must be finite").into()
            );
        }
        if self.ranges_m.len() > MAX_BEAMS {
            return Err(ScanError::TooManyBeams(self.ranges_m.len()));
        }
        let span = self.angle_increment_rad.abs() * self.ranges_m.len().saturating_sub(1) as f64;
        if span > 2.0 * std::f64::consts::PI + 1e-6 {
            return Err(ScanError::SpanTooLarge { beams: self.ranges_m.len(), increment: self.angle_increment_rad });
        }
        if let Some(t) = &self.sweep {
            t.check(self.ranges_m.len())?;
        }
        Ok(())
    }

    /// Number of beams.
    pub fn len(&self) -> usize {
        self.ranges_m.len()
    }

    /// Whether the scan has no beam.
    pub fn is_empty(&self) -> bool {
        self.ranges_m.is_empty()
    }

    /// Angle of beam `i` in the lidar frame, radians (`i` may be fractional for virtual rays).
    #[inline]
    pub fn beam_angle(&self, i: f64) -> f64 {
        self.angle_min_rad + i * self.angle_increment_rad
    }

    /// Whether reading `r` is usable under this scan's limits.
    #[inline]
    pub fn validity_of(&self, r: f32) -> BeamValidity {
        if !r.is_finite() {
            BeamValidity::NotFinite
        } else if r <= 0.0 || r < self.range_min_m {
            BeamValidity::BelowMin
        } else if r >= self.range_max_m {
            BeamValidity::AtOrBeyondMax
        } else {
            BeamValidity::Valid
        }
    }

    /// Validity of beam `i` (out of bounds is `NotFinite`).
    #[inline]
    pub fn validity(&self, i: usize) -> BeamValidity {
        self.ranges_m.get(i).map_or(BeamValidity::NotFinite, |&r| self.validity_of(r))
    }

    /// Number of valid beams.
    pub fn valid_count(&self) -> usize {
        (0..self.len()).filter(|&i| self.validity(i) == BeamValidity::Valid).count()
    }

    /// The lidar's pose in the map given the robot's.
    pub fn lidar_in_map(&self, robot_in_map: &Pose2) -> Pose2 {
        robot_in_map.compose(&self.lidar_in_robot)
    }

    /// The hit point of beam `i` in the map frame (paper eq. 2 with extrinsics), if valid.
    #[inline]
    pub fn hit_point(&self, lidar_in_map: &Pose2, i: usize) -> Option<Point2> {
        if self.validity(i) != BeamValidity::Valid {
            return None;
        }
        let r = self.ranges_m[i] as f64;
        let a = lidar_in_map.yaw + self.beam_angle(i as f64);
        Some(Point2::new(lidar_in_map.x + r * a.cos(), lidar_in_map.y + r * a.sin()))
    }
}

/// The longest sweep accepted, seconds (a lidar turning at 1 Hz).
pub const MAX_SWEEP_S: f64 = 1.0;

/// When the beams of a scan were measured: beam `i` at `stamp + first_beam_s + i ·
/// time_increment_s` (seconds).
///
/// ```
/// use mapkeeper_sensor::SweepTiming;
/// // ROS drivers stamp the first beam; the simulator stamps the last.
/// let ros = SweepTiming { first_beam_s: 0.0, time_increment_s: 1e-4 };
/// assert!((ros.beam_offset_s(540) - 0.054).abs() < 1e-12);
/// let sim = SweepTiming::ending_at_stamp(541, 1e-4);
/// assert!((sim.beam_offset_s(0) + 0.054).abs() < 1e-12 && sim.beam_offset_s(540).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepTiming {
    /// Time of beam 0 relative to the scan's stamp, seconds: 0 when the stamp is the first beam's
    /// time (the ROS drivers' convention, `LaserScan.header.stamp`), `−(n − 1) · time_increment_s`
    /// when it is the last beam's (the simulator's).
    pub first_beam_s: f64,
    /// Time between consecutive beams, seconds (ROS `LaserScan.time_increment`; negative for a
    /// lidar that sweeps its beams in decreasing index order).
    pub time_increment_s: f64,
}

impl SweepTiming {
    /// The timing of a scan of `beams` beams stamped at its last beam.
    pub fn ending_at_stamp(beams: usize, time_increment_s: f64) -> Self {
        Self { first_beam_s: -(beams.saturating_sub(1) as f64) * time_increment_s, time_increment_s }
    }

    /// Beam `i`'s time relative to the stamp, seconds.
    pub fn beam_offset_s(&self, i: usize) -> f64 {
        self.first_beam_s + i as f64 * self.time_increment_s
    }

    /// Whether the timing is usable for a scan of `beams` beams: finite, and every beam within
    /// [`MAX_SWEEP_S`] of the stamp. What is wrong otherwise (named `sweep timing`).
    pub fn check(&self, beams: usize) -> Result<(), ParamError> {
        let last = self.beam_offset_s(beams.saturating_sub(1));
        if !(self.first_beam_s.is_finite() && self.time_increment_s.is_finite()) {
            let value = format!("first_beam_s {} and time_increment_s {}", self.first_beam_s, self.time_increment_s);
            return Err(ParamError::new("sweep timing", value, "must be finite"));
        }
        if self.first_beam_s.abs() > MAX_SWEEP_S || last.abs() > MAX_SWEEP_S {
            return Err(ParamError::new(
                "sweep timing",
                format!("beams at {:.3} s to {last:.3} s", self.first_beam_s),
                format!("must put every beam within {MAX_SWEEP_S} s of the stamp"),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(ranges: Vec<f32>) -> LaserScan {
        LaserScan {
            stamp_ns: 0,
            lidar_id: 0,
            lidar_in_robot: Pose2::new(0.2, -0.1, -std::f64::consts::FRAC_PI_4),
            angle_min_rad: -0.5,
            angle_increment_rad: 0.25,
            range_min_m: 0.1,
            range_max_m: 30.0,
            ranges_m: ranges,
            sweep: None,
        }
    }

    #[test]
    fn validity_classes() {
        let s = scan(vec![1.0, f32::NAN, f32::INFINITY, -1.0, 0.0, 0.05, 30.0, 31.0, 29.99]);
        let v: Vec<_> = (0..s.len()).map(|i| s.validity(i)).collect();
        use BeamValidity::*;
        assert_eq!(
            v,
            vec![Valid, NotFinite, NotFinite, BelowMin, BelowMin, BelowMin, AtOrBeyondMax, AtOrBeyondMax, Valid]
        );
        assert_eq!(s.valid_count(), 2);
        assert!(s.validate().is_ok());
    }

    #[test]
    fn hit_point_uses_extrinsics() {
        let s = scan(vec![1.0, 1.0, 1.0]);
        let robot = Pose2::new(1.0, 1.0, std::f64::consts::FRAC_PI_4);
        let lidar = s.lidar_in_map(&robot);
        // Beam 2 points along the lidar's x axis, which is the map's x axis here.
        let p = s.hit_point(&lidar, 2).unwrap();
        assert!((p.x - (lidar.x + 1.0)).abs() < 1e-9 && (p.y - lidar.y).abs() < 1e-9);
    }

    #[test]
    fn header_errors() {
        let mut s = scan(vec![1.0]);
        s.angle_increment_rad = 0.0;
        let e = s.validate().unwrap_err();
        assert_eq!(e, ScanError::BadHeader(ParamError::new("angle_increment_rad", 0, "must be finite and non-zero")));
        assert_eq!(e.to_string(), "angle_increment_rad must be finite and non-zero, got 0");
        let mut s = scan(vec![1.0]);
        s.range_max_m = s.range_min_m;
        assert_eq!(
            s.validate().unwrap_err().to_string(),
            "range limits must satisfy 0 <= range_min_m < range_max_m (finite), got 0.1 and 0.1"
        );
        let mut s = scan(vec![1.0; 100]);
        s.angle_increment_rad = 0.1;
        assert!(matches!(s.validate(), Err(ScanError::SpanTooLarge { .. })));
        let mut s = scan(vec![]);
        s.lidar_in_robot.x = f64::NAN;
        assert!(matches!(s.validate(), Err(ScanError::BadHeader(p)) if p.name == "lidar_in_robot"));
        let mut s = scan(vec![1.0; 3]);
        s.sweep = Some(SweepTiming { first_beam_s: 0.0, time_increment_s: 0.75 });
        assert_eq!(
            s.validate().unwrap_err().to_string(),
            "sweep timing must put every beam within 1 s of the stamp, got beams at 0.000 s to 1.500 s"
        );
        s.sweep = Some(SweepTiming { first_beam_s: f64::NAN, time_increment_s: 0.0 });
        assert!(
            matches!(s.validate(), Err(ScanError::BadHeader(p)) if p.name == "sweep timing" && p.requirement == "must be finite")
        );
    }
}
