//! Rigid transforms in 3D, only as far as projecting a lidar mount or an odometry pose onto the
//! plane needs them.

use mapkeeper_grid::Pose2;

/// A rotation (row-major matrix) and a translation: a child frame in its parent frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid3 {
    /// Rotation, row-major.
    pub r: [[f64; 3]; 3],
    /// Translation, metres.
    pub t: [f64; 3],
}

impl Rigid3 {
    /// The identity.
    pub const IDENTITY: Rigid3 = Rigid3 { r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], t: [0.0; 3] };

    /// From a translation and a unit quaternion `[x, y, z, w]` (normalised here). `None` if a
    /// value is not finite or the quaternion has (nearly) zero length.
    pub fn from_translation_quaternion(t: [f64; 3], q: [f64; 4]) -> Option<Rigid3> {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(n.is_finite() && n > 1e-9 && t.iter().all(|v| v.is_finite())) {
            return None;
        }
        let [x, y, z, w] = q.map(|v| v / n);
        let r = [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)],
            [2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)],
            [2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)],
        ];
        Some(Rigid3 { r, t })
    }

    /// From a translation and roll, pitch, yaw (radians; `Rz(yaw)·Ry(pitch)·Rx(roll)`, URDF's
    /// convention).
    pub fn from_xyz_rpy(t: [f64; 3], rpy: [f64; 3]) -> Rigid3 {
        let (sr, cr) = rpy[0].sin_cos();
        let (sp, cp) = rpy[1].sin_cos();
        let (sy, cy) = rpy[2].sin_cos();
        let r = [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ];
        Rigid3 { r, t }
    }

    #[allow(clippy::needless_range_loop)]
    /// `self ∘ other` (`other` expressed in `self`'s child frame).
    pub fn compose(&self, other: &Rigid3) -> Rigid3 {
        let mut r = [[0.0; 3]; 3];
        let mut t = self.t;
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = (0..3).map(|k| self.r[i][k] * other.r[k][j]).sum();
                t[i] += self.r[i][j] * other.t[j];
            }
        }
        Rigid3 { r, t }
    }

    #[allow(clippy::needless_range_loop)]
    /// The inverse transform.
    pub fn inverse(&self) -> Rigid3 {
        let mut r = [[0.0; 3]; 3];
        let mut t = [0.0; 3];
        for i in 0..3 {
            for j in 0..3 {
                r[i][j] = self.r[j][i];
                t[i] -= self.r[j][i] * self.t[j];
            }
        }
        Rigid3 { r, t }
    }

    /// The child frame projected on the parent's xy plane: the planar pose of its x axis,
    /// whether it is upside down (its z axis points down, so angles about it run clockwise in the
    /// parent) and its tilt from level, degrees.
    pub fn planar(&self) -> (Pose2, bool, f64) {
        let yaw = self.r[1][0].atan2(self.r[0][0]);
        let mirrored = self.r[2][2] < 0.0;
        let tilt = self.r[2][2].abs().min(1.0).acos().to_degrees();
        (Pose2::new(self.t[0], self.t[1], yaw), mirrored, tilt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_and_rpy_agree_and_compose_inverts() {
        let a = Rigid3::from_xyz_rpy([1.0, 2.0, 0.5], [0.1, -0.2, 0.7]);
        // The same rotation as a quaternion (ZYX Euler angles).
        let (r, p, y) = (0.05f64, -0.1f64, 0.35f64);
        let q = [
            r.sin() * p.cos() * y.cos() - r.cos() * p.sin() * y.sin(),
            r.cos() * p.sin() * y.cos() + r.sin() * p.cos() * y.sin(),
            r.cos() * p.cos() * y.sin() - r.sin() * p.sin() * y.cos(),
            r.cos() * p.cos() * y.cos() + r.sin() * p.sin() * y.sin(),
        ];
        let b = Rigid3::from_translation_quaternion([1.0, 2.0, 0.5], q).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                assert!((a.r[i][j] - b.r[i][j]).abs() < 1e-12);
            }
        }
        let id = a.compose(&a.inverse());
        for i in 0..3 {
            assert!(id.t[i].abs() < 1e-12);
            for j in 0..3 {
                assert!((id.r[i][j] - f64::from(u8::from(i == j))).abs() < 1e-12);
            }
        }
        assert!(Rigid3::from_translation_quaternion([0.0; 3], [0.0; 4]).is_none());
        assert!(Rigid3::from_translation_quaternion([f64::NAN, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]).is_none());
    }

    #[test]
    fn planar_projection_of_a_level_and_an_upside_down_mount() {
        let (p, m, tilt) = Rigid3::from_xyz_rpy([0.3, -0.2, 0.4], [0.0, 0.0, -0.785]).planar();
        assert!((p.yaw + 0.785).abs() < 1e-12 && !m && tilt < 1e-6);
        let (p, m, tilt) = Rigid3::from_xyz_rpy([0.3, -0.2, 0.4], [std::f64::consts::PI, 0.0, 2.0]).planar();
        assert!((p.yaw - 2.0).abs() < 1e-9 && m && tilt < 1e-6);
    }
}
