//! People and other robots: kinematic bodies on waypoint loops or random walks. An agent pauses
//! while the robot stands in its way and, after waiting `give_way_s`, turns back, so it never
//! walks through the robot and two blocked parties never wait for each other for ever.

use crate::seeds::SimRng;
use crate::world::{Agent, Motion};
use mapkeeper_common::ParamError;
use mapkeeper_grid::{Point2, Pose2};
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// How agents react to the robot.
///
/// ```
/// use mapkeeper_sim::AgentParams;
/// let p = AgentParams { give_way_s: 5.0, ..AgentParams::default() };
/// assert!(p.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AgentParams {
    /// An agent stops when the robot is within this distance ahead of its edge, metres
    /// (default 0.6).
    pub lookahead_m: f64,
    /// Lateral clearance an agent keeps from the robot, metres (default 0.05).
    pub clearance_m: f64,
    /// After waiting this long for the robot, an agent turns back, seconds (default 3).
    pub give_way_s: f64,
}

impl Default for AgentParams {
    fn default() -> Self {
        Self { lookahead_m: 0.6, clearance_m: 0.05, give_way_s: 3.0 }
    }
}

impl AgentParams {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), ParamError> {
        for (name, v) in
            [("lookahead_m", self.lookahead_m), ("clearance_m", self.clearance_m), ("give_way_s", self.give_way_s)]
        {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError::new(name, v, "must be finite and ≥ 0"));
            }
        }
        Ok(())
    }
}

/// One agent's state.
#[derive(Clone)]
pub(crate) struct AgentState {
    pub(crate) radius: f64,
    pub(crate) pose: Pose2,
    waypoints: Vec<Point2>,
    random_walk: bool,
    max_pause_s: f64,
    speed: f64,
    from: usize,
    target: usize,
    step_dir: isize,
    pause_s: f64,
    blocked_s: f64,
    rng: SimRng,
}

impl AgentState {
    pub(crate) fn new(agent: &Agent, run_seed: u64) -> Self {
        let waypoints = agent.motion.waypoints();
        let (random_walk, max_pause_s) = match agent.motion {
            Motion::Loop { max_pause_s, .. } => (false, max_pause_s),
            Motion::RandomWalk { max_pause_s, .. } => (true, max_pause_s),
        };
        let (a, b) = (waypoints[0], waypoints[1]);
        Self {
            radius: agent.footprint.center().distance(Point2::new(0.0, 0.0)) + agent.footprint.bounding_radius(),
            pose: Pose2::new(a.x, a.y, (b.y - a.y).atan2(b.x - a.x)),
            waypoints,
            random_walk,
            max_pause_s,
            speed: agent.speed_mps,
            from: 0,
            target: 1,
            step_dir: 1,
            pause_s: 0.0,
            blocked_s: 0.0,
            rng: SimRng::stream(run_seed, &format!("agent/{}", agent.id)),
        }
    }

    fn next_target(&mut self) -> usize {
        let n = self.waypoints.len();
        if self.random_walk {
            let t = self.target;
            let up = if t == 0 {
                true
            } else if t + 1 == n {
                false
            } else {
                self.rng.random::<bool>()
            };
            if up { t + 1 } else { t - 1 }
        } else {
            (self.target as isize + self.step_dir).rem_euclid(n as isize) as usize
        }
    }

    /// Moves the agent by one step of `dt_s`, unless the robot (a circle) is in the way.
    #[cfg(test)]
    pub(crate) fn advance(&mut self, dt_s: f64, robot: Point2, robot_radius: f64, p: &AgentParams) {
        self.advance_near(
            dt_s,
            &RobotView { position: robot, yaw: 0.0, radius: robot_radius, half_extents: None, corridor: None },
            p,
        );
    }

