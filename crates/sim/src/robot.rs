//! The Summit-XL Steel: footprint, drive limits, and the path follower that turns a route into
//! velocity commands.

use mapkeeper_common::ParamError;
use mapkeeper_grid::{Point2, Pose2, angle_diff};
use serde::{Deserialize, Serialize};

/// How the wheels move the base.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DriveKind {
    /// Mecanum wheels: any (vx, vy, ω).
    Omni,
    /// Skid steering: vy = 0.
    SkidSteer,
}

/// The robot's body, limits and path follower.
///
/// ```
/// use mapkeeper_sim::{DriveKind, RobotParams};
/// let mut r = RobotParams::default();
/// r.drive = DriveKind::SkidSteer;
/// assert!(r.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotParams {
    /// Footprint length along x, metres (default 0.75).
    pub length_m: f64,
    /// Footprint width along y, metres (default 0.68).
    pub width_m: f64,
    /// Mass, kilograms (default 105).
    pub mass_kg: f64,
    /// Drive kinematics (default omni).
    pub drive: DriveKind,
    /// Top speed, m/s (default 1.5).
    pub max_speed_mps: f64,
    /// Linear acceleration limit, m/s² (default 0.6).
    pub max_accel_mps2: f64,
    /// Yaw-rate limit, rad/s (default 3.0).
    pub max_yaw_rate_radps: f64,
    /// Yaw acceleration limit, rad/s² (default 1.5).
    pub max_yaw_accel_radps2: f64,
    /// Path follower.
    pub follower: FollowerParams,
}

impl Default for RobotParams {
    fn default() -> Self {
        Self {
            length_m: 0.75,
            width_m: 0.68,
            mass_kg: 105.0,
            drive: DriveKind::Omni,
            max_speed_mps: 1.5,
            max_accel_mps2: 0.6,
            max_yaw_rate_radps: 3.0,
            max_yaw_accel_radps2: 1.5,
            follower: FollowerParams::default(),
        }
    }
}

impl RobotParams {
    /// Checks every field; the follower's are named `follower.…`.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (name, v) in [
            ("length_m", self.length_m),
            ("width_m", self.width_m),
            ("mass_kg", self.mass_kg),
            ("max_speed_mps", self.max_speed_mps),
            ("max_accel_mps2", self.max_accel_mps2),
            ("max_yaw_rate_radps", self.max_yaw_rate_radps),
            ("max_yaw_accel_radps2", self.max_yaw_accel_radps2),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ParamError::new(name, v, "must be finite and > 0"));
            }
        }
        self.follower.validate().map_err(|e| e.within("follower"))
    }

    /// Half the footprint's extent across and along a direction of travel at `angle` from the
    /// robot's heading: `(across, along)`.
    pub(crate) fn half_extents(&self, angle: f64) -> (f64, f64) {
        let (s, c) = angle.sin_cos();
        let (hl, hw) = (self.length_m / 2.0, self.width_m / 2.0);
        ((hl * s).abs() + (hw * c).abs(), (hl * c).abs() + (hw * s).abs())
    }
}

/// The pure-pursuit path follower.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FollowerParams {
    /// Look-ahead distance along the route, metres (default 0.6).
    pub lookahead_m: f64,
    /// A waypoint counts as reached within this distance, metres (default 0.15).
    pub waypoint_tolerance_m: f64,
    /// The last waypoint counts as reached within this distance, metres (default 0.05).
    pub goal_tolerance_m: f64,
    /// Turns sharper than this stop the robot at the waypoint, degrees (default 60).
    pub corner_angle_deg: f64,
    /// At a gentler turn the robot slows so that turning its velocity at the braking
    /// acceleration would cut the corner by at most this much, metres (default 0.1; 0 turns
    /// the rule off). Without it a robot at full speed swings wide of a 30-50° turn by more
    /// than half a metre.
    pub corner_cut_m: f64,
    /// Heading gain: commanded yaw rate per radian of heading error, 1/s (default 2.5).
    pub yaw_gain: f64,
    /// Omni drive: turn to face the direction of travel (default true).
    pub face_travel_direction: bool,
    /// Look this far beyond the stopping distance for agents in the way, metres (default 0.5).
    pub agent_lookahead_m: f64,
    /// Lateral clearance kept from agents, metres (default 0.05).
    pub agent_clearance_m: f64,
    /// With an agent inside the clearance but clear of the robot's footprint, drive no faster
    /// than this, m/s (default 0.2).
    pub creep_speed_mps: f64,
}

