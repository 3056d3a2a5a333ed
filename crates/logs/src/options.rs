//! How a recorded log is read: which topics are the lidars, where the odometry comes from,
//! which frames are the robot's base and odometry frames, which clock stamps the messages.

/// Where the odometry comes from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum OdometryFrom {
    /// The topic `/odom` if the log has it, else the only odometry topic, else the
    /// `odom → base` transform of `/tf`.
    #[default]
    Auto,
    /// This `nav_msgs/Odometry` topic (CARMEN: `ODOM`).
    Topic(String),
    /// The `odom → base` transform of `/tf` ([`ImportOptions::odom_frame`],
    /// [`ImportOptions::base_frame`]).
    Tf,
    /// None from the log: the caller makes it by matching the scans (`mapkeeper convert
    /// --odometry-from-scans`). The assembled log has no odometry records, any odometry the file
    /// holds is left out (a note says so), and the report's odometry source says it is to be
    /// made from the scans.
    Scans,
}

/// Which kind of CARMEN log a file is: raw (the laser lines' poses and the `ODOM` lines are the
/// robot's odometry) or corrected (SLAM-corrected poses in the laser lines, raw odometry
/// re-anchored at each scan in the `ODOM` lines). See the `carmen` module.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CarmenKind {
    /// Tell from what the file holds (the import report says what it found and why).
    #[default]
    Auto,
    /// A raw log: the odometry is the `ODOM` lines as written, or, without them, the laser lines'
    /// odometry fields; no reference poses.
    Raw,
    /// A corrected log: the laser lines' poses are the reference, the odometry is re-chained
    /// from the `ODOM` lines.
    Corrected,
}

impl CarmenKind {
    /// Every kind, by its flag name.
    pub const NAMES: [(&'static str, CarmenKind); 3] =
        [("auto", CarmenKind::Auto), ("raw", CarmenKind::Raw), ("corrected", CarmenKind::Corrected)];

    /// The kind of a flag value (`auto`, `raw`, `corrected`).
    pub fn from_name(name: &str) -> Option<CarmenKind> {
        Self::NAMES.iter().find(|(n, _)| *n == name).map(|(_, k)| *k)
    }
}

/// Which clock stamps a message.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StampFrom {
    /// The message's own stamp (`header.stamp`; CARMEN's `ipc_timestamp`), as a ROS node sees it.
    #[default]
    Header,
    /// When the recorder received it (the bag's record time, MCAP `log_time`; CARMEN's
    /// `logger_timestamp`).
    Record,
}

/// Where the messages' times come from (`--time-source`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TimeSource {
    /// The stamps, unless they cannot be trusted (they repeat or step back across many messages,
    /// or are printed too coarsely to order them): then the file's order, timed as
    /// [`TimeSource::Line`] does, with a note saying why (the `timing` module).
    #[default]
    Auto,
    /// The stamps as written (a few steps back clamped, as always), even where they cannot be
    /// trusted (a note says so).
    Stamp,
    /// The file's order: a CARMEN log's lines (written in time order), timed from the printed
    /// stamps where they change or from [`ImportOptions::rate_hz`]; a bag's messages by when the
    /// recorder received them.
    Line,
}

impl TimeSource {
    /// Every source, by its flag name.
    pub const NAMES: [(&'static str, TimeSource); 3] =
        [("auto", TimeSource::Auto), ("stamp", TimeSource::Stamp), ("line", TimeSource::Line)];

    /// The source of a flag value (`auto`, `stamp`, `line`).
    pub fn from_name(name: &str) -> Option<TimeSource> {
        Self::NAMES.iter().find(|(n, _)| *n == name).map(|(_, k)| *k)
    }
}

/// Which scans of each lidar are kept (`--keep-every`, `--every-m`): for heavy logs, and to
/// test a localiser on scans further apart than the log has them. Odometry and reference poses
/// are all kept.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Thinning {
    /// Every scan.
    #[default]
    All,
    /// The first scan of each lidar and every `n`-th after it.
    KeepEvery(usize),
    /// The first scan of each lidar, then the first scan after the odometry has travelled at
    /// least this far (metres, along its path) since the last scan kept.
    EveryMetres(f64),
}

impl Thinning {
    /// The largest `--keep-every`.
    pub const MAX_KEEP_EVERY: usize = 1_000_000;
    /// The range of `--every-m`, metres.
    pub const EVERY_M_RANGE: std::ops::RangeInclusive<f64> = 0.001..=100.0;