    /// Moves the agent by one step of `dt_s`, unless the robot (a circle) is in the way or the
    /// step would take the agent into the robot's braking corridor.
    pub(crate) fn advance_near(&mut self, dt_s: f64, robot: &RobotView, p: &AgentParams) {
        let robot_radius = robot.radius;
        if self.pause_s > 0.0 {
            self.pause_s = (self.pause_s - dt_s).max(0.0);
            return;
        }
        let pos = self.pose.position();
        let target = self.waypoints[self.target];
        let (dx, dy) = (target.x - pos.x, target.y - pos.y);
        let dist = dx.hypot(dy);
        if dist > 1e-12 {
            let dir = (dx / dist, dy / dist);
            let (rx, ry) = (robot.position.x - pos.x, robot.position.y - pos.y);
            let t = rx * dir.0 + ry * dir.1;
            let lateral = (rx * dir.1 - ry * dir.0).abs();
            // The robot's footprint measured across and along this agent's way.
            let (r_across, r_along) = match robot.half_extents {
                Some((hl, hw)) => {
                    let (sn, cs) = (dir.1.atan2(dir.0) - robot.yaw).sin_cos();
                    ((hl * sn).abs() + (hw * cs).abs(), (hl * cs).abs() + (hw * sn).abs())
                }
                None => (robot_radius, robot_radius),
            };
            if t > 0.0 && t < r_along + self.radius + p.lookahead_m && lateral < r_across + self.radius + p.clearance_m
            {
                self.blocked_s += dt_s;
                if self.blocked_s >= p.give_way_s {
                    // Turn back.
                    self.blocked_s = 0.0;
                    std::mem::swap(&mut self.from, &mut self.target);
                    self.step_dir = -self.step_dir;
                }
                return;
            }
        }
        let step = self.speed * dt_s;
        if dist > 1e-12
            && let Some(c) = &robot.corridor
        {
            let next = Point2::new(pos.x + step.min(dist) * dx / dist, pos.y + step.min(dist) * dy / dist);
            if c.blocks(pos, next, self.radius + p.clearance_m) {
                self.blocked_s += dt_s;
                if self.blocked_s >= p.give_way_s {
                    self.blocked_s = 0.0;
                    std::mem::swap(&mut self.from, &mut self.target);
                    self.step_dir = -self.step_dir;
                }
                return;
            }
        }
        self.blocked_s = 0.0;
        if step >= dist {
            self.pose = Pose2::new(target.x, target.y, self.pose.yaw);
            self.from = self.target;
            self.target = self.next_target();
            if self.max_pause_s > 0.0 {
                self.pause_s = self.rng.random::<f64>() * self.max_pause_s;
            }
            let next = self.waypoints[self.target];
            self.pose.yaw = (next.y - target.y).atan2(next.x - target.x);
        } else {
            self.pose = Pose2::new(pos.x + step * dx / dist, pos.y + step * dy / dist, dy.atan2(dx));
        }
    }
}

/// What an agent knows of the robot.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RobotView {
    /// The robot's centre.
    pub(crate) position: Point2,
    /// The robot's heading, radians.
    pub(crate) yaw: f64,
    /// Radius of the circle bounding the robot, metres.
    pub(crate) radius: f64,
    /// Half length and half width of the robot's rectangle (`None`: use the circle).
    pub(crate) half_extents: Option<(f64, f64)>,
    /// The stretch of floor the robot needs to brake, when it moves.
    pub(crate) corridor: Option<Corridor>,
}

/// The rectangle ahead of a moving robot that it sweeps before it can stop: from its rear
/// (`-behind_m`) to `ahead_m` along `dir`, `half_width_m` either side of its centre line.
/// People do not step into it (they wait, as they would for a forklift).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Corridor {
    pub(crate) origin: Point2,
    pub(crate) dir: (f64, f64),
    pub(crate) behind_m: f64,
    pub(crate) ahead_m: f64,
    pub(crate) half_width_m: f64,
}

impl Corridor {
    /// (along, |lateral|) of `p`.
    fn coords(&self, p: Point2) -> (f64, f64) {
        let (rx, ry) = (p.x - self.origin.x, p.y - self.origin.y);
        (rx * self.dir.0 + ry * self.dir.1, (rx * self.dir.1 - ry * self.dir.0).abs())
    }

    fn inside(&self, p: Point2, grow: f64) -> (bool, f64) {
        let (t, lat) = self.coords(p);
        (t > -self.behind_m - grow && t < self.ahead_m + grow && lat < self.half_width_m + grow, lat)
    }

