//! Scans as a moving lidar takes them: a lidar sweeps its beams one after the other, so while the
//! robot moves, the beams of one scan are measured from different poses (motion distortion).
//! [`SweepTiming`](crate::SweepTiming) says when each beam was measured; [`deskew`] re-expresses every beam as if it
//! had been measured from the robot's pose at one reference time, given the robot's motion over
//! the sweep.
//!
//! The deskewed scan keeps the scan's beam layout (`angle_min_rad`, `angle_increment_rad`, the
//! beam count), so every consumer reads it as any scan: each valid beam's endpoint is moved into
//! the reference frame and written into the beam whose angle is nearest to its new bearing (at
//! most half an increment off; where two land on one beam the nearer endpoint is kept). Beams
//! that nothing lands on are NaN (invalid); invalid readings (no return, below the minimum, …)
//! stay where they were unless a moved valid beam lands there.

use crate::scan::LaserScan;
use mapkeeper_grid::{Point2, Pose2, wrap_angle};

/// `scan` deskewed: `robot_at(τ)` is the robot's pose `τ` seconds after the scan's stamp, in the
/// frame of the robot at the reference time (so `robot_at` of the reference offset is the
/// identity). Without timing (or with a timing [`SweepTiming::check`](crate::SweepTiming::check) refuses) the scan is
/// returned as it is.
pub fn deskew(scan: &LaserScan, robot_at: impl Fn(f64) -> Pose2) -> LaserScan {
    let n = scan.ranges_m.len();
    let Some(timing) = scan.sweep.filter(|t| t.check(n).is_ok()) else { return scan.clone() };
    let inc = scan.angle_increment_rad;
    if !(inc.is_finite() && inc != 0.0) {
        return scan.clone();
    }
    let mount = scan.lidar_in_robot;
    let mount_inv = mount.inverse();
    let mut out: Vec<f32> = vec![f32::NAN; n];
    let mut moved: Vec<bool> = vec![false; n];
    for (i, &r) in scan.ranges_m.iter().enumerate() {
        if scan.validity_of(r) != crate::BeamValidity::Valid {
            if !moved[i] {
                out[i] = r;
            }
            continue;
        }
        let a = scan.beam_angle(i as f64);
        let in_lidar = Point2::new(r as f64 * a.cos(), r as f64 * a.sin());
        let lidar_then = robot_at(timing.beam_offset_s(i)).compose(&mount);
        let p = mount_inv.transform_point(lidar_then.transform_point(in_lidar));
        let (range, bearing) = (p.x.hypot(p.y), p.y.atan2(p.x));
        let shift = (wrap_angle(bearing - a) / inc).round();
        let j = i as f64 + shift;
        if !(j >= 0.0 && j < n as f64) {
            continue;
        }
        let j = j as usize;
        let range = range as f32;
        if !moved[j] || range < out[j] {
            out[j] = range;
            moved[j] = true;
        }
    }
    LaserScan { ranges_m: out, sweep: None, ..scan.clone() }
}

/// The robot's motion over a sweep at constant velocity, from two odometry poses: `before` at
/// `before_ns` and `now` at `now_ns` (`before_ns < now_ns`). Returns `robot_at` for [`deskew`]
/// of a scan stamped `stamp_ns`, with the robot at `now_ns` as the reference: the pose at
/// `stamp + τ` in the frame of the robot at `now_ns`, interpolated (or, past `now_ns`,
/// extrapolated) linearly in x, y and yaw.
pub fn constant_velocity(
    before: Pose2,
    before_ns: u64,
    now: Pose2,
    now_ns: u64,
    stamp_ns: u64,
) -> Option<impl Fn(f64) -> Pose2> {
    if before_ns >= now_ns {
        return None;
    }
    let span_s = (now_ns - before_ns) as f64 * 1e-9;
    let back = now.between(&before);
    let stamp_from_now_s = (stamp_ns as f64 - now_ns as f64) * 1e-9;
    Some(move |tau: f64| {
        // The fraction of the way back to `before` at stamp + τ (negative: after now).
        let k = -(stamp_from_now_s + tau) / span_s;
        Pose2::new(k * back.x, k * back.y, k * back.yaw)
    })
}

