//! The sensor log: a versioned, line-oriented JSON Lines file (see `docs/sensor-log.md`).
//!
//! Line 1 is a [`LogHeader`]; every further line is one [`LogRecord`]: a laser scan, an
//! odometry reading or a true pose, each timestamped in integer nanoseconds. Non-finite ranges
//! ("no return", NaN) are written as `null` and read back as `+inf`, since JSON has no infinity.

use crate::scan::LaserScan;
use mapkeeper_grid::{AtomicFile, Pose2};
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Read, Write};
use std::path::{Path, PathBuf};

/// The format name written in every header.
pub const LOG_FORMAT: &str = "mapkeeper-sensor-log";
/// The format version this crate writes and reads.
pub const LOG_VERSION: u32 = 1;
/// Longest line accepted, bytes (a 65,536-beam scan fits with room to spare).
pub const MAX_LINE_BYTES: usize = 4 << 20;

/// First line of a log.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LogHeader {
    /// Always [`LOG_FORMAT`].
    pub format: String,
    /// Always [`LOG_VERSION`] for this reader.
    pub version: u32,
    /// Free-form provenance (seed, world, robot, tool version), kept verbatim.
    #[serde(default)]
    pub meta: serde_json::Map<String, serde_json::Value>,
}

impl LogHeader {
    /// A header of the current format with the given provenance.
    pub fn new(meta: serde_json::Map<String, serde_json::Value>) -> Self {
        Self { format: LOG_FORMAT.to_string(), version: LOG_VERSION, meta }
    }
}

/// A wheel-odometry reading: the robot's pose integrated in the odometry frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometryReading {
    /// Time, nanoseconds since the start of the run.
    pub stamp_ns: u64,
    /// Robot base pose in the odometry frame.
    pub pose_in_odom: Pose2,
}

/// The true robot pose (from a simulator or a motion-capture system).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruePose {
    /// Time, nanoseconds since the start of the run.
    pub stamp_ns: u64,
    /// Robot base pose in the map frame.
    pub pose_in_map: Pose2,
}

/// One line of the log after the header.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LogRecord {
    /// A laser scan.
    Scan(#[serde(with = "scan_json")] LaserScan),
    /// An odometry reading.
    Odom(OdometryReading),
    /// A true pose.
    Truth(TruePose),
}

impl LogRecord {
    /// The record's timestamp, nanoseconds.
    pub fn stamp_ns(&self) -> u64 {
        match self {
            LogRecord::Scan(s) => s.stamp_ns,
            LogRecord::Odom(o) => o.stamp_ns,
            LogRecord::Truth(t) => t.stamp_ns,
        }
    }
}

/// Scans with `null` for non-finite ranges.
mod scan_json {
    use super::*;

    #[derive(Serialize, Deserialize)]
    #[serde(deny_unknown_fields)]
    struct ScanRepr {
        stamp_ns: u64,
        lidar_id: u32,
        lidar_in_robot: Pose2,
        angle_min_rad: f64,
        angle_increment_rad: f64,
        range_min_m: f32,
        range_max_m: f32,
        ranges_m: Vec<Option<f32>>,
    }

    pub fn serialize<S: serde::Serializer>(s: &LaserScan, ser: S) -> Result<S::Ok, S::Error> {
        ScanRepr {
            stamp_ns: s.stamp_ns,
            lidar_id: s.lidar_id,
            lidar_in_robot: s.lidar_in_robot,
            angle_min_rad: s.angle_min_rad,
            angle_increment_rad: s.angle_increment_rad,
            range_min_m: s.range_min_m,
            range_max_m: s.range_max_m,
            ranges_m: s.ranges_m.iter().map(|&r| r.is_finite().then_some(r)).collect(),
        }
        .serialize(ser)
    }