    /// Whether a step of a circle of radius `grow` from `from` to `to` enters the corridor or,
    /// inside it, moves towards its centre line.
    pub(crate) fn blocks(&self, from: Point2, to: Point2, grow: f64) -> bool {
        let (was_in, lat0) = self.inside(from, grow);
        let (is_in, lat1) = self.inside(to, grow);
        is_in && (!was_in || lat1 < lat0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shape::Shape;
    use crate::world::AgentKind;

    fn person(motion: Motion) -> Agent {
        Agent {
            id: "p".into(),
            kind: AgentKind::Person,
            footprint: Shape::circle(Point2::new(0.0, 0.0), 0.25),
            speed_mps: 1.0,
            motion,
        }
    }

    #[test]
    fn loop_walks_at_speed_and_wraps() {
        let a = person(Motion::Loop { waypoints: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], max_pause_s: 0.0 });
        let mut s = AgentState::new(&a, 1);
        let far = Point2::new(100.0, 100.0);
        let p = AgentParams::default();
        for _ in 0..50 {
            s.advance(0.02, far, 0.5, &p);
        }
        assert!((s.pose.x - 1.0).abs() < 1e-9 && s.pose.y.abs() < 1e-9);
        for _ in 0..(50 + 71) {
            s.advance(0.02, far, 0.5, &p);
        }
        // 1 m up, then √2 m back to the first waypoint.
        assert!(s.pose.position().distance(Point2::new(0.0, 0.0)) < 0.02);
    }

    #[test]
    fn waits_for_the_robot_then_turns_back() {
        // A person walks +x from (0, 0) towards (5, 0) at 1 m/s; a robot (radius 0.5) stands at
        // (3, 0). The person stops once the robot is within its radius + the person's radius +
        // the look-ahead in front of them, waits `give_way_s`, then walks back towards (0, 0).
        let a = person(Motion::Loop { waypoints: vec![[0.0, 0.0], [5.0, 0.0]], max_pause_s: 0.0 });
        let mut s = AgentState::new(&a, 1);
        let p = AgentParams::default();
        let (robot, robot_radius, dt) = (Point2::new(3.0, 0.0), 0.5, 0.02);
        let stop_x = robot.x - (robot_radius + 0.25 + p.lookahead_m);
        // Walks towards the robot until it stops.
        let mut moving_steps = 0;
        loop {
            let before = s.pose.x;
            s.advance(dt, robot, robot_radius, &p);
            if s.pose.x == before {
                break;
            }
            assert!(s.pose.x > before, "walks towards (5, 0): {before} -> {}", s.pose.x);
            moving_steps += 1;
            assert!(moving_steps < 500, "never stopped for the robot: {:?}", s.pose);
        }
        let x_stop = s.pose.x;
        assert!((x_stop - stop_x).abs() <= 0.02 + 1e-9, "stopped at x = {x_stop}, expected ≈ {stop_x}");
        assert!((s.pose.yaw).abs() < 1e-9, "facing the robot while waiting: {:?}", s.pose);
        // Waits: one step was spent blocked already; count the rest until it moves again.
        let mut waiting_steps = 1;
        while s.pose.x == x_stop {
            s.advance(dt, robot, robot_radius, &p);
            waiting_steps += 1;
            assert!(waiting_steps < 1_000, "waits for ever: {:?}", s.pose);
        }
        // The step that moved it is not waiting.
        let waited_s = f64::from(waiting_steps - 1) * dt;
        assert!((waited_s - p.give_way_s).abs() <= 2.0 * dt, "waited {waited_s} s, give_way_s = {}", p.give_way_s);
        // Turned back: it now walks away from the robot, towards (0, 0), at its speed.
        assert!(s.pose.x < x_stop, "moved towards the robot after waiting: {:?}", s.pose);
        assert!((s.pose.yaw.abs() - std::f64::consts::PI).abs() < 1e-9, "heading back along -x: {:?}", s.pose);
        for _ in 0..24 {
            let before = s.pose.x;
            s.advance(dt, robot, robot_radius, &p);
            assert!(s.pose.x < before, "keeps walking back: {before} -> {}", s.pose.x);
        }
        // 25 steps of 0.02 s at 1 m/s: 0.5 m back from where it waited.
        assert!((s.pose.x - (x_stop - 0.5)).abs() < 1e-9, "{:?}", s.pose);
        assert_eq!(s.pose.y, 0.0);
    }

    #[test]
    fn people_do_not_step_into_a_moving_robots_braking_corridor() {
        // Robot at the origin driving +x; corridor 2 m ahead, 0.34 m either side.
        let c = Corridor {
            origin: Point2::new(0.0, 0.0),
            dir: (1.0, 0.0),
            behind_m: 0.4,
            ahead_m: 2.0,
            half_width_m: 0.34,
        };
        // Stepping in from the side: refused.
        assert!(c.blocks(Point2::new(1.0, 0.62), Point2::new(1.0, 0.58), 0.25));
        // Walking along beside it, or away from it: fine.
        assert!(!c.blocks(Point2::new(1.0, 0.7), Point2::new(1.1, 0.7), 0.25));
        assert!(!c.blocks(Point2::new(1.0, 0.3), Point2::new(1.0, 0.35), 0.25));
        // Beyond the corridor's end: fine.
        assert!(!c.blocks(Point2::new(2.5, 0.5), Point2::new(2.5, 0.0), 0.2));
        // An agent in a robot's corridor is kept from walking, then turns back.
        let a = person(Motion::Loop { waypoints: vec![[1.0, 1.0], [1.0, -1.0]], max_pause_s: 0.0 });
        let mut s = AgentState::new(&a, 1);
        let view = RobotView {
            position: Point2::new(0.0, 0.0),
            yaw: 0.0,
            radius: 0.5,
            half_extents: Some((0.375, 0.34)),
            corridor: Some(c),
        };
        let p = AgentParams::default();
        for _ in 0..25 {
            s.advance_near(0.02, &view, &p);
        }
        assert!(s.pose.y >= 0.59 + 0.05, "stopped at the corridor's edge: {:?}", s.pose);
    }
}