impl Default for FollowerParams {
    fn default() -> Self {
        Self {
            lookahead_m: 0.6,
            waypoint_tolerance_m: 0.15,
            goal_tolerance_m: 0.05,
            corner_angle_deg: 60.0,
            corner_cut_m: 0.1,
            yaw_gain: 2.5,
            face_travel_direction: true,
            agent_lookahead_m: 0.5,
            agent_clearance_m: 0.05,
            creep_speed_mps: 0.2,
        }
    }
}

impl FollowerParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (name, v) in [
            ("lookahead_m", self.lookahead_m),
            ("waypoint_tolerance_m", self.waypoint_tolerance_m),
            ("goal_tolerance_m", self.goal_tolerance_m),
            ("yaw_gain", self.yaw_gain),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ParamError::new(name, v, "must be finite and > 0"));
            }
        }
        for (name, v) in [
            ("corner_angle_deg", self.corner_angle_deg),
            ("corner_cut_m", self.corner_cut_m),
            ("agent_lookahead_m", self.agent_lookahead_m),
            ("agent_clearance_m", self.agent_clearance_m),
            ("creep_speed_mps", self.creep_speed_mps),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError::new(name, v, "must be finite and ≥ 0"));
            }
        }
        Ok(())
    }
}

/// Margin below which an agent beside the robot's path counts as in the way whatever the
/// clearance setting, metres (the physics engine reports contacts a little before touching).
const CONTACT_SKIN_M: f64 = 0.02;

/// A circle bounding an agent, for the "is the way blocked" test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Obstruction {
    pub(crate) center: Point2,
    pub(crate) radius: f64,
}

/// What the follower wants this tick.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Desire {
    /// Desired world-frame velocity, m/s.
    pub(crate) vel: (f64, f64),
    /// Desired heading, if any.
    pub(crate) yaw: Option<f64>,
    /// Whether an agent blocks the way.
    pub(crate) blocked: bool,
}

/// Route progress.
#[derive(Clone, Debug, Default)]
pub(crate) struct Follower {
    pub(crate) route: Vec<Point2>,
    /// Index of the waypoint being driven to; `route.len()` when done.
    pub(crate) target: usize,
    pub(crate) stopped: bool,
}

impl Follower {
    pub(crate) fn set_route(&mut self, route: Vec<Point2>) {
        self.route = route;
        self.target = 0;
    }

    pub(crate) fn done(&self) -> bool {
        self.target >= self.route.len()
    }

    /// The cosine of the turn at waypoint `k` (1 where there is none: the start, a repeated
    /// point; −1 at the goal, a stop).
    fn turn_cos(&self, k: usize) -> f64 {
        if k + 1 >= self.route.len() {
            return -1.0;
        }
        if k == 0 {
            return 1.0;
        }
        let (a, b, c) = (self.route[k - 1], self.route[k], self.route[k + 1]);
        let (u, v) = ((b.x - a.x, b.y - a.y), (c.x - b.x, c.y - b.y));
        let (nu, nv) = (u.0.hypot(u.1), v.0.hypot(v.1));
        if nu == 0.0 || nv == 0.0 {
            return 1.0;
        }
        ((u.0 * v.0 + u.1 * v.1) / (nu * nv)).clamp(-1.0, 1.0)
    }

    fn is_corner(&self, k: usize, corner_cos: f64) -> bool {
        self.turn_cos(k) < corner_cos
    }

    /// Whether the robot has gone past the waypoint it drives to without coming within the
    /// tolerance (it cut a gentle corner, or a leg was shorter than the look-ahead; never at a
    /// sharp corner, which is a stop): ahead of the
    /// waypoint along both the leg into it and the leg out of it, and within the look-ahead of
    /// the leg out. Without this the look-ahead, pinned to the missed waypoint, can hold the
    /// robot swinging about it for ever.
    fn passed(&self, pos: Point2, f: &FollowerParams) -> bool {
        let k = self.target;
        if k == 0 || k + 1 >= self.route.len() {
            return false;
        }
        // A sharp corner is a stop: the robot comes to rest on it before turning.
        if self.is_corner(k, f.corner_angle_deg.to_radians().cos()) {
            return false;
        }
        let (a, b, c) = (self.route[k - 1], self.route[k], self.route[k + 1]);
        let ahead_of =
            |from: Point2, to: Point2| (pos.x - b.x) * (to.x - from.x) + (pos.y - b.y) * (to.y - from.y) > 0.0;
        ahead_of(a, b) && ahead_of(b, c) && pos.distance(project(pos, b, c)) <= f.lookahead_m
    }