    pub fn deserialize<'de, D: serde::Deserializer<'de>>(de: D) -> Result<LaserScan, D::Error> {
        let r = ScanRepr::deserialize(de)?;
        Ok(LaserScan {
            stamp_ns: r.stamp_ns,
            lidar_id: r.lidar_id,
            lidar_in_robot: r.lidar_in_robot,
            angle_min_rad: r.angle_min_rad,
            angle_increment_rad: r.angle_increment_rad,
            range_min_m: r.range_min_m,
            range_max_m: r.range_max_m,
            ranges_m: r.ranges_m.into_iter().map(|r| r.unwrap_or(f32::INFINITY)).collect(),
            sweep: None,
        })
    }
}

/// What went wrong reading or writing a log. Every variant names the file; parse errors name
/// the line (1-based).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LogError {
    /// The file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A line is not valid JSON of the expected shape.
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The file is empty (no header).
    #[error("{path}: empty file, expected a '{LOG_FORMAT}' header on line 1")]
    Empty {
        /// The file.
        path: PathBuf,
    },
}

fn parse_err(path: &Path, line: usize, message: impl Into<String>) -> LogError {
    LogError::Parse { path: path.to_path_buf(), line, message: one_line(message.into()) }
}

/// `message` with control characters escaped (`\n` as the two characters `\` `n`): serde_json
/// quotes the offending key or string unescaped, and an error must stay on one line.
fn one_line(message: String) -> String {
    if !message.contains(char::is_control) {
        return message;
    }
    message.chars().map(|c| if c.is_control() { c.escape_default().to_string() } else { c.to_string() }).collect()
}

/// A whole log in memory.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorLog {
    /// The header.
    pub header: LogHeader,
    /// The records in file order (non-decreasing time per record type).
    pub records: Vec<LogRecord>,
}

impl SensorLog {
    /// Reads and validates a log: header format and version, each record's shape, each scan's
    /// header ([`LaserScan::validate`]), finite poses, and non-decreasing timestamps per record
    /// type.
    pub fn read(path: &Path) -> Result<SensorLog, LogError> {
        let file = File::open(path).map_err(|source| LogError::Io { path: path.to_path_buf(), source })?;
        SensorLog::from_reader(BufReader::new(file), path)
    }

    /// Reads and validates a log from any buffered reader, as [`SensorLog::read`] does from a
    /// file; `path` names the source in error messages only.
    ///
    /// ```
    /// use mapkeeper_sensor::SensorLog;
    /// let text = "{\"format\":\"mapkeeper-sensor-log\",\"version\":1}\nnot json\n";
    /// let e = SensorLog::from_reader(text.as_bytes(), "in-memory.jsonl".as_ref()).unwrap_err();
    /// assert!(e.to_string().starts_with("in-memory.jsonl:2:"), "{e}");
    /// ```
    pub fn from_reader<R: BufRead>(mut reader: R, path: &Path) -> Result<SensorLog, LogError> {
        let mut buf = Vec::new();
        let mut line_no = 0usize;
        let mut header = None;
        let mut records = Vec::new();
        let mut last = [0u64; 3];
        loop {
            buf.clear();
            let n = (&mut reader)
                .take(MAX_LINE_BYTES as u64 + 1)
                .read_until(b'\n', &mut buf)
                .map_err(|source| LogError::Io { path: path.to_path_buf(), source })?;
            if n == 0 {
                break;
            }
            line_no += 1;
            if buf.len() > MAX_LINE_BYTES {
                return Err(parse_err(path, line_no, format!("line longer than {MAX_LINE_BYTES} bytes")));
            }
            let text = std::str::from_utf8(&buf).map_err(|_| parse_err(path, line_no, "not UTF-8"))?;
            let text = text.trim();
            if text.is_empty() {
                continue;
            }
            if header.is_none() {
                let h: LogHeader =
                    serde_json::from_str(text).map_err(|e| parse_err(path, line_no, format!("bad header: {e}")))?;
                if h.format != LOG_FORMAT {
                    return Err(parse_err(path, line_no, format!("format is '{}', expected '{LOG_FORMAT}'", h.format)));
                }
                if h.version != LOG_VERSION {
                    return Err(parse_err(
                        path,
                        line_no,
                        format!("version {} is not supported (this reader reads version {LOG_VERSION})", h.version),
                    ));
                }
                header = Some(h);
                continue;
            }
            let rec: LogRecord = serde_json::from_str(text).map_err(|e| parse_err(path, line_no, e.to_string()))?;
            let (kind, what) = match &rec {
                LogRecord::Scan(s) => {
                    s.validate().map_err(|e| parse_err(path, line_no, format!("scan: {e}")))?;
                    (0, "scan")
                }
                LogRecord::Odom(o) => {
                    if !o.pose_in_odom.is_finite() {
                        return Err(parse_err(path, line_no, "odom: pose_in_odom is not finite"));
                    }
                    (1, "odom")
                }
                LogRecord::Truth(t) => {
                    if !t.pose_in_map.is_finite() {
                        return Err(parse_err(path, line_no, "truth: pose_in_map is not finite"));
                    }
                    (2, "truth")
                }
            };
            if rec.stamp_ns() < last[kind] {
                return Err(parse_err(
                    path,
                    line_no,
                    format!("{what} time goes backwards ({} ns after {} ns)", rec.stamp_ns(), last[kind]),
                ));
            }
            last[kind] = rec.stamp_ns();
            records.push(rec);
        }
        let header = header.ok_or_else(|| LogError::Empty { path: path.to_path_buf() })?;
        Ok(SensorLog { header, records })
    }

