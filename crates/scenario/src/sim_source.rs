//! The simulator as a [`SensorSource`]: it advances physics ticks until a lidar fires and hands
//! out that tick's scans and odometry, with the true pose (and the distance driven) apart. It
//! is also the [`RobotControl`] of the experiments: stop at once (with a timed resume), resume, move.

use mapkeeper_grid::Pose2;
use mapkeeper_harness::{RobotControl, SensorFrame, SensorSource, SourceError, Step, Truth};
use mapkeeper_sim::Simulator;

/// A simulator driving its route, tick by tick, until the route is done or the time is up.
pub struct SimSource {
    sim: Simulator,
    max_ticks: u64,
    collisions: u64,
    distance_m: f64,
    prev_truth: Pose2,
    route_done: bool,
    /// The handed-out step's tick still has its end-of-tick work to do; with its route_done.
    pending: Option<bool>,
    /// Tick at which [`RobotControl::stop`] stopped the robot, and after how many ticks the
    /// source resumes it by itself.
    stopped: Option<(u64, Option<u64>)>,
}

impl std::fmt::Debug for SimSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SimSource").field("tick", &self.sim.tick()).field("max_ticks", &self.max_ticks).finish()
    }
}

impl SimSource {
    /// A source over `sim` (its route already set) that ends after `max_sim_time_s`.
    pub fn new(sim: Simulator, max_sim_time_s: f64) -> Self {
        let max_ticks = (max_sim_time_s * 1e9 / sim.params().tick_ns as f64).ceil() as u64;
        let prev_truth = sim.true_pose();
        Self {
            sim,
            max_ticks,
            collisions: 0,
            distance_m: 0.0,
            prev_truth,
            route_done: false,
            pending: None,
            stopped: None,
        }
    }

    /// The simulator.
    pub fn sim(&self) -> &Simulator {
        &self.sim
    }

    /// Contacts of the robot that began so far.
    pub fn collisions(&self) -> u64 {
        self.collisions
    }

    /// Distance the robot travelled (true), metres.
    pub fn distance_m(&self) -> f64 {
        self.distance_m
    }

    /// Whether the route was completed.
    pub fn route_done(&self) -> bool {
        self.route_done
    }

    /// Simulated time so far, seconds.
    pub fn sim_time_s(&self) -> f64 {
        self.sim.stamp_ns() as f64 / 1e9
    }

    /// The end of a tick: a timed resume falls due.
    fn end_of_tick(&mut self) {
        if let Some((since, Some(wait))) = self.stopped
            && self.sim.tick() - since >= wait
        {
            self.sim.resume();
            self.stopped = None;
        }
    }
}

impl SensorSource for SimSource {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        if let Some(route_done) = self.pending.take() {
            self.end_of_tick();
            if route_done {
                self.route_done = true;
                return Ok(None);
            }
        }
        while self.sim.tick() < self.max_ticks {
            let out = self.sim.step();
            self.collisions += out.collisions.iter().filter(|c| c.started).count() as u64;
            let truth = out.truth.pose_in_map;
            self.distance_m += self.prev_truth.distance(&truth);
            self.prev_truth = truth;
            if !out.scans.is_empty() {
                self.pending = Some(out.route_done);
                let frame =
                    SensorFrame { stamp_ns: out.stamp_ns, odometry: Some(out.odometry.pose_in_odom), scans: out.scans };
                return Ok(Some(Step {
                    frame,
                    truth: Some(Truth { pose_in_map: truth, distance_m: self.distance_m }),
                }));
            }
            self.end_of_tick();
            if out.route_done {
                self.route_done = true;
                return Ok(None);
            }
        }
        Ok(None)
    }

    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        Some(self)
    }
}

impl RobotControl for SimSource {
    /// Halts the robot where it is ([`Simulator::halt`]: it stands still from the next tick on,
    /// rather than braking over up to 2 m), as the paper stops it while pose updating runs.
    fn stop(&mut self, resume_after_s: Option<f64>) {
        if self.stopped.is_none() {
            self.sim.halt();
            let tick_ns = self.sim.params().tick_ns as f64;
            self.stopped = Some((self.sim.tick(), resume_after_s.map(|s| (s * 1e9 / tick_ns).ceil() as u64)));
        }
    }

    fn resume(&mut self) {
        if self.stopped.take().is_some() {
            self.sim.resume();
        }
    }

    fn is_stopped(&self) -> bool {
        self.stopped.is_some()
    }

    fn move_robot(&mut self, pose_in_map: Pose2) {
        self.sim.teleport_robot(pose_in_map);
        self.prev_truth = self.sim.true_pose();
    }
}