    /// Why the value cannot be used, if it cannot (`0: expected …`).
    pub fn problem(&self) -> Option<String> {
        match *self {
            Thinning::All => None,
            Thinning::KeepEvery(n) if !(1..=Self::MAX_KEEP_EVERY).contains(&n) => {
                Some(format!("{n}: expected a whole number from 1 to {}", Self::MAX_KEEP_EVERY))
            }
            Thinning::EveryMetres(m) if !(m.is_finite() && Self::EVERY_M_RANGE.contains(&m)) => Some(format!(
                "{m}: expected metres from {} to {}",
                Self::EVERY_M_RANGE.start(),
                Self::EVERY_M_RANGE.end()
            )),
            _ => None,
        }
    }
}

/// The range of `--rate`, scans per second.
pub const RATE_HZ_RANGE: std::ops::RangeInclusive<f64> = 0.001..=1000.0;

/// How a recorded log is turned into a sensor log.
#[derive(Clone, Debug, PartialEq)]
pub struct ImportOptions {
    /// The lidars' scan topics, in lidar-id order; empty: every topic with laser scans, sorted by
    /// name.
    pub scan_topics: Vec<String>,
    /// The lidars by their scans' `frame_id` instead, in lidar-id order (for a driver that puts
    /// several lidars on one topic); when given, [`Self::scan_topics`] is not used.
    pub scan_frames: Vec<String>,
    /// The odometry.
    pub odometry: OdometryFrom,
    /// The robot's base frame (lidar mounts are found from it; `base_link`).
    pub base_frame: String,
    /// The odometry frame (`odom`).
    pub odom_frame: String,
    /// A topic of reference poses in the map frame (`nav_msgs/Odometry`,
    /// `geometry_msgs/PoseStamped` or `PoseWithCovarianceStamped`), written as truth records;
    /// `None`: no reference (CARMEN's corrected poses are always the reference).
    pub truth_topic: Option<String>,
    /// The clock.
    pub stamp: StampFrom,
    /// CARMEN logs: raw or corrected (default: told from the file).
    pub carmen_kind: CarmenKind,
    /// Read a damaged file past its damage instead of refusing it: a CARMEN log's truncated or
    /// corrupt gzip stream up to the damage; a ROS 1 bag's damaged records and chunks skipped to
    /// the next chunk that reads, a truncated bag as far as it goes. What was read is kept, and
    /// the import report's `salvaged:` notes say what was skipped. Default `false`: the damage
    /// is an error.
    pub salvage: bool,
    /// Where the times come from: the stamps unless they cannot be trusted (default), the stamps
    /// as written, or the file's order.
    pub time_source: TimeSource,
    /// The first lidar's scan rate, scans per second, for timing a log by its order when its
    /// stamps cannot (`--rate`; in [`RATE_HZ_RANGE`]); `None`: from the printed stamps where
    /// they change.
    pub rate_hz: Option<f64>,
    /// Which scans are kept.
    pub thinning: Thinning,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            scan_topics: Vec::new(),
            scan_frames: Vec::new(),
            odometry: OdometryFrom::Auto,
            base_frame: "base_link".into(),
            odom_frame: "odom".into(),
            truth_topic: None,
            stamp: StampFrom::Header,
            carmen_kind: CarmenKind::Auto,
            salvage: false,
            time_source: TimeSource::Auto,
            rate_hz: None,
            thinning: Thinning::All,
        }
    }
}