    /// The look-ahead point on the route, the path distance to the next stop (a sharp corner
    /// or the goal), from `pos`, and the highest speed from which every gentle corner before
    /// that stop can still be slowed for (braking at `accel`).
    fn lookahead(&self, pos: Point2, f: &FollowerParams, accel: f64) -> (Point2, f64, f64) {
        let corner_cos = f.corner_angle_deg.to_radians().cos();
        // Look-ahead point and path distance to the next stop (sharp corner or goal).
        let start =
            if self.target == 0 { pos } else { project(pos, self.route[self.target - 1], self.route[self.target]) };
        let mut from = start;
        let mut along = 0.0;
        let mut look = None;
        let mut cap = f64::INFINITY;
        let mut k = self.target;
        loop {
            let to = self.route[k];
            let seg = from.distance(to);
            if look.is_none() && along + seg >= f.lookahead_m {
                let t = if seg > 0.0 { (f.lookahead_m - along) / seg } else { 0.0 };
                look = Some(Point2::new(from.x + t * (to.x - from.x), from.y + t * (to.y - from.y)));
            }
            along += seg;
            if f.corner_cut_m > 0.0 && !self.is_corner(k, corner_cos) {
                // Turning the velocity v through θ at acceleration a, along the straight line
                // in velocity space, cuts the corner by v² sin²(θ/2) / 2a.
                let half_sin = ((1.0 - self.turn_cos(k)) / 2.0).sqrt();
                if half_sin > 1e-6 {
                    let v_corner = (2.0 * accel * f.corner_cut_m).sqrt() / half_sin;
                    let d = pos.distance(start) + along;
                    cap = cap.min((v_corner * v_corner + 2.0 * accel * d).sqrt());
                }
            }
            if self.is_corner(k, corner_cos) || (along > 20.0 && look.is_some()) {
                if look.is_none() {
                    look = Some(to);
                }
                break;
            }
            from = to;
            k += 1;
        }
        let stop_dist = pos.distance(start) + along;
        let look = look.unwrap_or(self.route[self.target]);
        (look, stop_dist, cap)
    }

