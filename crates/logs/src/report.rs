//! What an import found: the lidars, the odometry, the reference, every topic, and the
//! timestamps that stepped back. Printed by the CLI and kept in the sensor log's header `meta`.

use mapkeeper_grid::Pose2;
use mapkeeper_sensor::LogHeader;
use serde::Serialize;
use std::collections::BTreeMap;

/// Messages of one topic of the file.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TopicCount {
    /// The message type (`sensor_msgs/msg/LaserScan`, `FLASER`).
    pub type_name: String,
    /// How many.
    pub messages: usize,
}

/// One lidar of the imported log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LidarInfo {
    /// Its `lidar_id` in the sensor log.
    pub id: u32,
    /// Its topic.
    pub topic: String,
    /// Its frame.
    pub frame_id: String,
    /// Its mount in the base frame, projected on the plane.
    pub mount: Pose2,
    /// Where the mount comes from.
    pub mount_source: String,
    /// Whether it is mounted upside down (its scans mirrored: angles negated).
    pub mirrored: bool,
    /// Its tilt from level, degrees (the projection ignores it).
    pub tilt_deg: f64,
    /// Its scans.
    pub scans: usize,
    /// Beams of its first scan.
    pub beams: usize,
}

/// Timestamps of one stream that stepped back: each is replaced by 1 ns after the stamp before it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BackwardSteps {
    /// The stream (topic).
    pub stream: String,
    /// How many stamps stepped back.
    pub count: usize,
    /// The largest step back, seconds.
    pub largest_s: f64,
}

/// How the odometry was made by matching the scans (`mapkeeper convert --odometry-from-scans`),
/// for a log that has scans and no odometry. Each step (the scans of one stamp) gives one
/// reading: the match's pose where it was accepted, the constant-velocity prediction where not.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ScanOdometrySummary {
    /// The method, in a sentence (with its main parameters).
    pub method: String,
    /// Steps, one odometry reading each.
    pub steps: usize,
    /// Steps whose match was accepted.
    pub matched: usize,
    /// Steps whose match was refused (too few beams fit the local map): the prediction stands.
    pub refused: usize,
    /// Steps without a usable beam (all readings invalid or beyond the range used): the
    /// prediction stands.
    pub without_beams: usize,
    /// Times the local map was started afresh, from the prediction, after refused matches in a
    /// row.
    pub restarts: usize,
    /// The odometry's path length, metres.
    pub path_m: f64,
}

impl ScanOdometrySummary {
    /// One line for a terminal.
    pub fn line(&self) -> String {
        format!(
            "odometry made by scan matching: {} steps, {} matched, {} refused (prediction kept), {} without usable beams, \
{} local-map restart(s), {:.1} m of path",
            self.steps, self.matched, self.refused, self.without_beams, self.restarts, self.path_m
        )
    }
}

/// What an import found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ImportReport {
    /// The file read.
    pub source: String,
    /// Its format.
    pub format: String,
    /// The log's first stamp on its own clock, nanoseconds: every stamp of the sensor log is
    /// relative to it.
    pub epoch_ns: u64,
    /// From the first to the last record, seconds.
    pub duration_s: f64,
    /// Scans imported, all lidars.
    pub scans: usize,
    /// Where the odometry came from.
    pub odometry_source: String,
    /// Odometry readings imported.
    pub odometry_messages: usize,
    /// How the odometry was made from the scans, when it was (`--odometry-from-scans`; absent
    /// from `import.json` otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scan_odometry: Option<ScanOdometrySummary>,
    /// Where the reference poses came from, if any.
    pub truth_source: Option<String>,
    /// Reference poses imported.
    pub truth_poses: usize,
    /// The lidars.
    pub lidars: Vec<LidarInfo>,
    /// Streams whose timestamps stepped back (each moved to 1 ns after the stamp before).
    pub backward_steps: Vec<BackwardSteps>,
    /// Every topic of the file with its type and message count.
    pub topics: BTreeMap<String, TopicCount>,
    /// Anything else worth knowing (messages skipped, fields ignored).
    pub notes: Vec<String>,
}

impl ImportReport {
    /// The odometry source named when it is made by matching the scans.
    pub const SCAN_ODOMETRY_SOURCE: &'static str = "scan matching (--odometry-from-scans)";

    /// Records odometry made from the scans: the source, the reading count and how it went.
    pub fn set_scan_odometry(&mut self, summary: ScanOdometrySummary) {
        self.odometry_source = Self::SCAN_ODOMETRY_SOURCE.to_string();
        self.odometry_messages = summary.steps;
        self.scan_odometry = Some(summary);
    }

    /// The sensor log's header for this import: the report as its `meta`, with the tool's name
    /// and version.
    pub fn log_header(&self) -> LogHeader {
        let meta = match serde_json::to_value(self) {
            Ok(serde_json::Value::Object(mut m)) => {
                m.insert("tool".into(), format!("mapkeeper-logs {}", env!("CARGO_PKG_VERSION")).into());
                m
            }
            _ => serde_json::Map::new(),
        };
        LogHeader::new(meta)
    }

    /// A few lines for a terminal.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![format!(
            "{} ({}): {} scans from {} lidar(s), {} odometry readings from {}, {:.1} s",
            self.source,
            self.format,
            self.scans,
            self.lidars.len(),
            self.odometry_messages,
            self.odometry_source,
            self.duration_s
        )];
        for l in &self.lidars {
            out.push(format!(
                "  lidar {}: {} (frame {}), {} scans of {} beams, mount ({:.3}, {:.3}, {:.3} rad){}{} from {}",
                l.id,
                l.topic,
                l.frame_id,
                l.scans,
                l.beams,
                l.mount.x,
                l.mount.y,
                l.mount.yaw,
                if l.mirrored { ", upside down (mirrored)" } else { "" },
                if l.tilt_deg > 2.0 { format!(", tilted {:.1} deg (ignored)", l.tilt_deg) } else { String::new() },
                l.mount_source
            ));
        }
        if let Some(s) = &self.scan_odometry {
            out.push(format!("  {}", s.line()));
        }
        if let Some(t) = &self.truth_source {
            out.push(format!("  reference: {} poses from {t}", self.truth_poses));
        }
        for b in &self.backward_steps {
            out.push(format!(
                "  {}: {} timestamps step back (largest {:.3} s), each moved to 1 ns after the one before",
                b.stream, b.count, b.largest_s
            ));
        }
        out.extend(self.notes.iter().map(|n| format!("  note: {n}")));
        out
    }
}
