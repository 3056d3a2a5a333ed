//! Where steps come from: a [`SensorSource`] yields [`Step`]s (the sensor frame the estimators
//! see, and the truth they never see); a source that drives a robot also offers
//! [`RobotControl`], through which an experiment stops, resumes or moves the robot.

use mapkeeper_grid::Pose2;
use mapkeeper_sensor::LaserScan;

/// What the estimators are given at one step: the stamp, the odometry and every lidar's scan.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorFrame {
    /// Stamp of the step, nanoseconds on the source's clock.
    pub stamp_ns: u64,
    /// The robot's pose in the odometry frame at `stamp_ns`; `None` where the source has no
    /// odometry for this step (a log whose first odometry record comes later).
    pub odometry: Option<Pose2>,
    /// The scans of this step, one per lidar, each with its mounting pose.
    pub scans: Vec<LaserScan>,
}

/// The ground truth at one step: for observers and scoring only, never for an estimator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Truth {
    /// The robot's true pose in the map frame.
    pub pose_in_map: Pose2,
    /// Distance the robot has travelled since the start of the source (true), metres.
    pub distance_m: f64,
}

/// One step of a source: the frame the estimators see and, where known, the truth.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// What the estimators see.
    pub frame: SensorFrame,
    /// What only observers and experiment controls see.
    pub truth: Option<Truth>,
}

/// A stream of steps: a simulator, a recorded log, a robot.
pub trait SensorSource {
    /// The next step, or `None` at the end of the stream.
    fn next_step(&mut self) -> Result<Option<Step>, SourceError>;

    /// The robot behind the stream, if the source can act on it (a simulator can; a log
    /// cannot).
    fn control(&mut self) -> Option<&mut dyn RobotControl> {
        None
    }
}

/// What an experiment can do to the robot of a source that drives one.
pub trait RobotControl {
    /// Stops the robot where it is (no-op if already stopped by this interface); with
    /// `resume_after_s`, the source resumes it by itself once that much time has passed.
    fn stop(&mut self, resume_after_s: Option<f64>);
    /// Resumes a robot stopped by [`RobotControl::stop`] (no-op otherwise).
    fn resume(&mut self);
    /// Whether the robot is stopped by [`RobotControl::stop`].
    fn is_stopped(&self) -> bool;
    /// Moves the robot to `pose_in_map` at once; its odometry does not see the jump.
    fn move_robot(&mut self, pose_in_map: Pose2);
}

/// A source could not deliver its next step.
#[derive(Debug, thiserror::Error)]
#[error("{source_name}: {message}")]
pub struct SourceError {
    /// Which source (a file path, "simulator").
    pub source_name: String,
    /// What went wrong, and where.
    pub message: String,
}
