//! Update gating (§4.5 and the parameter table): the cells update runs only after the robot has
//! moved at least `gating_min_translation_m` or turned at least `gating_min_rotation_rad` since
//! the last processed scan, measured by odometry. The `authors` preset adds a minimum interval
//! and a pause after fast rotations.

use crate::UpdaterParams;
use mapkeeper_grid::{Pose2, angle_diff};

/// Why a step was not processed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GateReason {
    /// The robot has not moved or turned enough since the last processed scan.
    TooLittleMotion,
    /// Less than `gating_min_interval_s` since the last processed scan.
    TooSoon,
    /// Inside the pause that follows a rotation faster than `fast_rotation_rad_s`.
    FastRotationPause,
}

#[derive(Clone, Copy, Debug)]
struct Pause {
    start_ns: u64,
    travelled_m: f64,
}

/// The gate's memory: the odometry pose and time of the last processed and the last seen step.
#[derive(Clone, Debug, Default)]
pub struct UpdateGate {
    last_processed: Option<(Pose2, u64)>,
    last_seen: Option<(Pose2, u64)>,
    pause: Option<Pause>,
}

impl UpdateGate {
    /// A gate that lets the first step through.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decides whether the step at `robot_in_odom`, `stamp_ns` is processed; `None` means yes.
    /// The caller reports a processed step with [`UpdateGate::mark_processed`].
    pub fn check(&mut self, robot_in_odom: Pose2, stamp_ns: u64, params: &UpdaterParams) -> Option<GateReason> {
        // Fast-rotation pause bookkeeping (`authors` preset), over every step seen.
        if let Some((prev, prev_ns)) = self.last_seen {
            let dt_s = stamp_ns.saturating_sub(prev_ns) as f64 * 1e-9;
            let step_m = prev.distance(&robot_in_odom);
            if let Some(p) = self.pause.as_mut() {
                p.travelled_m += step_m;
            }
            if params.fast_rotation_rad_s.is_finite() && dt_s > 0.0 {
                let rate = angle_diff(robot_in_odom.yaw, prev.yaw).abs() / dt_s;
                if rate > params.fast_rotation_rad_s {
                    self.pause = Some(Pause { start_ns: stamp_ns, travelled_m: 0.0 });
                }
            }
        }
        self.last_seen = Some((robot_in_odom, stamp_ns));
        if let Some(p) = self.pause {
            let elapsed_s = stamp_ns.saturating_sub(p.start_ns) as f64 * 1e-9;
            if elapsed_s < params.fast_rotation_pause_s || p.travelled_m < params.fast_rotation_pause_m {
                return Some(GateReason::FastRotationPause);
            }
            self.pause = None;
        }
        let (last, last_ns) = self.last_processed?;
        let dt_s = stamp_ns.saturating_sub(last_ns) as f64 * 1e-9;
        if dt_s < params.gating_min_interval_s {
            return Some(GateReason::TooSoon);
        }
        let moved = last.distance(&robot_in_odom) >= params.gating_min_translation_m;
        let turned = angle_diff(robot_in_odom.yaw, last.yaw).abs() >= params.gating_min_rotation_rad;
        if moved || turned { None } else { Some(GateReason::TooLittleMotion) }
    }

    /// Records that the step at `robot_in_odom`, `stamp_ns` was processed.
    pub fn mark_processed(&mut self, robot_in_odom: Pose2, stamp_ns: u64) {
        self.last_processed = Some((robot_in_odom, stamp_ns));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_gate_5cm_or_20deg() {
        let p = UpdaterParams::paper();
        let mut g = UpdateGate::new();
        assert_eq!(g.check(Pose2::IDENTITY, 0, &p), None);
        g.mark_processed(Pose2::IDENTITY, 0);
        assert_eq!(g.check(Pose2::new(0.049, 0.0, 0.0), 1, &p), Some(GateReason::TooLittleMotion));
        assert_eq!(g.check(Pose2::new(0.0, 0.0, 19.9f64.to_radians()), 2, &p), Some(GateReason::TooLittleMotion));
        assert_eq!(g.check(Pose2::new(0.03, 0.04, 0.0), 3, &p), None); // exactly 0.05 m
        assert_eq!(g.check(Pose2::new(0.0, 0.0, -20.0f64.to_radians()), 4, &p), None);
        // Nothing was marked processed, so the reference stays at the origin.
        assert_eq!(g.check(Pose2::new(0.01, 0.0, 0.0), 5, &p), Some(GateReason::TooLittleMotion));
    }

    #[test]
    fn authors_gate_interval_and_fast_rotation_pause() {
        let p = UpdaterParams::authors();
        let mut g = UpdateGate::new();
        assert_eq!(g.check(Pose2::IDENTITY, 0, &p), None);
        g.mark_processed(Pose2::IDENTITY, 0);
        // Moved enough but only 0.2 s later.
        assert_eq!(g.check(Pose2::new(0.1, 0.0, 0.0), 200_000_000, &p), Some(GateReason::TooSoon));
        assert_eq!(g.check(Pose2::new(0.2, 0.0, 0.0), 400_000_000, &p), None);
        g.mark_processed(Pose2::new(0.2, 0.0, 0.0), 400_000_000);
        // 0.5 rad in 0.1 s: 5 rad/s, far above 12°/s.
        assert_eq!(g.check(Pose2::new(0.2, 0.0, 0.5), 500_000_000, &p), Some(GateReason::FastRotationPause));
        // 2 s later but only 1 m travelled: still paused.
        assert_eq!(g.check(Pose2::new(1.2, 0.0, 0.5), 2_500_000_000, &p), Some(GateReason::FastRotationPause));
        assert_eq!(g.check(Pose2::new(2.0, 0.0, 0.5), 3_500_000_000, &p), None);
    }
}
