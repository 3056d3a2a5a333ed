//! The simulator: a rapier world with the robot, the static and movable geometry and the
//! agents, stepped on an integer tick clock; lidars, odometry and the true pose are its outputs.

use crate::agents::{AgentParams, AgentState, Corridor, RobotView};
use crate::error::{SimError, params_err};
use crate::lidar::{LidarParams, LidarSim, Scene};
use crate::odometry::{Odometry, OdometryParams};
use crate::raycast::StaticCaster;
use crate::realism::{PoseHistory, SensorRealism};
use crate::robot::{DriveKind, Follower, Obstruction, RobotParams};
use crate::shape::Shape;
use crate::world::{AgentKind, ObstacleRef, World};
use mapkeeper_common::ParamError;
use mapkeeper_grid::{Point2, Pose2, angle_diff};
use mapkeeper_sensor::{LaserScan, OdometryReading, TruePose};
use rapier2d::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex};

/// Everything configurable about a run except the world and the seed.
///
/// ```
/// use mapkeeper_sim::{LidarParams, SimParams};
/// let mut p = SimParams::default();
/// p.lidars = vec![LidarParams::hokuyo_ust20lx(mapkeeper_grid::Pose2::new(0.3, 0.0, 0.0))];
/// assert!(p.validate().is_ok());
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimParams {
    /// Physics step, nanoseconds (default 20,000,000: 50 Hz).
    pub tick_ns: u64,
    /// The robot.
    pub robot: RobotParams,
    /// The lidars, in `lidar_id` order (default: front and rear SICK S300).
    pub lidars: Vec<LidarParams>,
    /// Wheel odometry noise.
    pub odometry: OdometryParams,
    /// Agent behaviour.
    pub agents: AgentParams,
    /// Sensor realism (mixed pixels, motion distortion, latency, …). Default: every effect
    /// off, the `ideal` profile (not written then).
    #[serde(default, skip_serializing_if = "SensorRealism::is_ideal")]
    pub realism: SensorRealism,
}

impl Default for SimParams {
    fn default() -> Self {
        Self {
            tick_ns: 20_000_000,
            robot: RobotParams::default(),
            lidars: LidarParams::summit_xl_pair(),
            odometry: OdometryParams::default(),
            agents: AgentParams::default(),
            realism: SensorRealism::default(),
        }
    }
}

impl SimParams {
    /// Checks every component.
    pub fn validate(&self) -> Result<(), SimError> {
        if !(1_000_000..=1_000_000_000).contains(&self.tick_ns) {
            return Err(params_err("SimParams", ParamError::new("tick_ns", self.tick_ns, "must be in 1 ms..1 s")));
        }
        self.robot.validate().map_err(|e| params_err("RobotParams", e))?;
        for (i, l) in self.lidars.iter().enumerate() {
            l.validate().map_err(|e| params_err(format!("lidars[{i}]"), e))?;
        }
        self.odometry.validate().map_err(|e| params_err("OdometryParams", e))?;
        self.realism.validate().map_err(|e| params_err("realism", e))?;
        self.agents.validate().map_err(|e| params_err("AgentParams", e))
    }
}

/// The robot touched something.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CollisionEvent {
    /// Tick of the physics step in which it happened.
    pub tick: u64,
    /// Time, nanoseconds.
    pub stamp_ns: u64,
    /// What the robot touched.
    pub other: ObstacleRef,
    /// True when contact began, false when it ended.
    pub started: bool,
}

/// What one step produced.
#[derive(Clone, Debug, PartialEq)]
pub struct StepOutput {
    /// The tick reached by this step (1 after the first step).
    pub tick: u64,
    /// `tick × tick_ns`.
    pub stamp_ns: u64,
    /// Scans of the lidars that fired at this tick, in lidar order.
    pub scans: Vec<LaserScan>,
    /// Wheel odometry at this tick.
    pub odometry: OdometryReading,
    /// The true pose at this tick.
    pub truth: TruePose,
    /// Contacts of the robot that began or ended during this step.
    pub collisions: Vec<CollisionEvent>,
    /// Whether the route's last waypoint has been reached (true also with no route).
    pub route_done: bool,
    /// Whether the robot is waiting for an agent in its way.
    pub blocked: bool,
}

