//! The chain localiser run a frame ahead of the updater (`Session::set_localise_ahead`) gives the
//! run of one thread, bit for bit, through everything that makes it go back: a control
//! re-initialising the estimate after a step or before one, and a control stopping and resuming
//! the robot after the source showed the next frame (which then changes).
#![allow(clippy::unwrap_used)]

use mapkeeper_grid::{CellState, OccupancyGrid, Pose2, cast_ray};
use mapkeeper_harness::{
    Control, HarnessError, NoClock, Observer, PoseSource, RobotControl, SensorFrame, SensorSource, Session,
    SessionStep, SourceError, Step, run,
};
use mapkeeper_localiser::{FilterParams, Localiser};
use mapkeeper_sensor::LaserScan;
use mapkeeper_testkit::rooms::{fill_cells, ten_by_ten_centred};

/// The 10 m × 10 m room centred on the origin (0.1 m cells) with a pillar.
fn room() -> OccupancyGrid {
    let mut m = ten_by_ten_centred();
    fill_cells(&mut m, 60..64, 30..36, CellState::Occupied);
    m
}

/// A robot driving across the room, its scan cast in the map; it stands while stopped. The
/// source shows its next frame before it is taken, as a source run ahead does.
struct Drive {
    map: OccupancyGrid,
    k: u64,
    steps: u64,
    /// Distance driven, metres (the odometry and the truth are the same here).
    x: f64,
    stopped: bool,
    next: Option<Step>,
}

impl Drive {
    fn new(steps: u64) -> Self {
        Self { map: room(), k: 0, steps, x: -3.0, stopped: false, next: None }
    }

    fn pose(&self) -> Pose2 {
        Pose2::new(self.x, 0.4 * (self.x * 0.7).sin(), 0.2 * (self.x * 0.5).cos())
    }

    fn make(&mut self) -> Option<Step> {
        if self.k >= self.steps {
            return None;
        }
        self.k += 1;
        if !self.stopped {
            self.x += 0.06;
        }
        let pose = self.pose();
        let stamp_ns = self.k * 80_000_000;
        let ranges_m = (0..181)
            .map(|i| {
                let a = pose.yaw - 1.5 + i as f64 * 0.0167;
                cast_ray(&self.map, pose.position(), a, 12.0, true).range_m as f32
            })
            .collect();
        let scan = LaserScan {
            stamp_ns,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: -1.5,
            angle_increment_rad: 0.0167,
            range_min_m: 0.05,
            range_max_m: 12.0,
            ranges_m,
            sweep: None,
        };
        Some(Step { frame: SensorFrame { stamp_ns, odometry: Some(pose), scans: vec![scan] }, truth: None })
    }
}

impl SensorSource for Drive {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        Ok(match self.next.take() {
            Some(s) => Some(s),
            None => self.make(),
        })
    }

    fn peek_frame(&mut self) -> Option<&SensorFrame> {
        if self.next.is_none() {
            self.next = self.make();
        }
        self.next.as_ref().map(|s| &s.frame)
    }

    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        Some(self)
    }
}

impl RobotControl for Drive {
    fn stop(&mut self, _resume_after_s: Option<f64>) {
        self.stop_or_resume(true);
    }

    fn resume(&mut self) {
        self.stop_or_resume(false);
    }

    fn is_stopped(&self) -> bool {
        self.stopped
    }

    fn move_robot(&mut self, _pose_in_map: Pose2) {}
}

impl Drive {
    /// Acting on the robot drops the step shown and not yet taken: it is made again.
    fn stop_or_resume(&mut self, stop: bool) {
        if self.stopped == stop {
            return;
        }
        if self.next.take().is_some() {
            self.k -= 1;
            if !self.stopped {
                self.x -= 0.06; // it had moved the robot
            }
        }
        self.stopped = stop;
    }
}

/// Re-initialises the estimate and stops and resumes the robot at fixed steps.
struct Script {
    step: u64,
}

impl Control for Script {
    fn before_step(
        &mut self,
        _step: &Step,
        session: &mut Session<'_>,
        _robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        self.step += 1;
        if self.step == 31 {
            session
                .set_estimate(Pose2::new(-1.0, 0.1, 0.0), [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.003]])?;
        }
        Ok(())
    }

    fn after_step(
        &mut self,
        step: &Step,
        _report: &SessionStep,
        session: &mut Session<'_>,
        robot: Option<&mut dyn RobotControl>,
    ) -> Result<(), HarnessError> {
        let robot = robot.unwrap();
        match self.step {
            12 => {
                let p = step.frame.odometry.unwrap();
                session.set_estimate(p, [[0.02, 0.0, 0.0], [0.0, 0.02, 0.0], [0.0, 0.0, 0.005]])?;
            }
            18 => robot.stop(None),
            24 => robot.resume(),
            _ => {}
        }
        Ok(())
    }
}

/// Every step's report and the particles the observers see.
#[derive(Default)]
struct Record {
    steps: Vec<SessionStep>,
    particles: Vec<Vec<Pose2>>,
}

impl Observer for Record {
    fn on_step(&mut self, _step: &Step, report: &SessionStep, session: &Session<'_>) {
        self.steps.push(report.clone());
        self.particles.push(session.particles().unwrap().to_vec());
    }
}

fn drive(ahead: bool, params: FilterParams) -> (Record, mapkeeper_harness::AheadCounts) {
    let map = room();
    let mut loc = Localiser::new(&map, params, 3).unwrap();
    loc.init_pose(Pose2::new(-2.95, 0.05, 0.1), [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.003]]).unwrap();
    let mut session = Session::new(PoseSource::Localiser(Box::new(loc)), None, None, &NoClock);
    session.set_localise_ahead(ahead);
    assert_eq!(session.localises_ahead(), ahead);
    let mut source = Drive::new(60);
    let (mut script, mut record) = (Script { step: 0 }, Record::default());
    run(&mut source, &mut session, &mut [&mut script], &mut [&mut record]).unwrap();
    let counts = session.ahead_counts();
    session.finish().unwrap();
    (record, counts)
}

#[test]
fn the_localiser_run_ahead_gives_the_run_of_one_thread() {
    let small = FilterParams { min_particles: 100, max_particles: 400, ..FilterParams::default() };
    for params in [small, FilterParams::amcl()] {
        let (inline, none) = drive(false, params);
        let (ahead, counts) = drive(true, params);
        assert_eq!(none, mapkeeper_harness::AheadCounts::default());
        assert_eq!(inline.steps.len(), 60);
        assert_eq!(inline.steps, ahead.steps, "the reports differ");
        assert_eq!(inline.particles, ahead.particles, "the particles the observers see differ");
        // The test exercises every path: updates used as run ahead, and updates thrown away
        // (a re-initialisation, a stop after the next frame was shown).
        assert!(counts.used > 5, "{counts:?}");
        assert!(counts.discarded >= 2, "{counts:?}");
        assert_eq!(counts.sent, counts.used + counts.discarded, "{counts:?}");
        assert!(inline.steps.iter().filter(|s| s.localiser.is_some_and(|r| r.sensor_update)).count() > 10);
    }
}