    /// The desired motion from `pose`, given the robot's parameters and the agents nearby.
    ///
    /// The way is blocked when an agent is in the corridor ahead along the route, or along the
    /// robot's current velocity (they differ while it cuts a corner), within the braking
    /// distance plus `agent_lookahead_m`; an agent only in the `agent_clearance_m` band of that
    /// corridor slows the robot to `creep_speed_mps`. An agent closer than the robot's bounding
    /// circle plus its own radius and `agent_clearance_m` stops the robot from turning (its
    /// corners sweep that circle).
    pub(crate) fn desire(&mut self, pose: &Pose2, vel: (f64, f64), p: &RobotParams, agents: &[Obstruction]) -> Desire {
        let speed = vel.0.hypot(vel.1);
        let f = &p.follower;
        let pos = pose.position();
        // Advance past reached waypoints.
        while !self.done() {
            let last = self.target + 1 == self.route.len();
            let tol = if last { f.goal_tolerance_m } else { f.waypoint_tolerance_m };
            // A stop (a sharp corner) counts as reached only once the robot is on its braking
            // curve there: arriving faster (after a short leg, or a corner cut), it would swing
            // wide when it turns.
            let slow_enough = last
                || !self.is_corner(self.target, f.corner_angle_deg.to_radians().cos())
                || speed <= 1.1 * (2.0 * 0.8 * p.max_accel_mps2 * tol).sqrt();
            if (pos.distance(self.route[self.target]) <= tol && slow_enough) || (!last && self.passed(pos, f)) {
                self.target += 1;
            } else {
                break;
            }
        }
        if self.done() || self.stopped {
            return Desire::default();
        }
        let a = 0.8 * p.max_accel_mps2;
        let (look, stop_dist, corner_cap) = self.lookahead(pos, f, a);
        let (dx, dy) = (look.x - pos.x, look.y - pos.y);
        let dist = dx.hypot(dy);
        if dist < 1e-9 {
            return Desire::default();
        }
        let dir = (dx / dist, dy / dist);
        let mut v =
            p.max_speed_mps.min((2.0 * a * stop_dist).sqrt()).min(corner_cap).max(0.05_f64.min(p.max_speed_mps));
        let travel_yaw = dir.1.atan2(dir.0);
        // Agents in the corridor ahead.
        let braking = speed * speed / (2.0 * p.max_accel_mps2) + f.agent_lookahead_m;
        // Agents in a corridor along `d`, with a lateral clearance of `margin`.
        let in_corridor_with = |d: (f64, f64), margin: f64| {
            let (across, along) = p.half_extents(angle_diff(d.1.atan2(d.0), pose.yaw));
            agents.iter().any(|o| {
                let (rx, ry) = (o.center.x - pos.x, o.center.y - pos.y);
                let t = rx * d.0 + ry * d.1;
                let lateral = (rx * d.1 - ry * d.0).abs();
                t > 0.0 && t < along + braking + o.radius && lateral < across + o.radius + margin
            })
        };
        // Only the clearance band is occupied: creep past instead of waiting for ever for an
        // agent that waits for the robot.
        let mut creep = false;
        let mut in_corridor = |d: (f64, f64)| {
            if in_corridor_with(d, CONTACT_SKIN_M) {
                true
            } else if in_corridor_with(d, f.agent_clearance_m) {
                creep = true;
                false
            } else {
                false
            }
        };
        let bounding = p.length_m.hypot(p.width_m) / 2.0;
        let too_close: Vec<&Obstruction> =
            agents.iter().filter(|o| o.center.distance(pos) < bounding + o.radius + f.agent_clearance_m).collect();
        let mut blocked = in_corridor(dir);
        if speed > 0.05 {
            blocked |= in_corridor((vel.0 / speed, vel.1 / speed));
        }
        if blocked {
            v = 0.0;
        } else if creep {
            v = v.min(f.creep_speed_mps);
        }
        let yaw = match p.drive {
            _ if !too_close.is_empty() => None,
            DriveKind::Omni if !f.face_travel_direction => None,
            _ => Some(travel_yaw),
        };
        if p.drive == DriveKind::SkidSteer {
            let err = angle_diff(travel_yaw, pose.yaw);
            v *= if err.abs() > std::f64::consts::FRAC_PI_4 { 0.0 } else { err.cos() };
            let (s, c) = pose.yaw.sin_cos();
            return Desire { vel: (v * c, v * s), yaw, blocked };
        }
        Desire { vel: (v * dir.0, v * dir.1), yaw, blocked }
    }
}