#[derive(Default)]
struct Collector(Mutex<Vec<(ColliderHandle, ColliderHandle, bool)>>);

impl EventHandler for Collector {
    fn handle_collision_event(
        &self,
        _: &RigidBodySet,
        _: &ColliderSet,
        event: rapier2d::prelude::CollisionEvent,
        _: Option<&ContactPair>,
    ) {
        if let Ok(mut v) = self.0.lock() {
            v.push((event.collider1(), event.collider2(), event.started()));
        }
    }
    fn handle_contact_force_event(&self, _: Real, _: &RigidBodySet, _: &ColliderSet, _: &ContactPair, _: Real) {}
    fn handle_soft_body_tear_event(&self, _: &SoftBodySet, _: &SoftBodyTearEvent) {}
}

/// A running simulation.
pub struct Simulator {
    /// W_i, never changed by a run (shared by the copies).
    world: Arc<World>,
    params: SimParams,
    seed: u64,
    tick: u64,
    physics: PhysicsWorld,
    events: Collector,
    robot_body: RigidBodyHandle,
    robot_collider: ColliderHandle,
    robot_radius: f64,
    refs: Vec<ObstacleRef>,
    agents: Vec<(AgentState, RigidBodyHandle)>,
    lidars: Vec<LidarSim>,
    odometry: Odometry,
    follower: Follower,
    cmd_vel: (f64, f64),
    cmd_fwd: f64,
    cmd_omega: f64,
    prev_true: Pose2,
    blocked: bool,
    /// The static obstacles binned for the lidars, never changed (shared by the copies).
    statics: Arc<StaticCaster>,
    agent_shapes: Vec<(Shape, Point2, f64)>,
    scratch: Vec<Option<f64>>,
    /// The robot's recent true poses (motion distortion and latency only).
    history: Option<PoseHistory>,
    /// Distance each agent has walked, metres (the gait of people's legs).
    walked: Vec<f64>,
}

/// A copy of a running simulation: the same state, so that stepping the copy gives bit for bit
/// what stepping the original would (a pipelined run keeps copies to rewind to; test
/// `a_cloned_simulator_steps_as_the_original`). The physics pipelines are rapier's workspace
/// buffers only, so the copy gets fresh ones; pending collision events are drained every step,
/// so it starts with none.
impl Clone for Simulator {
    fn clone(&self) -> Self {
        let p = &self.physics;
        let physics = PhysicsWorld {
            gravity: p.gravity,
            integration_parameters: p.integration_parameters,
            islands: p.islands.clone(),
            broad_phase: p.broad_phase.clone(),
            narrow_phase: p.narrow_phase.clone(),
            bodies: p.bodies.clone(),
            colliders: p.colliders.clone(),
            impulse_joints: p.impulse_joints.clone(),
            multibody_joints: p.multibody_joints.clone(),
            soft_bodies: p.soft_bodies.clone(),
            ccd_solver: p.ccd_solver.clone(),
            ..PhysicsWorld::default()
        };
        let events = Collector(Mutex::new(self.events.0.lock().map(|v| v.clone()).unwrap_or_default()));
        Self {
            world: self.world.clone(),
            params: self.params.clone(),
            seed: self.seed,
            tick: self.tick,
            physics,
            events,
            robot_body: self.robot_body,
            robot_collider: self.robot_collider,
            robot_radius: self.robot_radius,
            refs: self.refs.clone(),
            agents: self.agents.clone(),
            lidars: self.lidars.clone(),
            odometry: self.odometry.clone(),
            follower: self.follower.clone(),
            cmd_vel: self.cmd_vel,
            cmd_fwd: self.cmd_fwd,
            cmd_omega: self.cmd_omega,
            prev_true: self.prev_true,
            blocked: self.blocked,
            statics: self.statics.clone(),
            agent_shapes: self.agent_shapes.clone(),
            scratch: self.scratch.clone(),
            history: self.history.clone(),
            walked: self.walked.clone(),
        }
    }
}

