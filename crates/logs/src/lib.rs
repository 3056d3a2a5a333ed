//! # mapkeeper-logs
//!
//! Recorded robot logs in, runs out. Readers turn a ROS 1 bag, a ROS 2 bag in MCAP storage or a
//! CARMEN log into the project's [`SensorLog`] (`docs/sensor-log.md`), so the localiser and the
//! updater run on a robot's own recordings exactly as on the simulator's; `docs/real-data.md`
//! gives the commands.
//!
//! Every reader decodes its messages and hands them to one [`Assembler`], which picks the lidars,
//! finds their mounts from the static transforms, takes the odometry from a topic or from the
//! `odom → base` transform, counts (and clamps) timestamps that step back, and re-bases time on
//! the log's first stamp; the [`ImportReport`] says what it found.
//!
//! The other way, [`McapRunWriter`] writes a run (scans, odometry, truth, estimates, particles,
//! maps, verdicts) as a ROS 2 bag in MCAP storage that Foxglove Studio and `ros2 bag` read.
//!
//! ```
//! use mapkeeper_logs::{LogFormat, detect_format};
//! let dir = std::env::temp_dir().join(format!("mapkeeper-logs-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("robot.log");
//! std::fs::write(&path, "PARAM robot_frontlaser_offset 0.0 nohost 0\nODOM 0 0 0 0 0 0 0.1 h 0.1\n").unwrap();
//! assert_eq!(detect_format(&path).unwrap(), LogFormat::Carmen);
//! std::fs::remove_dir_all(&dir).ok();
//! ```
#![warn(missing_docs)]

mod assemble;
pub mod carmen;
mod error;
mod options;
mod report;
mod rigid;
pub mod ros1;
pub mod ros2;
mod timing;

pub use assemble::{
    Assembler, RawOdometry, RawPose, RawScan, RawTransform, RosScanFields, SCANS_TO_COME, mount_from_transforms,
};
pub use error::ImportError;
pub use options::{CarmenKind, ImportOptions, OdometryFrom, RATE_HZ_RANGE, StampFrom, Thinning, TimeSource};
pub use report::{BackwardSteps, ImportReport, LidarInfo, ScanOdometrySummary, TopicCount};
pub use rigid::Rigid3;
pub use ros2::{
    CHANGE_ADDED, CHANGE_NONE, CHANGE_OTHER, CHANGE_REMOVED, McapRunWriter, McapWriteError, UpdaterStepMsg,
    write_log_mcap,
};

use mapkeeper_sensor::SensorLog;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The formats a log can come in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogFormat {
    /// The project's JSON Lines sensor log (a `.jsonl` file, or a folder holding `log.jsonl`).
    Jsonl,
    /// A ROS 2 bag in MCAP storage (a `.mcap` file, or a bag folder with `metadata.yaml`).
    Mcap,
    /// A ROS 1 bag (`.bag`, format 2.0).
    Ros1Bag,
    /// A CARMEN log (plain text or gzipped).
    Carmen,
}

impl LogFormat {
    /// Every format, by its flag name.
    pub const NAMES: [(&'static str, LogFormat); 4] = [
        ("jsonl", LogFormat::Jsonl),
        ("mcap", LogFormat::Mcap),
        ("bag", LogFormat::Ros1Bag),
        ("carmen", LogFormat::Carmen),
    ];

    /// The format of a flag value (`jsonl`, `mcap`, `bag`, `carmen`).
    pub fn from_name(name: &str) -> Option<LogFormat> {
        Self::NAMES.iter().find(|(n, _)| *n == name).map(|(_, f)| *f)
    }

    /// The flag name.
    pub fn name(self) -> &'static str {
        Self::NAMES.iter().find(|(_, f)| *f == self).map_or("jsonl", |(n, _)| n)
    }
}

/// A log read into memory, with what the import found (`None` for the project's own log, which
/// needs no import).
#[derive(Clone, Debug)]
pub struct Imported {
    /// The sensor log.
    pub log: SensorLog,
    /// What the import found.
    pub report: Option<ImportReport>,
    /// The file read (a folder's `log.jsonl`, a bag folder's `.mcap`).
    pub path: PathBuf,
}

