//! The Lost policy's walk (issue 54 item 2): after a stopped Lost episode gives up, the robot
//! walks on for `walk_s` while Lost, so pose updating looks from new places; without it, the
//! robot stops again at the next Lost step and stands (the paper's reaction).
#![allow(clippy::unwrap_used)]

use mapkeeper_grid::Pose2;
use mapkeeper_harness::{
    LostEnd, LostPolicy, NoClock, PoseSource, RobotControl, SensorFrame, SensorSource, Session, SourceError, Step, run,
};
use mapkeeper_sensor::{LaserScan, StampedPose};
use mapkeeper_testkit::rooms::ten_by_ten_centred;
use mapkeeper_updater::{MapUpdater, UpdaterParams};

/// A robot driving along +x at 1 m/s unless stopped, a step every 0.1 s for 12 s, whose lidar
/// sees a wall 2 m away all round: nothing on the map fits it, every step says Lost.
struct Robot {
    k: u64,
    x: f64,
    stopped: bool,
    /// x at every step.
    xs: Vec<f64>,
}

impl SensorSource for Robot {
    fn next_step(&mut self) -> Result<Option<Step>, SourceError> {
        if self.k == 120 {
            return Ok(None);
        }
        if self.k > 0 && !self.stopped {
            self.x += 0.1;
        }
        self.xs.push(self.x);
        let stamp_ns = self.k * 100_000_000;
        self.k += 1;
        let scan = LaserScan {
            stamp_ns,
            lidar_id: 0,
            lidar_in_robot: Pose2::IDENTITY,
            angle_min_rad: -std::f64::consts::PI,
            angle_increment_rad: std::f64::consts::TAU / 360.0,
            range_min_m: 0.05,
            range_max_m: 20.0,
            ranges_m: vec![2.0; 360],
            sweep: None,
        };
        let frame = SensorFrame { stamp_ns, odometry: Some(Pose2::new(self.x, 0.0, 0.0)), scans: vec![scan] };
        Ok(Some(Step { frame, truth: None }))
    }

    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        Some(self)
    }
}

impl RobotControl for Robot {
    fn stop(&mut self, _resume_after_s: Option<f64>) {
        self.stopped = true;
    }
    fn resume(&mut self) {
        self.stopped = false;
    }
    fn is_stopped(&self) -> bool {
        self.stopped
    }
    fn move_robot(&mut self, _pose_in_map: Pose2) {}
}

/// Runs the robot under the policy; returns how far it went and the policy's episodes.
fn drive(walk_s: f64) -> (f64, Vec<mapkeeper_harness::LostEpisode>) {
    let map = ten_by_ten_centred();
    let updater = MapUpdater::new(map, UpdaterParams::mapkeeper()).unwrap();
    let track = PoseSource::Track(vec![StampedPose { stamp_ns: 0, pose: Pose2::new(0.5, 0.3, 0.0) }]);
    let mut session = Session::new(track, Some(updater), None, &NoClock);
    let cov = [[0.01, 0.0, 0.0], [0.0, 0.01, 0.0], [0.0, 0.0, 0.0025]];
    let mut lost = LostPolicy::new(true, 2.0, cov).with_walk(walk_s);
    let mut robot = Robot { k: 0, x: 0.0, stopped: false, xs: Vec::new() };
    run(&mut robot, &mut session, &mut [&mut lost], &mut []).unwrap();
    let (counts, episodes) = lost.finish();
    assert_eq!(counts.recoveries, 0, "nothing fits: {counts}");
    (robot.xs.last().copied().unwrap(), episodes)
}

#[test]
fn after_a_give_up_the_robot_walks_on_only_when_told_to() {
    // Standing: stopped at the first Lost, a step's move after each 2 s give-up.
    let (went, episodes) = drive(0.0);
    assert!(went < 0.75, "{went} m");
    assert!(episodes.iter().all(|e| e.stopped), "{episodes:?}");
    // Walking 2 s after each stopped give-up: stand 2 s, walk 2 s, … (about 4 m in 12 s).
    let (went, episodes) = drive(2.0);
    assert!(went > 3.0, "{went} m");
    let walked: Vec<_> = episodes.iter().filter(|e| !e.stopped).collect();
    assert!(!walked.is_empty() && walked.iter().all(|e| e.end != LostEnd::Recovered), "{episodes:?}");
    assert!(walked.iter().all(|e| e.attempts > 0), "pose updating keeps trying while walking: {episodes:?}");
    // Every walk follows a stopped give-up.
    for w in episodes.windows(2) {
        if !w[1].stopped {
            assert!(w[0].end == LostEnd::GaveUp, "{episodes:?}");
        }
    }
}
