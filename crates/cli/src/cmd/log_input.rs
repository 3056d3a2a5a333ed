//! `--log` and its companions, shared by every command that reads a recorded log (`localise`,
//! `update`, `map`, `convert`): the project's own log, a ROS 2 MCAP bag, a ROS 1 bag or a CARMEN
//! log, detected from the content (`docs/real-data.md`).

use mapkeeper_logs::{
    CarmenKind, ImportOptions, Imported, LogFormat, OdometryFrom, RATE_HZ_RANGE, StampFrom, Thinning, TimeSource,
    read_log,
};
use mapkeeper_sensor::SensorLog;
use std::path::PathBuf;

/// Where a recorded log comes from and how it is read.
#[derive(clap::Args, Debug, Clone)]
pub struct LogInput {
    /// The log: a folder holding log.jsonl, a mapkeeper .jsonl log, a ROS 2 bag (a folder with
    /// metadata.yaml, or a .mcap file), a ROS 1 .bag, or a CARMEN log (plain or gzipped); the
    /// format is detected from the content (docs/real-data.md).
    #[arg(long, value_name = "PATH")]
    pub log: PathBuf,
    /// The log's format, instead of detecting it: jsonl, mcap, bag or carmen.
    #[arg(long, value_name = "FORMAT", value_parser = log_format)]
    pub log_format: Option<LogFormat>,
    /// A lidar's scan topic (repeat for several lidars, in lidar-id order; default: every topic
    /// with sensor_msgs/LaserScan messages, sorted by name; CARMEN: FLASER, RLASER, ROBOTLASER1).
    #[arg(long = "scan-topic", value_name = "TOPIC")]
    pub scan_topics: Vec<String>,
    /// A lidar by its scans' frame_id instead of its topic (repeat for several, in lidar-id
    /// order): for drivers that put several lidars on one topic.
    #[arg(long = "scan-frame", value_name = "FRAME", conflicts_with = "scan_topics")]
    pub scan_frames: Vec<String>,
    /// The odometry topic (nav_msgs/Odometry; default: /odom if present, else the only odometry
    /// topic, else the odom → base transform of /tf).
    #[arg(long, value_name = "TOPIC", conflicts_with = "odom_from_tf")]
    pub odom_topic: Option<String>,
    /// Take the odometry from the odom → base transform of /tf (--odom-frame, --base-frame).
    #[arg(long)]
    pub odom_from_tf: bool,
    /// The robot's base frame (lidar mounts are read from the static transforms from it).
    #[arg(long, value_name = "FRAME", default_value = "base_link")]
    pub base_frame: String,
    /// The odometry frame.
    #[arg(long, value_name = "FRAME", default_value = "odom")]
    pub odom_frame: String,
    /// A topic of reference poses in the map frame (nav_msgs/Odometry, geometry_msgs/PoseStamped
    /// or PoseWithCovarianceStamped), read as the log's true poses (CARMEN corrected logs: their
    /// corrected poses, always).
    #[arg(long, value_name = "TOPIC")]
    pub truth_topic: Option<String>,
    /// Which clock stamps a message: header (its own stamp, as a ROS node sees it) or record
    /// (when the recorder received it).
    #[arg(long, value_name = "CLOCK", default_value = "header", value_parser = stamp_from)]
    pub stamp: StampFrom,
    /// CARMEN logs: auto (told from the file: a laser line whose pose and odometry triplets
    /// differ, or no ODOM lines, or ODOM lines that are not re-anchored at the scans, make it
    /// raw), raw (odometry = the ODOM lines, else the laser lines' odometry fields; no
    /// reference) or corrected (reference = the laser lines' poses, odometry re-chained from the
    /// ODOM lines). The import report says which was read and why.
    #[arg(long, value_name = "KIND", default_value = "auto", value_parser = carmen_kind)]
    pub carmen_kind: CarmenKind,
    /// Read a damaged file past its damage instead of refusing it: a truncated or corrupt gzipped
    /// CARMEN log up to the damage; a ROS 1 bag's damaged records and chunks skipped to the next
    /// chunk that reads, a truncated bag as far as it goes. The import report's `salvaged:` notes
    /// say what was skipped.
    #[arg(long)]
    pub salvage: bool,
    #[command(flatten)]
    pub time: TimeFlags,
}