const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";
const ROSBAG_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// The format of the log at `path`, from its content (a folder by the files in it).
pub fn detect_format(path: &Path) -> Result<LogFormat, ImportError> {
    if path.is_dir() {
        if path.join("log.jsonl").is_file() {
            return Ok(LogFormat::Jsonl);
        }
        if path.join("metadata.yaml").is_file() {
            return Ok(LogFormat::Mcap);
        }
        return Err(ImportError::unusable(
            path,
            "a folder that holds neither a sensor log 'log.jsonl' nor a ROS 2 bag 'metadata.yaml'",
        ));
    }
    let mut head = Vec::with_capacity(64);
    std::fs::File::open(path).and_then(|f| f.take(64).read_to_end(&mut head)).map_err(|e| ImportError::io(path, e))?;
    if head.starts_with(MCAP_MAGIC) {
        return Ok(LogFormat::Mcap);
    }
    if head.starts_with(ROSBAG_MAGIC) {
        return Ok(LogFormat::Ros1Bag);
    }
    if head.starts_with(b"#ROSBAG") {
        let version =
            String::from_utf8_lossy(&head[..head.iter().position(|&b| b == b'\n').unwrap_or(head.len())]).into_owned();
        return Err(ImportError::parse(path, "byte 0", format!("'{version}': only ROS bag format 2.0 is read")));
    }
    if head.starts_with(&[0x1f, 0x8b]) {
        return Ok(LogFormat::Carmen);
    }
    let first = head.iter().find(|b| !b.is_ascii_whitespace());
    if first == Some(&b'{') {
        return Ok(LogFormat::Jsonl);
    }
    if carmen::looks_like_carmen(&head) {
        return Ok(LogFormat::Carmen);
    }
    Err(ImportError::parse(
        path,
        "byte 0",
        "not a log this tool reads (a mapkeeper JSON Lines log, a ROS 2 MCAP bag, a ROS 1 bag v2.0 or a CARMEN log); \
name the format with --log-format if it is one",
    ))
}

/// Reads the log at `path` in `format` (detected from the content if `None`).
pub fn read_log(path: &Path, format: Option<LogFormat>, options: &ImportOptions) -> Result<Imported, ImportError> {
    let format = match format {
        Some(f) => f,
        None => detect_format(path)?,
    };
    match format {
        LogFormat::Jsonl => {
            let file = if path.is_dir() { path.join("log.jsonl") } else { path.to_path_buf() };
            if options.time_source != TimeSource::Auto || options.rate_hz.is_some() || options.thinning != Thinning::All
            {
                return Err(ImportError::unusable(
                    &file,
                    "--time-source, --rate, --keep-every and --every-m are for imported logs (bags, CARMEN); this \
project's own log is read as written",
                ));
            }
            let log = SensorLog::read(&file)?;
            Ok(Imported { log, report: None, path: file })
        }
        LogFormat::Carmen => {
            let (log, report) = carmen::read(path, options)?;
            Ok(Imported { log, report: Some(report), path: path.to_path_buf() })
        }
        LogFormat::Mcap => {
            let (log, report) = ros2::read(path, options)?;
            let files = ros2::bag_files(path)?;
            let file = if files.len() == 1 { files[0].clone() } else { path.to_path_buf() };
            Ok(Imported { log, report: Some(report), path: file })
        }
        LogFormat::Ros1Bag => {
            let (log, report) = ros1::read(path, options)?;
            Ok(Imported { log, report: Some(report), path: path.to_path_buf() })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_projects_own_log_refuses_the_import_only_options() {
        let dir = std::env::temp_dir().join(format!("mapkeeper-logs-jsonl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("log.jsonl");
        std::fs::write(&path, "{\"format\":\"mapkeeper-sensor-log\",\"version\":1,\"meta\":{}}\n").unwrap();
        for options in [
            ImportOptions { thinning: Thinning::KeepEvery(2), ..ImportOptions::default() },
            ImportOptions { rate_hz: Some(5.0), ..ImportOptions::default() },
            ImportOptions { time_source: TimeSource::Line, ..ImportOptions::default() },
        ] {
            let e = read_log(&dir, None, &options).unwrap_err().to_string();
            assert!(e.contains("log.jsonl") && e.contains("are for imported logs"), "{e}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