/// The projection of `p` on the segment `a`–`b`.
fn project(p: Point2, a: Point2, b: Point2) -> Point2 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let len2 = dx * dx + dy * dy;
    if len2 == 0.0 {
        return b;
    }
    let t = (((p.x - a.x) * dx + (p.y - a.y) * dy) / len2).clamp(0.0, 1.0);
    Point2::new(a.x + t * dx, a.y + t * dy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn follower_heads_for_lookahead_and_slows_at_goal() {
        let p = RobotParams::default();
        let mut f = Follower::default();
        f.set_route(vec![Point2::new(0.0, 0.0), Point2::new(10.0, 0.0)]);
        let d = f.desire(&Pose2::new(0.0, 0.5, 0.0), (0.0, 0.0), &p, &[]);
        // Past the first waypoint (0.5 m away > tolerance? no: 0.5 > 0.15, so it drives there first).
        assert!(d.vel.1 < 0.0);
        let d = f.desire(&Pose2::new(0.05, 0.0, 0.0), (1.0, 0.0), &p, &[]);
        assert_eq!(f.target, 1);
        assert!((d.vel.0 - 1.5).abs() < 1e-9 && d.vel.1.abs() < 1e-9);
        // Near the goal the speed follows √(2·a·d).
        let d = f.desire(&Pose2::new(9.9, 0.0, 0.0), (0.3, 0.0), &p, &[]);
        assert!((d.vel.0 - (2.0 * 0.48 * 0.1f64).sqrt()).abs() < 1e-9);
        f.desire(&Pose2::new(9.99, 0.0, 0.0), (0.0, 0.0), &p, &[]);
        assert!(f.done());
    }

    #[test]
    fn a_missed_waypoint_is_passed_not_circled() {
        let p = RobotParams::default();
        let mut f = Follower::default();
        // A 0.3 m jog: the robot, cutting it, goes by (3, 0.3) 0.2 m off.
        f.set_route(vec![Point2::new(0.0, 0.0), Point2::new(3.0, 0.0), Point2::new(3.0, 0.3), Point2::new(3.0, 5.0)]);
        f.target = 2;
        // Before the waypoint along the leg into it: still its target.
        f.desire(&Pose2::new(3.2, 0.1, 0.0), (0.5, 0.0), &p, &[]);
        assert_eq!(f.target, 2);
        // Past it along both legs, 0.2 m from it and from the leg out: the next one.
        let d = f.desire(&Pose2::new(3.2, 0.5, 0.0), (0.5, 0.0), &p, &[]);
        assert_eq!(f.target, 3);
        assert!(d.vel.1 > 0.0, "heads on along the leg out: {:?}", d.vel);
        // A sharp corner (90° here) is a stop, never passed: the robot is brought back to it.
        let mut g = Follower::default();
        g.set_route(vec![Point2::new(0.0, 0.0), Point2::new(0.0, 2.0), Point2::new(3.0, 2.0)]);
        g.target = 1;
        g.desire(&Pose2::new(0.5, 2.2, 0.0), (0.0, 1.0), &p, &[]);
        assert_eq!(g.target, 1);
        // Far off the leg out (beyond the look-ahead): not counted as passed.
        f.target = 2;
        f.desire(&Pose2::new(4.0, 0.5, 0.0), (0.5, 0.0), &p, &[]);
        assert_eq!(f.target, 2);
    }

    #[test]
    fn the_robot_slows_for_gentle_corners_and_stops_at_sharp_ones() {
        let p = RobotParams::default();
        let a = 0.8 * p.max_accel_mps2;
        // A 40° turn 1 m ahead: v ≤ √(v_c² + 2·a·d), v_c = √(2·a·cut) / sin(20°).
        let mut f = Follower::default();
        let turn = 40f64.to_radians();
        f.set_route(vec![
            Point2::new(0.0, 0.0),
            Point2::new(10.0, 0.0),
            Point2::new(10.0 + 5.0 * turn.cos(), 5.0 * turn.sin()),
        ]);
        f.target = 1;
        let d = f.desire(&Pose2::new(9.0, 0.0, 0.0), (1.5, 0.0), &p, &[]);
        let v_c = (2.0 * a * p.follower.corner_cut_m).sqrt() / (turn / 2.0).sin();
        let want = (v_c * v_c + 2.0 * a * 1.0).sqrt();
        assert!((d.vel.0.hypot(d.vel.1) - want).abs() < 1e-9, "{:?} against {want}", d.vel);
        assert!(want < p.max_speed_mps);
        // Switched off, the same corner is taken at full speed.
        let mut q = p.clone();
        q.follower.corner_cut_m = 0.0;
        let d = f.desire(&Pose2::new(9.0, 0.0, 0.0), (1.5, 0.0), &q, &[]);
        assert!((d.vel.0.hypot(d.vel.1) - q.max_speed_mps).abs() < 1e-9);
        // A sharp (90°) corner within the tolerance is reached only at braking-curve speed.
        let mut g = Follower::default();
        g.set_route(vec![Point2::new(0.0, 0.0), Point2::new(5.0, 0.0), Point2::new(5.0, 5.0)]);
        g.target = 1;
        g.desire(&Pose2::new(4.9, 0.0, 0.0), (0.7, 0.0), &p, &[]);
        assert_eq!(g.target, 1, "too fast to turn: still braking for the corner");
        g.desire(&Pose2::new(4.9, 0.0, 0.0), (0.3, 0.0), &p, &[]);
        assert_eq!(g.target, 2);
    }

    #[test]
    fn agent_ahead_blocks_agent_beside_does_not() {
        let p = RobotParams::default();
        let mut f = Follower::default();
        f.set_route(vec![Point2::new(0.0, 0.0), Point2::new(10.0, 0.0)]);
        let ahead = [Obstruction { center: Point2::new(1.0, 0.1), radius: 0.25 }];
        assert!(f.desire(&Pose2::new(0.05, 0.0, 0.0), (0.0, 0.0), &p, &ahead).blocked);
        let beside = [Obstruction { center: Point2::new(1.0, 0.7), radius: 0.25 }];
        assert!(!f.desire(&Pose2::new(0.05, 0.0, 0.0), (0.0, 0.0), &p, &beside).blocked);
        let behind = [Obstruction { center: Point2::new(-0.8, 0.0), radius: 0.25 }];
        assert!(!f.desire(&Pose2::new(0.05, 0.0, 0.0), (0.0, 0.0), &p, &behind).blocked);
    }
}