fn rapier_pose(p: &Pose2) -> Pose {
    Pose::new(Vector::new(p.x as f32, p.y as f32), p.yaw as f32)
}

/// A rapier collider for a shape in its parent's frame.
fn collider_for(shape: &Shape) -> Result<ColliderBuilder, SimError> {
    Ok(match shape {
        Shape::Rect { center, size, yaw_deg } => ColliderBuilder::cuboid(
            (size[0] / 2.0) as f32,
            (size[1] / 2.0) as f32,
        )
        .position(rapier_pose(&Pose2::new(center[0], center[1], yaw_deg.to_radians()))),
        Shape::Circle { center, radius } => {
            ColliderBuilder::ball(*radius as f32).translation(Vector::new(center[0] as f32, center[1] as f32))
        }
        Shape::Polygon { points } => {
            let v: Vec<Vector> = points.iter().map(|p| Vector::new(p[0] as f32, p[1] as f32)).collect();
            let convex = is_convex(points);
            match convex.then(|| ColliderBuilder::convex_polyline(v.clone())).flatten() {
                Some(b) => b,
                None => {
                    let n = v.len() as u32;
                    ColliderBuilder::polyline(v, Some((0..n).map(|i| [i, (i + 1) % n]).collect()))
                }
            }
        }
    })
}

fn is_convex(points: &[[f64; 2]]) -> bool {
    let n = points.len();
    let mut sign = 0.0;
    for i in 0..n {
        let (a, b, c) = (points[i], points[(i + 1) % n], points[(i + 2) % n]);
        let cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
        if cross != 0.0 {
            if sign != 0.0 && cross.signum() != sign {
                return false;
            }
            sign = cross.signum();
        }
    }
    true
}

impl Simulator {
    /// Builds the simulation of `world` (validated again here) with `params`; every random
    /// stream derives from `seed`.
    pub fn new(world: &World, params: SimParams, seed: u64) -> Result<Self, SimError> {
        world.validate(&world.name)?;
        params.validate()?;
        let mut physics = PhysicsWorld { gravity: Vector::ZERO, ..PhysicsWorld::default() };
        physics.integration_parameters.dt = params.tick_ns as f32 / 1e9;
        let mut refs = Vec::new();
        let obstacles = world.obstacles();
        let statics = StaticCaster::new(&obstacles.iter().map(|(_, s)| s.clone()).collect::<Vec<_>>(), 0.5);
        for (r, shape) in obstacles {
            let b = collider_for(&shape)?.user_data(refs.len() as u128).friction(0.0);
            refs.push(r);
            physics.colliders.insert(b);
        }
        let start = world.robot_start.pose();
        let rp = &params.robot;
        let robot_body = physics.bodies.insert(RigidBodyBuilder::dynamic().pose(rapier_pose(&start)).can_sleep(false));
        let robot_collider = physics.colliders.insert_with_parent(
            ColliderBuilder::cuboid((rp.length_m / 2.0) as f32, (rp.width_m / 2.0) as f32)
                .mass(rp.mass_kg as f32)
                .friction(0.0)
                .restitution(0.0)
                .user_data(u128::MAX)
                .active_events(ActiveEvents::COLLISION_EVENTS),
            robot_body,
            &mut physics.bodies,
        );
        let mut agents = Vec::new();
        for a in &world.agents {
            let state = AgentState::new(a, seed);
            let body = physics
                .bodies
                .insert(RigidBodyBuilder::kinematic_position_based().pose(rapier_pose(&state.pose)).can_sleep(false));
            let b = collider_for(&a.footprint)?.user_data(refs.len() as u128).friction(0.0);
            refs.push(ObstacleRef::Agent(a.id.clone()));
            physics.colliders.insert_with_parent(b, body, &mut physics.bodies);
            agents.push((state, body));
        }
        let lidars = params
            .lidars
            .iter()
            .enumerate()
            .map(|(i, l)| LidarSim::new(i, l, seed, params.tick_ns, &params.realism))
            .collect::<Result<Vec<_>, _>>()?;
        let history = params.realism.needs_history().then(|| {
            let keep = lidars.iter().map(LidarSim::lookback_ns).max().unwrap_or(0) + 2 * params.tick_ns;
            let mut h = PoseHistory::new(keep);
            h.push(0, start);
            h
        });
        let events = Collector::default();
        // Make the colliders visible to scene queries before the first step.
        physics.detect_collisions(&(), &events);
        if let Ok(mut v) = events.0.lock() {
            v.clear();
        }
        Ok(Self {
            world: Arc::new(world.clone()),
            odometry: Odometry::new(&params.odometry, seed),
            robot_radius: rp.length_m.hypot(rp.width_m) / 2.0,
            params,
            seed,
            tick: 0,
            physics,
            events,
            robot_body,
            robot_collider,
            refs,
            agents,
            lidars,
            follower: Follower::default(),
            cmd_vel: (0.0, 0.0),
            cmd_fwd: 0.0,
            cmd_omega: 0.0,
            prev_true: start,
            blocked: false,
            statics: Arc::new(statics),
            agent_shapes: Vec::new(),
            scratch: Vec::new(),
            history,
            walked: vec![0.0; world.agents.len()],
        })
    }

