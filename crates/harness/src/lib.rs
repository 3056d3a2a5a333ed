//! # mapkeeper-harness
//!
//! One loop for simulated and recorded data. A [`SensorSource`] (the simulator, a replayed
//! log) yields [`Step`]s: a [`SensorFrame`] for the estimators and, apart, the [`Truth`]. A
//! [`Session`] owns the estimators (the chain localiser or a recorded track, the map updater,
//! an optional baseline localiser) and processes one frame at a time; it never sees the truth.
//! [`Observer`]s (statistics, trajectories, timelines) read the step, truth included, and the
//! session's report; [`Control`]s are what an experiment does: bias the estimate, stop, resume
//! or move the robot, hand a recovered pose back, or feed the updater a pose of its own (an
//! oracle's, [`Session::set_updater_pose_override`]). [`run`] drives them all.
//!
//! This crate depends on no simulator: the replay path builds without rapier.
//!
//! ```
//! use mapkeeper_harness::{LogSource, NoClock, PoseSource, ReplayOptions, Session, run};
//! use mapkeeper_sensor::{LogHeader, SensorLog};
//! let log = SensorLog { header: LogHeader::new(Default::default()), records: Vec::new() };
//! let mut source = LogSource::new(log, "empty", ReplayOptions::default());
//! let mut session = Session::new(PoseSource::None, None, None, &NoClock);
//! assert_eq!(run(&mut source, &mut session, &mut [], &mut []).unwrap(), 0);
//! ```
#![warn(missing_docs)]

pub mod driver;
mod error;
pub mod jobs;
pub mod lost;
pub mod mcap_out;
pub mod replay;
pub mod scoring;
pub mod session;
pub mod source;

pub use driver::{Control, Observer, run, step_once};
pub use error::HarnessError;
pub use lost::{DEFAULT_LOST_WAIT_S, HandoverHold, LostCounts, LostEnd, LostEpisode, LostPolicy};
/// The injected clock (`mapkeeper_common::clock`).
pub use mapkeeper_common::clock;
/// Parameter files (`mapkeeper_common::params`).
pub use mapkeeper_common::params as config;
pub use mapkeeper_common::{Clock, NoClock};
pub use replay::{DEFAULT_SYNC_WINDOW_NS, LogSource, OdometryAt, ReplayOptions};
pub use scoring::{ErrorSample, LocAcc, LocScore, LocStats, Trajectories, UpdaterWork};
pub use session::{Baseline, BaselineSample, PoseBias, PoseSource, Session, SessionOutput, SessionStep, Skip};
pub use source::{RobotControl, SensorFrame, SensorSource, SourceError, Step, Truth};