/// Every scan of `scans` deskewed to the robot at `now` (time ns, pose), the motion over each
/// sweep taken at constant velocity from `before` ([`constant_velocity`], [`deskew`]); a scan
/// without timing, or with no motion to take (`before` not earlier than `now`), as it is.
pub fn deskew_all(scans: &[LaserScan], before: (u64, Pose2), now: (u64, Pose2)) -> Vec<LaserScan> {
    scans
        .iter()
        .map(|s| match constant_velocity(before.1, before.0, now.1, now.0, s.stamp_ns) {
            Some(at) => deskew(s, at),
            None => s.clone(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SweepTiming;

    /// A lidar at the robot's centre in a square room of half-side 5 m centred at the origin:
    /// the range of a beam at `bearing` (map frame) from `from`.
    fn wall_range(from: Pose2, bearing: f64) -> f64 {
        let (c, s) = (bearing.cos(), bearing.sin());
        let tx = if c > 0.0 {
            (5.0 - from.x) / c
        } else if c < 0.0 {
            (-5.0 - from.x) / c
        } else {
            f64::INFINITY
        };
        let ty = if s > 0.0 {
            (5.0 - from.y) / s
        } else if s < 0.0 {
            (-5.0 - from.y) / s
        } else {
            f64::INFINITY
        };
        tx.min(ty)
    }

    /// A 360-beam scan taken while the robot drives at (vx, 0) m/s and turns at w rad/s from the
    /// origin, beams swept over `sweep_s` and stamped at the last beam.
    fn moving_scan(vx: f64, w: f64, sweep_s: f64) -> (LaserScan, impl Fn(f64) -> Pose2) {
        let n = 360;
        let dt = sweep_s / (n - 1) as f64;
        let inc = 2.0 * std::f64::consts::PI / n as f64;
        // Robot pose at time t (s) from the stamp, world frame; the stamp pose is (0, 0, 0).
        let pose = move |t: f64| Pose2::new(vx * t, 0.0, w * t);
        let ranges_m = (0..n)
            .map(|i| {
                let t = -((n - 1 - i) as f64) * dt;
                let p = pose(t);
                wall_range(p, p.yaw - std::f64::consts::PI + i as f64 * inc) as f32
            })
            .collect();
        let scan = LaserScan {
            stamp_ns: 1_000_000_000,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: -std::f64::consts::PI,
            angle_increment_rad: inc,
            range_min_m: 0.05,
            range_max_m: 30.0,
            ranges_m,
            sweep: Some(SweepTiming::ending_at_stamp(n, dt)),
        };
        (scan, pose)
    }

    fn truth_ranges(scan: &LaserScan) -> Vec<f64> {
        (0..scan.ranges_m.len()).map(|i| wall_range(Pose2::IDENTITY, scan.beam_angle(i as f64))).collect()
    }

    /// Median absolute error against the ranges seen from the stamp pose, metres.
    fn median_error(scan: &LaserScan) -> f64 {
        let truth = truth_ranges(scan);
        let mut e: Vec<f64> = scan
            .ranges_m
            .iter()
            .zip(&truth)
            .filter(|(r, _)| r.is_finite())
            .map(|(r, t)| (*r as f64 - t).abs())
            .collect();
        e.sort_by(f64::total_cmp);
        e[e.len() / 2]
    }

    #[test]
    fn deskewing_removes_the_distortion_of_a_turning_drive() {
        let (scan, pose) = moving_scan(1.0, 1.0, 0.1);
        let raw = median_error(&scan);
        let fixed = deskew(&scan, &pose);
        assert!(fixed.sweep.is_none());
        let after = median_error(&fixed);
        assert!(raw > 0.05, "the distortion should be visible: {raw}");
        // What is left is the re-binning: a beam lands at most half an increment (0.5° here) off.
        assert!(after < 0.02 && after < raw / 5.0, "deskewed median error {after} (raw {raw})");
        let holes = fixed.ranges_m.iter().filter(|r| r.is_nan()).count();
        assert!(holes <= 10, "{holes} beams without a reading");
    }

    #[test]
    fn the_constant_velocity_motion_from_two_odometry_poses() {
        // 1 m/s forward, 1 rad/s, odometry 0.1 s apart, scan stamped at the later one.
        let before = Pose2::new(2.0, 3.0, 0.5);
        let now = before.compose(&Pose2::new(0.1, 0.0, 0.1));
        let at = constant_velocity(before, 0, now, 100_000_000, 100_000_000).unwrap();
        assert!(at(0.0).distance(&Pose2::IDENTITY) < 1e-12);
        let half = at(-0.05);
        assert!((half.x + 0.05).abs() < 2e-3 && (half.yaw + 0.05).abs() < 1e-12, "{half:?}");
        // A scan stamped 0.02 s before the odometry: its stamp is already 0.02 s back.
        let at = constant_velocity(before, 0, now, 100_000_000, 80_000_000).unwrap();
        assert!((at(0.0).yaw + 0.02).abs() < 1e-12);
        assert!(constant_velocity(before, 5, now, 5, 5).is_none());
    }

    #[test]
    fn a_scan_without_timing_or_with_a_bad_one_is_returned_as_is() {
        let (mut scan, pose) = moving_scan(1.0, 0.5, 0.1);
        scan.sweep = None;
        assert_eq!(deskew(&scan, &pose), scan);
        scan.sweep = Some(SweepTiming { first_beam_s: f64::NAN, time_increment_s: 1e-4 });
        assert_eq!(deskew(&scan, &pose).ranges_m, scan.ranges_m);
        scan.sweep = Some(SweepTiming { first_beam_s: 0.0, time_increment_s: 0.01 });
        assert!(scan.sweep.unwrap().check(360).is_err());
        assert_eq!(deskew(&scan, &pose), scan);
    }

    #[test]
    fn a_standing_robot_keeps_its_scan() {
        let (scan, _) = moving_scan(0.0, 0.0, 0.1);
        let fixed = deskew(&scan, |_| Pose2::IDENTITY);
        assert_eq!(fixed.ranges_m, scan.ranges_m);
    }
}