    /// Writes the log atomically (a temporary file in the same folder, then a rename).
    pub fn write(&self, path: &Path) -> Result<(), LogError> {
        let mut w = LogWriter::create(path, &self.header)?;
        for r in &self.records {
            w.write(r)?;
        }
        w.finish()
    }

    /// The scans, in order.
    pub fn scans(&self) -> impl Iterator<Item = &LaserScan> {
        self.records.iter().filter_map(|r| match r {
            LogRecord::Scan(s) => Some(s),
            _ => None,
        })
    }

    /// The odometry readings, in order.
    pub fn odometry(&self) -> impl Iterator<Item = &OdometryReading> {
        self.records.iter().filter_map(|r| match r {
            LogRecord::Odom(o) => Some(o),
            _ => None,
        })
    }

    /// The true poses, in order.
    pub fn truth(&self) -> impl Iterator<Item = &TruePose> {
        self.records.iter().filter_map(|r| match r {
            LogRecord::Truth(t) => Some(t),
            _ => None,
        })
    }
}

/// Streams records to a temporary file and renames it into place on [`LogWriter::finish`], so an
/// interrupted run never leaves a log that looks complete.
pub struct LogWriter {
    path: PathBuf,
    out: BufWriter<AtomicFile>,
}

impl LogWriter {
    /// Starts a log at `path` with `header`.
    pub fn create(path: &Path, header: &LogHeader) -> Result<Self, LogError> {
        let io = |source| LogError::Io { path: path.to_path_buf(), source };
        let file = AtomicFile::create(path).map_err(io)?;
        let mut w = Self { path: path.to_path_buf(), out: BufWriter::new(file) };
        w.line(header)?;
        Ok(w)
    }

    fn line<T: Serialize>(&mut self, value: &T) -> Result<(), LogError> {
        let io = |source| LogError::Io { path: self.path.clone(), source };
        serde_json::to_writer(&mut self.out, value).map_err(|e| io(std::io::Error::other(e)))?;
        self.out.write_all(b"\n").map_err(io)
    }

    /// Appends one record.
    pub fn write(&mut self, record: &LogRecord) -> Result<(), LogError> {
        self.line(record)
    }