/// Where the messages' times come from and which scans are kept: shared by `LogInput` and the
/// several-log commands (`experiment real-data`).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct TimeFlags {
    /// Where the messages' times come from: auto (the stamps, unless they repeat or step back
    /// across many messages or are printed too coarsely to order them: then the file's order,
    /// with a note), stamp (the stamps as written) or line (the file's order: a CARMEN log's
    /// lines, timed from the printed stamps where they change or from --rate; a bag's record
    /// times).
    #[arg(long, value_name = "SOURCE", default_value = "auto", value_parser = time_source)]
    pub time_source: TimeSource,
    /// The first lidar's scan rate, scans per second, for a CARMEN log timed by its lines whose
    /// printed stamps never move on (e.g. all `1.13486e+09`): the scans are spaced 1/HZ apart.
    #[arg(long, value_name = "HZ", value_parser = rate_hz, allow_hyphen_values = true)]
    pub rate: Option<f64>,
    /// Keep the first scan of each lidar and every N-th after it (odometry and reference all
    /// kept): for heavy logs, or to test on sparser scans.
    #[arg(long, value_name = "N", value_parser = keep_every, conflicts_with = "every_m", allow_hyphen_values = true)]
    pub keep_every: Option<usize>,
    /// Keep the first scan of each lidar, then one each time the odometry has travelled at least
    /// M metres along its path since the last kept (odometry and reference all kept).
    #[arg(long, value_name = "M", value_parser = every_m, allow_hyphen_values = true)]
    pub every_m: Option<f64>,
}

impl TimeFlags {
    /// Whether every flag is at its default (nothing asked for).
    pub fn is_default(&self) -> bool {
        self.time_source == TimeSource::Auto && self.rate.is_none() && self.thinning() == Thinning::All
    }

    /// The thinning these flags ask for.
    pub fn thinning(&self) -> Thinning {
        match (self.keep_every, self.every_m) {
            (Some(n), _) => Thinning::KeepEvery(n),
            (None, Some(m)) => Thinning::EveryMetres(m),
            (None, None) => Thinning::All,
        }
    }
}

fn time_source(s: &str) -> Result<TimeSource, String> {
    TimeSource::from_name(s)
        .ok_or_else(|| format!("'{}' is not a time source (known: auto, stamp, line)", s.escape_debug()))
}

fn rate_hz(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{}' is not a number", s.escape_debug()))?;
    if !(v.is_finite() && RATE_HZ_RANGE.contains(&v)) {
        return Err(format!(
            "{v}: expected scans per second from {} to {}",
            RATE_HZ_RANGE.start(),
            RATE_HZ_RANGE.end()
        ));
    }
    Ok(v)
}

fn keep_every(s: &str) -> Result<usize, String> {
    let n: usize = s.parse().map_err(|_| format!("'{}' is not a whole number", s.escape_debug()))?;
    Thinning::KeepEvery(n).problem().map_or(Ok(n), Err)
}

fn every_m(s: &str) -> Result<f64, String> {
    let m: f64 = s.parse().map_err(|_| format!("'{}' is not a number", s.escape_debug()))?;
    Thinning::EveryMetres(m).problem().map_or(Ok(m), Err)
}

fn carmen_kind(s: &str) -> Result<CarmenKind, String> {
    CarmenKind::from_name(s)
        .ok_or_else(|| format!("'{}' is not a CARMEN log kind (known: auto, raw, corrected)", s.escape_debug()))
}

fn log_format(s: &str) -> Result<LogFormat, String> {
    LogFormat::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = LogFormat::NAMES.iter().map(|(n, _)| *n).collect();
        format!("'{}' is not a log format (known: {})", s.escape_debug(), names.join(", "))
    })
}

fn stamp_from(s: &str) -> Result<StampFrom, String> {
    match s {
        "header" => Ok(StampFrom::Header),
        "record" => Ok(StampFrom::Record),
        _ => Err(format!("'{}' is not a clock (known: header, record)", s.escape_debug())),
    }
}

impl LogInput {
    /// `--log path` with every other reading flag at its default.
    pub fn path(path: &std::path::Path) -> Self {
        Self {
            log: path.to_path_buf(),
            log_format: None,
            scan_topics: Vec::new(),
            scan_frames: Vec::new(),
            odom_topic: None,
            odom_from_tf: false,
            base_frame: "base_link".into(),
            odom_frame: "odom".into(),
            truth_topic: None,
            stamp: StampFrom::Header,
            carmen_kind: CarmenKind::Auto,
            salvage: false,
            time: TimeFlags::default(),
        }
    }

