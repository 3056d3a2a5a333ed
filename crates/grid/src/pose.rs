//! Rigid transforms in the plane (SE(2)) and points.
//!
//! Frames are named in variable names (`pose_in_map`, `lidar_in_robot`): a `Pose2` called
//! `a_in_b` maps coordinates expressed in frame `a` into frame `b`.

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// A point in the plane, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point2 {
    /// x coordinate, metres.
    pub x: f64,
    /// y coordinate, metres.
    pub y: f64,
}

impl Point2 {
    /// A point from its coordinates.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Euclidean distance to `other`.
    pub fn distance(self, other: Point2) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// Squared Euclidean distance to `other`.
    pub fn distance_sq(self, other: Point2) -> f64 {
        let dx = self.x - other.x;
        let dy = self.y - other.y;
        dx * dx + dy * dy
    }

    /// Whether both coordinates are finite.
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

impl From<[f64; 2]> for Point2 {
    /// `[x, y]`.
    fn from([x, y]: [f64; 2]) -> Self {
        Self { x, y }
    }
}

/// A rigid transform in the plane: translation `(x, y)` in metres, rotation `yaw` in radians.
///
/// ```
/// use mapkeeper_grid::{Point2, Pose2};
/// let robot_in_map = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
/// let p = robot_in_map.transform_point(Point2::new(1.0, 0.0));
/// assert!((p.x - 1.0).abs() < 1e-12 && (p.y - 3.0).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose2 {
    /// Translation along x, metres.
    pub x: f64,
    /// Translation along y, metres.
    pub y: f64,
    /// Rotation, radians (counter-clockwise).
    pub yaw: f64,
}

impl Pose2 {
    /// The identity transform.
    pub const IDENTITY: Pose2 = Pose2 { x: 0.0, y: 0.0, yaw: 0.0 };

    /// A pose from its components.
    pub const fn new(x: f64, y: f64, yaw: f64) -> Self {
        Self { x, y, yaw }
    }

    /// The translation part as a point.
    pub fn position(&self) -> Point2 {
        Point2::new(self.x, self.y)
    }

    /// `self ∘ other`: if `self` is `b_in_c` and `other` is `a_in_b`, the result is `a_in_c`.
    #[inline]
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        self.prepare().compose(other)
    }

    /// The inverse transform: `a_in_b` becomes `b_in_a`.
    pub fn inverse(&self) -> Pose2 {
        let (s, c) = self.yaw.sin_cos();
        Pose2 { x: -c * self.x - s * self.y, y: s * self.x - c * self.y, yaw: wrap_angle(-self.yaw) }
    }

    /// The motion from `self` to `other` expressed in `self`'s frame (`self⁻¹ ∘ other`).
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// Maps a point expressed in this pose's frame into the parent frame.
    #[inline]
    pub fn transform_point(&self, p: Point2) -> Point2 {
        self.prepare().transform_point(p)
    }

    /// The pose with its yaw's sine and cosine computed once, for applying it many times:
    /// [`PreparedPose::transform_point`] and [`PreparedPose::compose`] give the same results
    /// as the pose's own methods, bit for bit.
    ///
    /// ```
    /// use mapkeeper_grid::{Point2, Pose2};
    /// let pose = Pose2::new(1.0, -2.0, 0.7);
    /// let t = pose.prepare();
    /// let p = Point2::new(0.3, 4.0);
    /// assert_eq!(t.transform_point(p), pose.transform_point(p));
    /// let q = Pose2::new(-0.5, 0.25, 3.0);
    /// assert_eq!(t.compose(&q), pose.compose(&q));
    /// ```
    #[inline]
    pub fn prepare(&self) -> PreparedPose {
        let (sin, cos) = self.yaw.sin_cos();
        PreparedPose { pose: *self, sin, cos }
    }

    /// Euclidean distance between the translation parts.
    pub fn distance(&self, other: &Pose2) -> f64 {
        self.position().distance(other.position())
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite()
    }
}

/// Wraps an angle into `(-π, π]`.
pub fn wrap_angle(a: f64) -> f64 {
    if !a.is_finite() {
        return a;
    }
    let mut r = a % (2.0 * PI);
    if r <= -PI {
        r += 2.0 * PI;
    } else if r > PI {
        r -= 2.0 * PI;
    }
    r
}

/// Signed smallest difference `a − b` between two angles, in `(-π, π]`.
pub fn angle_diff(a: f64, b: f64) -> f64 {
    wrap_angle(a - b)
}

/// A [`Pose2`] with the sine and cosine of its yaw ([`Pose2::prepare`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedPose {
    pose: Pose2,
    sin: f64,
    cos: f64,
}

impl PreparedPose {
    /// The pose.
    #[inline]
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// `(sin, cos)` of the pose's yaw, as `yaw.sin_cos()` gives them.
    #[inline]
    pub fn sin_cos(&self) -> (f64, f64) {
        (self.sin, self.cos)
    }

    /// [`Pose2::transform_point`].
    #[inline(always)]
    pub fn transform_point(&self, p: Point2) -> Point2 {
        let (s, c, t) = (self.sin, self.cos, &self.pose);
        Point2::new(t.x + c * p.x - s * p.y, t.y + s * p.x + c * p.y)
    }

    /// [`Pose2::compose`].
    #[inline(always)]
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let (s, c, t) = (self.sin, self.cos, &self.pose);
        Pose2 {
            x: t.x + c * other.x - s * other.y,
            y: t.y + s * other.x + c * other.y,
            yaw: wrap_angle(t.yaw + other.yaw),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &Pose2, b: &Pose2) -> bool {
        (a.x - b.x).abs() < 1e-12 && (a.y - b.y).abs() < 1e-12 && angle_diff(a.yaw, b.yaw).abs() < 1e-12
    }

    #[test]
    fn compose_with_inverse_is_identity() {
        let p = Pose2::new(1.5, -2.0, 2.8);
        assert!(close(&p.compose(&p.inverse()), &Pose2::IDENTITY));
        assert!(close(&p.inverse().compose(&p), &Pose2::IDENTITY));
    }

    #[test]
    fn between_recovers_relative_motion() {
        let a = Pose2::new(1.0, 1.0, 0.3);
        let d = Pose2::new(0.5, -0.2, -0.1);
        let b = a.compose(&d);
        assert!(close(&a.between(&b), &d));
    }

    #[test]
    fn wrap_angle_range() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-15);
        assert!((angle_diff(-3.0, 3.0) - (2.0 * PI - 6.0)).abs() < 1e-12);
    }
}
