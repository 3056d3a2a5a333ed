//! # mapkeeper-sensor
//!
//! Plain sensor data: laser scans with their lidar's mounting pose (extrinsics), wheel
//! odometry, true poses, and the versioned JSON Lines sensor log that carries them. The
//! localiser and the updater take only these types, so a log file or a real robot can feed
//! them as well as the simulator.
//!
//! ```
//! use mapkeeper_sensor::{BeamValidity, LaserScan};
//! use mapkeeper_grid::Pose2;
//! let scan = LaserScan {
//!     stamp_ns: 0,
//!     lidar_id: 0,
//!     lidar_in_robot: Pose2::IDENTITY,
//!     angle_min_rad: -0.1,
//!     angle_increment_rad: 0.1,
//!     range_min_m: 0.1,
//!     range_max_m: 30.0,
//!     ranges_m: vec![2.0, f32::INFINITY, 0.05],
//!     sweep: None,
//! };
//! assert!(scan.validate().is_ok());
//! assert_eq!(scan.validity(1), BeamValidity::NotFinite);
//! assert_eq!(scan.valid_count(), 1);
//! ```
#![warn(missing_docs)]

mod deskew;
mod log;
mod scan;
pub mod tum;

pub use deskew::{constant_velocity, deskew, deskew_all};
pub use log::{
    LOG_FORMAT, LOG_VERSION, LogError, LogHeader, LogRecord, LogWriter, MAX_LINE_BYTES, OdometryReading, SensorLog,
    TruePose,
};
pub use scan::{BeamValidity, LaserScan, MAX_BEAMS, MAX_SWEEP_S, ScanError, SweepTiming};
pub use tum::{
    StampedPose, TumError, format_tum, interpolate, interpolate_within, read_tum, write_tum, write_tum_with_comment,
};