    /// Flushes and renames the file into place.
    pub fn finish(self) -> Result<(), LogError> {
        let path = self.path;
        let io = |source| LogError::Io { path: path.clone(), source };
        let file = self.out.into_inner().map_err(|e| io(e.into_error()))?;
        file.commit().map_err(io)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmpdir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("mapkeeper-sensor-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn sample() -> SensorLog {
        let scan = LaserScan {
            stamp_ns: 80_000_000,
            lidar_id: 1,
            lidar_in_robot: Pose2::new(-0.2865, 0.2089, 2.356194490192345),
            angle_min_rad: -2.356194490192345,
            angle_increment_rad: 0.008726646259971648,
            range_min_m: 0.1,
            range_max_m: 30.0,
            ranges_m: vec![1.25, f32::INFINITY, f32::NAN, 0.0, 29.5],
            sweep: None,
        };
        let mut meta = serde_json::Map::new();
        meta.insert("seed".into(), 7.into());
        SensorLog {
            header: LogHeader::new(meta),
            records: vec![
                LogRecord::Odom(OdometryReading { stamp_ns: 0, pose_in_odom: Pose2::new(0.0, 0.0, 0.0) }),
                LogRecord::Truth(TruePose { stamp_ns: 0, pose_in_map: Pose2::new(1.0, 2.0, 0.1) }),
                LogRecord::Scan(scan),
            ],
        }
    }

    #[test]
    fn round_trip_maps_non_finite_to_inf() {
        let d = tmpdir("rt");
        let p = d.join("log.jsonl");
        let log = sample();
        log.write(&p).unwrap();
        let back = SensorLog::read(&p).unwrap();
        assert_eq!(back.header, log.header);
        assert_eq!(back.records[..2], log.records[..2]);
        let s = back.scans().next().unwrap();
        assert_eq!(s.ranges_m[0], 1.25);
        assert_eq!(s.ranges_m[1], f32::INFINITY);
        assert_eq!(s.ranges_m[2], f32::INFINITY);
        assert_eq!(s.valid_count(), 2);
        // Byte-identical on a second write.
        let p2 = d.join("log2.jsonl");
        back.write(&p2).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), std::fs::read(&p2).unwrap());
        assert!(!d.join(".log.jsonl.tmp").exists());
    }

    fn read_text(name: &str, text: &str) -> Result<SensorLog, LogError> {
        let d = tmpdir(name);
        let p = d.join("log.jsonl");
        let mut f = File::create(&p).unwrap();
        f.write_all(text.as_bytes()).unwrap();
        SensorLog::read(&p)
    }

    #[test]
    fn errors_name_the_line() {
        let h = r#"{"format":"mapkeeper-sensor-log","version":1}"#;
        let cases = [
            ("empty", String::new(), "empty file"),
            ("badfmt", r#"{"format":"other","version":1}"#.to_string(), ":1: format"),
            ("badver", r#"{"format":"mapkeeper-sensor-log","version":9}"#.to_string(), ":1: version 9"),
            ("junk", format!("{h}\nnot json\n"), ":2:"),
            ("type", format!("{h}\n{{\"type\":\"lidar\",\"stamp_ns\":0}}\n"), ":2:"),
            (
                "nanpose",
                format!(
                    "{h}\n{{\"type\":\"odom\",\"stamp_ns\":0,\"pose_in_odom\":{{\"x\":1e999,\"y\":0,\"yaw\":0}}}}\n"
                ),
                ":2:",
            ),
            (
                "back",
                format!(
                    "{h}\n{{\"type\":\"odom\",\"stamp_ns\":5,\"pose_in_odom\":{{\"x\":0,\"y\":0,\"yaw\":0}}}}\n{{\"type\":\"odom\",\"stamp_ns\":4,\"pose_in_odom\":{{\"x\":0,\"y\":0,\"yaw\":0}}}}\n"
                ),
                ":3: odom time goes backwards",
            ),
            (
                "badscan",
                format!(
                    "{h}\n{{\"type\":\"scan\",\"stamp_ns\":0,\"lidar_id\":0,\"lidar_in_robot\":{{\"x\":0,\"y\":0,\"yaw\":0}},\"angle_min_rad\":0,\"angle_increment_rad\":0,\"range_min_m\":0.1,\"range_max_m\":30,\"ranges_m\":[1]}}\n"
                ),
                ":2: scan: angle_increment",
            ),
        ];
        for (name, text, want) in cases {
            let e = read_text(name, &text).unwrap_err().to_string();
            assert!(e.contains(want), "{name}: {e}");
            assert!(e.contains("log.jsonl"), "{name}: {e}");
        }
        let missing = SensorLog::read(Path::new("/nonexistent/log.jsonl")).unwrap_err().to_string();
        assert!(missing.contains("/nonexistent/log.jsonl"));
    }
}