    /// The world being simulated.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The parameters of the run.
    pub fn params(&self) -> &SimParams {
        &self.params
    }

    /// The run seed.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The current tick (0 before the first step).
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// The current time, nanoseconds.
    pub fn stamp_ns(&self) -> u64 {
        self.tick * self.params.tick_ns
    }

    /// Drive this route from where the robot is (replaces any previous route).
    pub fn set_route(&mut self, waypoints: Vec<Point2>) {
        self.follower.set_route(waypoints);
    }

    /// Stop: the robot brakes at its limits and waits until [`Simulator::resume`].
    pub fn stop(&mut self) {
        self.follower.stopped = true;
    }

    /// Halt: an emergency stop. The robot stands still from the next tick on (commanded and
    /// body velocities zeroed at once, not braked) and waits until [`Simulator::resume`]; only
    /// contact with something moving can still push it.
    pub fn halt(&mut self) {
        self.follower.stopped = true;
        if let Some(b) = self.physics.bodies.get_mut(self.robot_body) {
            b.set_linvel(Vector::ZERO, true);
            b.set_angvel(0.0, true);
        }
        self.cmd_vel = (0.0, 0.0);
        self.cmd_fwd = 0.0;
        self.cmd_omega = 0.0;
    }

    /// Resume the route after [`Simulator::stop`] or [`Simulator::halt`].
    pub fn resume(&mut self) {
        self.follower.stopped = false;
    }

    /// Whether the robot is stopped by [`Simulator::stop`].
    pub fn is_stopped(&self) -> bool {
        self.follower.stopped
    }

    /// The robot's true pose now.
    pub fn true_pose(&self) -> Pose2 {
        let p = self.physics.bodies[self.robot_body].position();
        Pose2::new(f64::from(p.translation.x), f64::from(p.translation.y), f64::from(p.rotation.angle()))
    }

    /// The agents' true poses now, in world order, with their ids.
    pub fn agent_poses(&self) -> Vec<(&str, Pose2)> {
        self.world.agents.iter().zip(&self.agents).map(|(a, (s, _))| (a.id.as_str(), s.pose)).collect()
    }