    /// The import options these flags give.
    pub fn options(&self) -> ImportOptions {
        let odometry = match (&self.odom_topic, self.odom_from_tf) {
            (Some(t), _) => OdometryFrom::Topic(t.clone()),
            (None, true) => OdometryFrom::Tf,
            (None, false) => OdometryFrom::Auto,
        };
        ImportOptions {
            scan_topics: self.scan_topics.clone(),
            scan_frames: self.scan_frames.clone(),
            odometry,
            base_frame: self.base_frame.clone(),
            odom_frame: self.odom_frame.clone(),
            truth_topic: self.truth_topic.clone(),
            stamp: self.stamp,
            carmen_kind: self.carmen_kind,
            salvage: self.salvage,
            time_source: self.time.time_source,
            rate_hz: self.time.rate,
            thinning: self.time.thinning(),
        }
    }

    /// Reads the log; prints what an import found on stderr. Returns the log and the path read
    /// (a folder's log.jsonl).
    pub fn read(&self) -> anyhow::Result<(SensorLog, PathBuf)> {
        self.read_with_origin().map(|(log, path, _)| (log, path))
    }

    /// As [`LogInput::read`], and whether the log was imported from a recorded format (a ROS 1
    /// or ROS 2 bag, a CARMEN log) rather than read as this project's own `log.jsonl`.
    pub fn read_with_origin(&self) -> anyhow::Result<(SensorLog, PathBuf, bool)> {
        let Imported { log, report, path } = self.read_imported()?;
        let imported = report.is_some();
        if let Some(r) = report {
            for line in r.lines() {
                errln!("import: {line}");
            }
        }
        Ok((log, path, imported))
    }

    /// Reads the log with its import report.
    pub fn read_imported(&self) -> anyhow::Result<Imported> {
        Ok(read_log(&self.log, self.log_format, &self.options())?)
    }
}

/// Refuses a log that has scans and no odometry for a command whose localiser moves by the
/// odometry (`localise`, `update --localise`, `run --log`): every step would be skipped. The
/// error names the file and the way out, `convert --odometry-from-scans`.
pub fn require_odometry(log: &SensorLog, path: &std::path::Path) -> anyhow::Result<()> {
    let scans = log.scans().count();
    if scans > 0 && log.odometry().next().is_none() {
        anyhow::bail!(
            "{}: {scans} scans and no odometry readings: the localiser moves by the odometry; make it from the scans \
with `mapkeeper convert --log {} --odometry-from-scans --out DIR` and give --log DIR",
            path.display(),
            path.display()
        );
    }
    Ok(())
}

/// The `--localiser` value that picks the preset from the log: [`resolve_localiser`].
pub const AUTO_LOCALISER: &str = "auto";

/// `--localiser auto` is `mapkeeper-real` (the preset for real robots' logs, with the
/// scan-matching front end) for an imported log, and `mapkeeper` (tuned for the simulator's two
/// S300s) for this project's own `log.jsonl`; any other name is itself.
pub fn resolve_localiser(name: &str, imported: bool) -> &str {
    match (name, imported) {
        (AUTO_LOCALISER, true) => "mapkeeper-real",
        (AUTO_LOCALISER, false) => "mapkeeper",
        (other, _) => other,
    }
}

/// Checks a `--localiser` value before anything is read: `auto` or a known preset.
pub fn check_localiser(name: &str) -> anyhow::Result<()> {
    if name != AUTO_LOCALISER {
        use anyhow::Context;
        mapkeeper_localiser::FilterParams::preset(name).context("--localiser")?;
    }
    Ok(())
}

#[cfg(test)]
mod localiser_tests {
    use super::*;

    #[test]
    fn auto_picks_by_origin_and_names_stand() {
        assert_eq!(resolve_localiser("auto", true), "mapkeeper-real");
        assert_eq!(resolve_localiser("auto", false), "mapkeeper");
        assert_eq!(resolve_localiser("amcl", true), "amcl");
        assert_eq!(resolve_localiser("mapkeeper", true), "mapkeeper");
    }
}