    /// Moves the robot instantly (a kidnapping), at rest. Odometry does not see the jump.
    pub fn teleport_robot(&mut self, pose: Pose2) {
        if let Some(b) = self.physics.bodies.get_mut(self.robot_body) {
            b.set_position(rapier_pose(&pose), true);
            b.set_linvel(Vector::ZERO, true);
            b.set_angvel(0.0, true);
        }
        self.cmd_vel = (0.0, 0.0);
        self.cmd_fwd = 0.0;
        self.cmd_omega = 0.0;
        self.prev_true = self.true_pose();
        let (stamp, now) = (self.stamp_ns(), self.prev_true);
        if let Some(h) = &mut self.history {
            *h = PoseHistory::new(h.keep_ns());
            h.push(stamp, now);
        }
        // Refresh the broad phase so that queries see the robot where it now is.
        self.physics.detect_collisions(&(), &self.events);
    }

    /// Velocity command for this tick from the follower, within the robot's limits.
    fn command(&mut self, pose: &Pose2, dt: f64) {
        let rp = &self.params.robot;
        let obstructions: Vec<Obstruction> =
            self.agents.iter().map(|(s, _)| Obstruction { center: s.pose.position(), radius: s.radius }).collect();
        let desire = self.follower.desire(pose, self.cmd_vel, rp, &obstructions);
        self.blocked = desire.blocked;
        let dv_max = rp.max_accel_mps2 * dt;
        match rp.drive {
            DriveKind::Omni => {
                let (mut dx, mut dy) = (desire.vel.0 - self.cmd_vel.0, desire.vel.1 - self.cmd_vel.1);
                let n = dx.hypot(dy);
                if n > dv_max {
                    dx *= dv_max / n;
                    dy *= dv_max / n;
                }
                let (vx, vy) = (self.cmd_vel.0 + dx, self.cmd_vel.1 + dy);
                let s = vx.hypot(vy);
                let k = if s > rp.max_speed_mps { rp.max_speed_mps / s } else { 1.0 };
                self.cmd_vel = (vx * k, vy * k);
            }
            DriveKind::SkidSteer => {
                let (s, c) = pose.yaw.sin_cos();
                let want = (desire.vel.0 * c + desire.vel.1 * s).clamp(-rp.max_speed_mps, rp.max_speed_mps);
                self.cmd_fwd += (want - self.cmd_fwd).clamp(-dv_max, dv_max);
                self.cmd_vel = (self.cmd_fwd * c, self.cmd_fwd * s);
            }
        }
        let want_omega = match desire.yaw {
            // Also while waiting for an agent: facing the way narrows the robot's footprint.
            Some(y)
                if desire.vel.0.hypot(desire.vel.1) > 1e-6 || desire.blocked || rp.drive == DriveKind::SkidSteer =>
            {
                let err = angle_diff(y, pose.yaw);
                let braking = (2.0 * rp.max_yaw_accel_radps2 * err.abs()).sqrt();
                (rp.follower.yaw_gain * err)
                    .clamp(-braking, braking)
                    .clamp(-rp.max_yaw_rate_radps, rp.max_yaw_rate_radps)
            }
            _ => 0.0,
        };
        let dw_max = rp.max_yaw_accel_radps2 * dt;
        self.cmd_omega += (want_omega - self.cmd_omega).clamp(-dw_max, dw_max);
    }

    /// What the agents know of the robot: its bounding circle and, when it moves, the corridor
    /// it sweeps before it can stop (its footprint across the direction of travel, its braking
    /// distance plus `agent_lookahead_m` ahead).
    fn robot_view(&self, pose: &Pose2) -> RobotView {
        let rp = &self.params.robot;
        let speed = self.cmd_vel.0.hypot(self.cmd_vel.1);
        let corridor = (speed > 0.05).then(|| {
            let dir = (self.cmd_vel.0 / speed, self.cmd_vel.1 / speed);
            let (across, along) = rp.half_extents(angle_diff(dir.1.atan2(dir.0), pose.yaw));
            Corridor {
                origin: pose.position(),
                dir,
                behind_m: along,
                ahead_m: along + speed * speed / (2.0 * rp.max_accel_mps2) + rp.follower.agent_lookahead_m,
                half_width_m: across,
            }
        });
        RobotView {
            position: pose.position(),
            yaw: pose.yaw,
            radius: self.robot_radius,
            half_extents: Some((rp.length_m / 2.0, rp.width_m / 2.0)),
            corridor,
        }
    }

    /// Advances one physics tick and returns what the robot's sensors produced.
    pub fn step(&mut self) -> StepOutput {
        let dt = self.params.tick_ns as f64 / 1e9;
        let pose = self.true_pose();
        self.command(&pose, dt);
        if let Some(b) = self.physics.bodies.get_mut(self.robot_body) {
            b.set_linvel(Vector::new(self.cmd_vel.0 as f32, self.cmd_vel.1 as f32), true);
            b.set_angvel(self.cmd_omega as f32, true);
        }
        let view = self.robot_view(&pose);
        for ((state, body), walked) in self.agents.iter_mut().zip(&mut self.walked) {
            let before = state.pose.position();
            state.advance_near(dt, &view, &self.params.agents);
            *walked += before.distance(state.pose.position());
            if let Some(b) = self.physics.bodies.get_mut(*body) {
                b.set_next_kinematic_position(rapier_pose(&state.pose));
            }
        }
        self.physics.step_with_events(&(), &self.events);
        self.tick += 1;
        let stamp_ns = self.stamp_ns();
        let truth = self.true_pose();
        self.odometry.update(&self.prev_true.between(&truth));
        self.prev_true = truth;
        if let Some(h) = &mut self.history {
            h.push(stamp_ns, truth);
        }
        let mut scans = Vec::new();
        let mut any = false;
        for l in &mut self.lidars {
            l.fire_now = l.due(stamp_ns);
            any |= l.fire_now;
        }
        if any {
            self.refresh_agent_shapes();
            let scene = Scene { statics: &self.statics, agents: &self.agent_shapes };
            for l in self.lidars.iter_mut().filter(|l| l.fire_now) {
                scans.push(l.scan(&scene, &truth, stamp_ns, &mut self.scratch, self.history.as_ref()));
            }
        }
        let collisions = self.drain_events(stamp_ns);
        StepOutput {
            tick: self.tick,
            stamp_ns,
            scans,
            odometry: OdometryReading { stamp_ns, pose_in_odom: self.odometry.pose() },
            truth: TruePose { stamp_ns, pose_in_map: truth },
            collisions,
            route_done: self.follower.done(),
            blocked: self.blocked,
        }
    }

    /// Casts every lidar now, at the current pose, without advancing time (for benchmarks and
    /// tools). It draws from the lidars' noise streams, so it changes later scans of the run.
    pub fn scan_now(&mut self) -> Vec<LaserScan> {
        let truth = self.true_pose();
        let stamp_ns = self.stamp_ns();
        self.refresh_agent_shapes();
        let scene = Scene { statics: &self.statics, agents: &self.agent_shapes };
        let history = self.history.as_ref();
        self.lidars.iter_mut().map(|l| l.scan(&scene, &truth, stamp_ns, &mut self.scratch, history)).collect()
    }

    /// The agents' outlines at their current poses (with `legs`, a person's disc is two legs).
    fn refresh_agent_shapes(&mut self) {
        self.agent_shapes.clear();
        for ((a, (state, _)), walked) in self.world.agents.iter().zip(&self.agents).zip(&self.walked) {
            let shape = a.footprint.transformed(&state.pose);
            if let (true, AgentKind::Person, Shape::Circle { center, .. }) = (self.params.realism.legs, a.kind, &shape)
            {
                let c = Point2::new(center[0], center[1]);
                for (leg, r) in self.params.realism.legs_of(c, state.pose.yaw, *walked) {
                    self.agent_shapes.push((Shape::circle(leg, r), leg, r));
                }
                continue;
            }
            let (c, r) = (shape.center(), shape.bounding_radius());
            self.agent_shapes.push((shape, c, r));
        }
    }

    fn drain_events(&mut self, stamp_ns: u64) -> Vec<CollisionEvent> {
        let raw = match self.events.0.lock() {
            Ok(mut v) => std::mem::take(&mut *v),
            Err(_) => Vec::new(),
        };
        let mut out: Vec<CollisionEvent> = raw
            .into_iter()
            .filter_map(|(a, b, started)| {
                let other = if a == self.robot_collider { b } else { a };
                let idx = self.physics.colliders.get(other)?.user_data;
                let other = self.refs.get(usize::try_from(idx).ok()?)?.clone();
                Some(CollisionEvent { tick: self.tick, stamp_ns, other, started })
            })
            .collect();
        out.sort_by(|x, y| (&x.other, x.started).cmp(&(&y.other, y.started)));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lidar::LidarNoise;
    use crate::route::Route;

    /// A bad value is refused with the component, the field (its section's name before it),
    /// the value and what it must be.
    #[test]
    fn a_bad_parameter_is_named_with_its_component_value_and_requirement() {
        let mut p = SimParams::default();
        p.robot.follower.lookahead_m = -0.5;
        let e = p.validate().unwrap_err();
        let SimError::Params { component, error } = &e else { panic!("{e:?}") };
        assert_eq!(component, "RobotParams");
        assert_eq!(error, &ParamError::new("follower.lookahead_m", -0.5, "must be finite and > 0"));
        assert_eq!(e.to_string(), "RobotParams: follower.lookahead_m must be finite and > 0, got -0.5");
        let mut p = SimParams::default();
        p.lidars[1].rate_hz = 0.0;
        assert_eq!(p.validate().unwrap_err().to_string(), "lidars[1]: rate_hz must be in [0.01, 1000], got 0");
        let p = SimParams { tick_ns: 5, ..SimParams::default() };
        assert_eq!(p.validate().unwrap_err().to_string(), "SimParams: tick_ns must be in 1 ms..1 s, got 5");
        let mut p = SimParams::default();
        p.odometry.scale_bias_frac = 0.5;
        assert_eq!(p.validate().unwrap_err().to_string(), "OdometryParams: scale_bias_frac must be < 0.5, got 0.5");
        let mut p = SimParams::default();
        p.agents.give_way_s = f64::INFINITY;
        assert_eq!(p.validate().unwrap_err().to_string(), "AgentParams: give_way_s must be finite and ≥ 0, got inf");
    }

    #[test]
    fn fast_caster_matches_rapier_beam_for_beam() {
        // Noise-free lidars along the default route with agents about: the binned caster and
        // rapier's cast_ray agree on every beam (rapier works in f32: grazing beams differ by ~1e-4 m).
        let world = World::default_warehouse();
        let mut params = SimParams::default();
        for l in &mut params.lidars {
            l.noise = LidarNoise::none();
        }
        let mut sim = Simulator::new(&world, params, 9).unwrap();
        sim.set_route(Route::default_warehouse().points());
        let mut beams = 0;
        for k in 0..1500 {
            sim.step();
            if k % 50 != 0 {
                continue;
            }
            let pose = sim.true_pose();
            sim.refresh_agent_shapes();
            let scene = Scene { statics: &sim.statics, agents: &sim.agent_shapes };
            let filter = QueryFilter::default().exclude_rigid_body(sim.robot_body);
            let query = sim.physics.broad_phase.as_query_pipeline(
                sim.physics.narrow_phase.query_dispatcher(),
                &sim.physics.bodies,
                &sim.physics.colliders,
                filter,
            );
            let mut fast = Vec::new();
            for l in &sim.lidars {
                l.true_ranges(&scene, &pose, &mut fast);
                let slow = l.true_ranges_rapier(&query, &pose);
                for (i, (a, b)) in fast.iter().zip(&slow).enumerate() {
                    match (a, b) {
                        (Some(a), Some(b)) => {
                            assert!((a - b).abs() < 2e-3, "tick {k} lidar {} beam {i}: {a} vs {b}", l.id)
                        }
                        (None, None) => {}
                        _ => panic!("tick {k} lidar {} beam {i}: {a:?} vs {b:?}", l.id),
                    }
                    beams += 1;
                }
            }
        }
        assert!(beams > 30_000);
    }
}
