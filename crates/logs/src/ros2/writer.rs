//! A run as a ROS 2 bag in MCAP storage, for Foxglove Studio and `ros2 bag`.
//!
//! Profile `ros2`; every message CDR little endian with a `ros2msg` schema holding the full
//! definitions of the types it uses; zstd-compressed chunks with message indexes and a summary
//! (statistics, chunk indexes), so a viewer can seek. Stamps are written as they are given
//! (nanoseconds from the run's start) in the headers and as `log_time` and `publish_time`.
//!
//! | topic | type | frame |
//! | --- | --- | --- |
//! | `/lidar_{id}/scan` | `sensor_msgs/msg/LaserScan` | `lidar_{id}` |
//! | `/tf_static` | `tf2_msgs/msg/TFMessage` | `base_link → lidar_{id}` (every mount so far, on each lidar's first scan) |
//! | `/odom` | `nav_msgs/msg/Odometry` | `odom`, child `base_link` |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | `odom → base_link` (odometry), `map → odom` (estimates) |
//! | `/truth` | `geometry_msgs/msg/PoseStamped` | `map` |
//! | `/estimate` | `geometry_msgs/msg/PoseWithCovarianceStamped` | `map` |
//! | `/particlecloud` | `geometry_msgs/msg/PoseArray` | `map` |
//! | `/map` | `nav_msgs/msg/OccupancyGrid` | `map` |
//! | `/updater/verdict` | `std_msgs/msg/String` | — |
//! | `/updater/step` | `mapkeeper_msgs/msg/UpdaterStep` (the definition is in the file) | — |
//! | `/updater/changes` | `nav_msgs/msg/OccupancyGrid` | `map`: the cells changed since the previous `/map`: 100 added, 0 removed, 50 free ↔ unknown, −1 unchanged |

use super::cdr::CdrWriter;
use super::schemas::{self, Def};
use mapkeeper_grid::{CellState, OccupancyGrid, Pose2};
use mapkeeper_sensor::LaserScan;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// A run could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum McapWriteError {
    /// Creating, writing or renaming the file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("{path}: writing MCAP: {source}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: mcap::McapError,
    },
    /// A value cannot be written as a ROS message.
    #[error("{path}: {topic}: {message}")]
    Value {
        /// The file.
        path: PathBuf,
        /// The topic of the message.
        topic: String,
        /// What is wrong.
        message: String,
    },
}

/// The topics of a run.
const ODOM_TOPIC: &str = "/odom";
const TF_TOPIC: &str = "/tf";
const TF_STATIC_TOPIC: &str = "/tf_static";
const TRUTH_TOPIC: &str = "/truth";
const ESTIMATE_TOPIC: &str = "/estimate";
const PARTICLES_TOPIC: &str = "/particlecloud";
const MAP_TOPIC: &str = "/map";
const VERDICT_TOPIC: &str = "/updater/verdict";
const STEP_TOPIC: &str = "/updater/step";
const CHANGES_TOPIC: &str = "/updater/changes";

/// The values of `/updater/changes`: a cell that became occupied.
pub const CHANGE_ADDED: i8 = 100;
/// A cell that was occupied and is no longer.
pub const CHANGE_REMOVED: i8 = 0;
/// A cell that changed between free and unknown.
pub const CHANGE_OTHER: i8 = 50;
/// A cell that did not change.
pub const CHANGE_NONE: i8 = -1;

/// One step of the map updater, as `/updater/step` carries it
/// (`mapkeeper_msgs/msg/UpdaterStep`; field meanings in its definition).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UpdaterStepMsg {
    /// The verdict acted on (`update`, `suspend`, `lost`; empty: not checked).
    pub verdict: String,
    /// The paper's localisation check alone.
    pub check_verdict: String,
    /// What happened to the step (`processed`, `gated`, …).
    pub outcome: String,
    /// Valid beams.
    pub valid_beams: u32,
    /// Detected-change beams.
    pub detected_change_beams: u32,
    /// Cells that became occupied.
    pub cells_added: u32,
    /// Cells that stopped being occupied.
    pub cells_removed: u32,
    /// Cells that changed between free and unknown.
    pub cells_other: u32,
    /// Registration's correction `(accepted, shift m, turn rad)`, when it ran.
    pub registration: Option<(bool, f64, f64)>,
    /// Pose updating's outcome (empty: no attempt; `recovered`; `recovered_global`, a pose of the
    /// global search; or why it refused).
    pub pose_recovery: String,
}

/// Writes a run as an MCAP file (see the module docs for its topics).
///
/// The file is written beside its final name and renamed there by [`McapRunWriter::finish`];
/// a writer dropped without `finish` removes it.
pub struct McapRunWriter {
    path: PathBuf,
    temp: PathBuf,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    schemas: HashMap<&'static str, u16>,
    /// Topic → (channel id, next sequence number).
    channels: BTreeMap<String, (u16, u32)>,
    /// The mounts published on `/tf_static`, by lidar id.
    mounts: BTreeMap<u32, Pose2>,
    /// Whether the file has its final name.
    renamed: bool,
}

impl std::fmt::Debug for McapRunWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRunWriter").field("path", &self.path).field("topics", &self.channels).finish()
    }
}

impl McapRunWriter {
    /// Starts the run file `path` (written as a temporary file beside it until
    /// [`McapRunWriter::finish`]).
    pub fn create(path: &Path) -> Result<Self, McapWriteError> {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let temp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
        let file = File::create(&temp).map_err(|source| McapWriteError::Io { path: path.to_path_buf(), source })?;
        let options = mcap::WriteOptions::new()
            .profile("ros2")
            .library(format!("mapkeeper-logs {} (mcap-rust {})", env!("CARGO_PKG_VERSION"), mcap::VERSION))
            .compression(Some(mcap::Compression::Zstd))
            // One compression thread: the output is the same on every machine.
            .compression_threads(0);
        let writer = options
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|source| McapWriteError::Mcap { path: path.to_path_buf(), source })?;
        Ok(Self {
            path: path.to_path_buf(),
            temp,
            writer: Some(writer),
            schemas: HashMap::new(),
            channels: BTreeMap::new(),
            mounts: BTreeMap::new(),
            renamed: false,
        })
    }

    /// A scan on `/lidar_{id}/scan` in frame `lidar_{id}`; on a lidar's first scan, its mount
    /// on `/tf_static` (`base_link → lidar_{id}`, with the mounts of the lidars seen before).
    pub fn scan(&mut self, scan: &LaserScan) -> Result<(), McapWriteError> {
        let topic = format!("/lidar_{}/scan", scan.lidar_id);
        let frame = format!("lidar_{}", scan.lidar_id);
        if let std::collections::btree_map::Entry::Vacant(e) = self.mounts.entry(scan.lidar_id) {
            e.insert(scan.lidar_in_robot);
            let mounts: Vec<(String, String, Pose2)> =
                self.mounts.iter().map(|(id, m)| ("base_link".to_string(), format!("lidar_{id}"), *m)).collect();
            let data = self.tf_message(TF_STATIC_TOPIC, scan.stamp_ns, &mounts)?;
            self.write(TF_STATIC_TOPIC, &schemas::TF_MESSAGE, scan.stamp_ns, &data)?;
        }
        let mut w = CdrWriter::little_endian();
        self.header(&mut w, &topic, scan.stamp_ns, &frame)?;
        let n = scan.ranges_m.len();
        let angle_max = scan.angle_min_rad + scan.angle_increment_rad * n.saturating_sub(1) as f64;
        w.f32(scan.angle_min_rad as f32);
        w.f32(angle_max as f32);
        w.f32(scan.angle_increment_rad as f32);
        // ROS stamps a scan at its first beam: a timing stamped elsewhere (the simulator's, at
        // the last beam) is written as unknown rather than shifting the stamp.
        let ros_timing = scan.sweep.filter(|t| t.first_beam_s == 0.0);
        w.f32(ros_timing.map_or(0.0, |t| t.time_increment_s as f32)); // time_increment (0: unknown)
        w.f32(0.0); // scan_time: unknown
        w.f32(scan.range_min_m);
        // ROS's range_max is inclusive; the scan's limit is not.
        w.f32(scan.range_max_m.next_down());
        w.f32_seq(&scan.ranges_m);
        w.f32_seq(&[]);
        let data = self.done(w, &topic)?;
        self.write(&topic, &schemas::LASER_SCAN, scan.stamp_ns, &data)
    }

    /// The odometry: `/odom` (`odom`, child `base_link`) and the same transform on `/tf`.
    pub fn odometry(&mut self, stamp_ns: u64, pose_in_odom: Pose2) -> Result<(), McapWriteError> {
        let mut w = CdrWriter::little_endian();
        self.header(&mut w, ODOM_TOPIC, stamp_ns, "odom")?;
        w.string("base_link");
        pose(&mut w, &pose_in_odom);
        covariance(&mut w, None);
        for _ in 0..6 {
            w.f64(0.0); // twist: not known
        }
        covariance(&mut w, None);
        let data = self.done(w, ODOM_TOPIC)?;
        self.write(ODOM_TOPIC, &schemas::ODOMETRY, stamp_ns, &data)?;
        let data = self.tf_message(TF_TOPIC, stamp_ns, &[("odom".into(), "base_link".into(), pose_in_odom)])?;
        self.write(TF_TOPIC, &schemas::TF_MESSAGE, stamp_ns, &data)
    }

    /// The true pose on `/truth` (frame `map`).
    pub fn true_pose(&mut self, stamp_ns: u64, pose_in_map: Pose2) -> Result<(), McapWriteError> {
        let mut w = CdrWriter::little_endian();
        self.header(&mut w, TRUTH_TOPIC, stamp_ns, "map")?;
        pose(&mut w, &pose_in_map);
        let data = self.done(w, TRUTH_TOPIC)?;
        self.write(TRUTH_TOPIC, &schemas::POSE_STAMPED, stamp_ns, &data)
    }

    /// The localiser's estimate on `/estimate` (frame `map`; the 6×6 covariance holds the x, y,
    /// yaw one given, zeros without); with the odometry pose of the same instant, also the
    /// `map → odom` transform on `/tf` (`estimate ∘ odometry⁻¹`), so the scans show in the map.
    pub fn estimate(
        &mut self,
        stamp_ns: u64,
        pose_in_map: Pose2,
        covariance_xy_yaw: Option<[[f64; 3]; 3]>,
        pose_in_odom: Option<Pose2>,
    ) -> Result<(), McapWriteError> {
        let mut w = CdrWriter::little_endian();
        self.header(&mut w, ESTIMATE_TOPIC, stamp_ns, "map")?;
        pose(&mut w, &pose_in_map);
        covariance(&mut w, covariance_xy_yaw.as_ref());
        let data = self.done(w, ESTIMATE_TOPIC)?;
        self.write(ESTIMATE_TOPIC, &schemas::POSE_WITH_COVARIANCE_STAMPED, stamp_ns, &data)?;
        if let Some(odom) = pose_in_odom {
            let map_to_odom = pose_in_map.compose(&odom.inverse());
            let data = self.tf_message(TF_TOPIC, stamp_ns, &[("map".into(), "odom".into(), map_to_odom)])?;
            self.write(TF_TOPIC, &schemas::TF_MESSAGE, stamp_ns, &data)?;
        }
        Ok(())
    }

    /// The particles on `/particlecloud` (frame `map`).
    pub fn particles(&mut self, stamp_ns: u64, poses: &[Pose2]) -> Result<(), McapWriteError> {
        let mut w = CdrWriter::little_endian();
        self.header(&mut w, PARTICLES_TOPIC, stamp_ns, "map")?;
        w.length(poses.len(), "poses");
        for p in poses {
            pose(&mut w, p);
        }
        let data = self.done(w, PARTICLES_TOPIC)?;
        self.write(PARTICLES_TOPIC, &schemas::POSE_ARRAY, stamp_ns, &data)
    }

    /// A map on `/map` (frame `map`): 0 free, 100 occupied, −1 unknown, rows from the bottom
    /// as the grid's, its origin the grid's.
    pub fn map(&mut self, stamp_ns: u64, map: &OccupancyGrid) -> Result<(), McapWriteError> {
        let cells: Vec<u8> = map
            .cells()
            .iter()
            .map(|c| match c {
                CellState::Free => 0u8,
                CellState::Occupied => 100,
                CellState::Unknown => (-1i8).to_le_bytes()[0],
            })
            .collect();
        self.grid(MAP_TOPIC, stamp_ns, map.geometry(), &cells)
    }

    /// What the updater did with a step, on `/updater/step`.
    pub fn updater_step(&mut self, stamp_ns: u64, m: &UpdaterStepMsg) -> Result<(), McapWriteError> {
        let mut w = CdrWriter::little_endian();
        self.header(&mut w, STEP_TOPIC, stamp_ns, "")?;
        w.string(&m.verdict);
        w.string(&m.check_verdict);
        w.string(&m.outcome);
        w.u32(m.valid_beams);
        w.u32(m.detected_change_beams);
        let share =
            if m.valid_beams == 0 { 0.0 } else { f64::from(m.detected_change_beams) / f64::from(m.valid_beams) };
        w.f64(share);
        w.u32(m.cells_added);
        w.u32(m.cells_removed);
        w.u32(m.cells_other);
        let (ran, (accepted, shift, turn)) = (m.registration.is_some(), m.registration.unwrap_or((false, 0.0, 0.0)));
        w.u8(u8::from(ran));
        w.u8(u8::from(accepted));
        w.f64(shift);
        w.f64(turn.to_degrees());
        w.string(&m.pose_recovery);
        let data = self.done(w, STEP_TOPIC)?;
        self.write(STEP_TOPIC, &schemas::UPDATER_STEP, stamp_ns, &data)
    }

    /// The cells changed since the last call, on `/updater/changes` (frame `map`): a grid of
    /// `geometry`'s shape holding [`CHANGE_ADDED`], [`CHANGE_REMOVED`], [`CHANGE_OTHER`] or
    /// [`CHANGE_NONE`] per cell (`values`, row-major from the bottom row as the grid's).
    pub fn changes(
        &mut self,
        stamp_ns: u64,
        geometry: &mapkeeper_grid::GridGeometry,
        values: &[i8],
    ) -> Result<(), McapWriteError> {
        if values.len() != geometry.width() * geometry.height() {
            return Err(self.value(
                CHANGES_TOPIC,
                format!("{} values for a {} × {} grid", values.len(), geometry.width(), geometry.height()),
            ));
        }
        let bytes: Vec<u8> = values.iter().map(|v| v.to_le_bytes()[0]).collect();
        self.grid(CHANGES_TOPIC, stamp_ns, geometry, &bytes)
    }

    /// An `OccupancyGrid` message of `geometry`'s shape with these cell bytes on `topic`.
    fn grid(
        &mut self,
        topic: &str,
        stamp_ns: u64,
        g: &mapkeeper_grid::GridGeometry,
        cells: &[u8],
    ) -> Result<(), McapWriteError> {
        let size = |n: usize, what: &str| {
            u32::try_from(n).map_err(|_| self.value(topic, format!("a {what} of {n} cells does not fit")))
        };
        let (width, height) = (size(g.width(), "width")?, size(g.height(), "height")?);
        let mut w = CdrWriter::little_endian();
        self.header(&mut w, topic, stamp_ns, "map")?;
        self.time(&mut w, topic, stamp_ns)?; // map_load_time
        w.f32(g.resolution_m() as f32);
        w.u32(width);
        w.u32(height);
        pose(&mut w, &g.origin());
        w.byte_seq(cells);
        let data = self.done(w, topic)?;
        self.write(topic, &schemas::OCCUPANCY_GRID, stamp_ns, &data)
    }

    /// The updater's verdict on `/updater/verdict`.
    pub fn verdict(&mut self, stamp_ns: u64, verdict: &str) -> Result<(), McapWriteError> {
        let mut w = CdrWriter::little_endian();
        w.string(verdict);
        let data = self.done(w, VERDICT_TOPIC)?;
        self.write(VERDICT_TOPIC, &schemas::STRING, stamp_ns, &data)
    }

    /// Writes the summary, closes the file and renames it to its name; returns the name.
    pub fn finish(mut self) -> Result<PathBuf, McapWriteError> {
        let Some(mut writer) = self.writer.take() else {
            return Err(self.io(std::io::Error::other("the writer was already closed")));
        };
        writer.finish().map_err(|source| McapWriteError::Mcap { path: self.path.clone(), source })?;
        let file = writer.into_inner().into_inner().map_err(|e| self.io(e.into_error()))?;
        file.sync_all().map_err(|e| self.io(e))?;
        drop(file);
        std::fs::rename(&self.temp, &self.path).map_err(|e| self.io(e))?;
        self.renamed = true;
        Ok(self.path.clone())
    }

    fn io(&self, source: std::io::Error) -> McapWriteError {
        McapWriteError::Io { path: self.path.clone(), source }
    }

    fn value(&self, topic: &str, message: String) -> McapWriteError {
        McapWriteError::Value { path: self.path.clone(), topic: topic.to_string(), message }
    }

    /// The bytes of a message, or the length that did not fit.
    fn done(&self, w: CdrWriter, topic: &str) -> Result<Vec<u8>, McapWriteError> {
        w.finish().map_err(|e| self.value(topic, e.message))
    }

    /// `builtin_interfaces/Time` of a stamp (seconds must fit an `int32`: up to 2³¹ s).
    fn time(&self, w: &mut CdrWriter, topic: &str, stamp_ns: u64) -> Result<(), McapWriteError> {
        let sec = i32::try_from(stamp_ns / 1_000_000_000)
            .map_err(|_| self.value(topic, format!("stamp {stamp_ns} ns does not fit a ROS time (int32 seconds)")))?;
        w.i32(sec);
        w.u32((stamp_ns % 1_000_000_000) as u32);
        Ok(())
    }

    /// `std_msgs/Header`.
    fn header(&self, w: &mut CdrWriter, topic: &str, stamp_ns: u64, frame: &str) -> Result<(), McapWriteError> {
        self.time(w, topic, stamp_ns)?;
        w.string(frame);
        Ok(())
    }

    /// A `tf2_msgs/TFMessage` of planar (parent, child, child in parent) transforms.
    fn tf_message(
        &self,
        topic: &str,
        stamp_ns: u64,
        transforms: &[(String, String, Pose2)],
    ) -> Result<Vec<u8>, McapWriteError> {
        let mut w = CdrWriter::little_endian();
        w.length(transforms.len(), "transforms");
        for (parent, child, p) in transforms {
            self.header(&mut w, topic, stamp_ns, parent)?;
            w.string(child);
            pose(&mut w, p); // Transform: Vector3 translation, Quaternion rotation: as a Pose.
        }
        self.done(w, topic)
    }

    /// Writes one message on `topic`, adding its schema and channel the first time.
    fn write(&mut self, topic: &str, def: &'static Def, stamp_ns: u64, data: &[u8]) -> Result<(), McapWriteError> {
        let path = self.path.clone();
        let mcap_err = |source: mcap::McapError| McapWriteError::Mcap { path: path.clone(), source };
        let Some(writer) = self.writer.as_mut() else {
            return Err(McapWriteError::Io { path: path.clone(), source: std::io::Error::other("writer closed") });
        };
        let schema_id = match self.schemas.get(def.name) {
            Some(id) => *id,
            None => {
                let text = def.schema_text();
                let id = writer.add_schema(&def.schema_name(), "ros2msg", text.as_bytes()).map_err(mcap_err)?;
                self.schemas.insert(def.name, id);
                id
            }
        };
        if !self.channels.contains_key(topic) {
            // As rosbag2 and rosbags write it; empty: the players' default QoS.
            let metadata = BTreeMap::from([("offered_qos_profiles".to_string(), String::new())]);
            let id = writer.add_channel(schema_id, topic, "cdr", &metadata).map_err(mcap_err)?;
            self.channels.insert(topic.to_string(), (id, 0));
        }
        let Some((channel_id, sequence)) = self.channels.get_mut(topic) else {
            return Ok(());
        };
        let header = mcap::records::MessageHeader {
            channel_id: *channel_id,
            sequence: *sequence,
            log_time: stamp_ns,
            publish_time: stamp_ns,
        };
        *sequence = sequence.wrapping_add(1);
        writer.write_to_known_channel(&header, data).map_err(mcap_err)
    }
}

impl Drop for McapRunWriter {
    fn drop(&mut self) {
        // Not finished (or finishing failed): the partial file goes.
        if let Some(writer) = self.writer.take() {
            drop(writer.into_inner());
        }
        if !self.renamed {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// `geometry_msgs/Pose` (or `Transform`) of a planar pose: z 0, a rotation about z.
fn pose(w: &mut CdrWriter, p: &Pose2) {
    let (s, c) = (p.yaw / 2.0).sin_cos();
    for v in [p.x, p.y, 0.0, 0.0, 0.0, s, c] {
        w.f64(v);
    }
}

/// A 6×6 covariance (x, y, z, roll, pitch, yaw; row-major) from an x, y, yaw one, zeros
/// without.
fn covariance(w: &mut CdrWriter, c: Option<&[[f64; 3]; 3]>) {
    const AXIS: [usize; 3] = [0, 1, 5];
    let mut full = [0.0; 36];
    if let Some(c) = c {
        for (i, row) in c.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                full[AXIS[i] * 6 + AXIS[j]] = *v;
            }
        }
    }
    for v in full {
        w.f64(v);
    }
}

/// Writes a whole sensor log as a ROS 2 MCAP bag (`/lidar_{id}/scan`, `/tf_static`, `/odom`,
/// `/tf`, and `/truth` for truth records), in the log's record order; returns the file written.
pub fn write_log_mcap(log: &mapkeeper_sensor::SensorLog, path: &Path) -> Result<PathBuf, McapWriteError> {
    let mut w = McapRunWriter::create(path)?;
    for r in &log.records {
        match r {
            mapkeeper_sensor::LogRecord::Scan(s) => w.scan(s)?,
            mapkeeper_sensor::LogRecord::Odom(o) => w.odometry(o.stamp_ns, o.pose_in_odom)?,
            mapkeeper_sensor::LogRecord::Truth(t) => w.true_pose(t.stamp_ns, t.pose_in_map)?,
        }
    }
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::cdr::CdrReader;
    use mapkeeper_grid::GridGeometry;

    /// Every message of `path` as (topic, schema name, schema text, data).
    fn messages(path: &Path) -> Vec<(String, String, String, Vec<u8>)> {
        let bytes = std::fs::read(path).unwrap();
        mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                let s = m.channel.schema.as_ref().unwrap();
                (m.channel.topic.clone(), s.name.clone(), String::from_utf8(s.data.to_vec()).unwrap(), m.data.to_vec())
            })
            .collect()
    }

    #[test]
    fn updater_steps_and_changes_read_back() {
        let dir = std::env::temp_dir().join(format!("mapkeeper-writer-steps-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("steps.mcap");
        let g = GridGeometry::new(3, 2, 0.05, Pose2::new(1.0, 2.0, 0.0)).unwrap();
        let mut w = McapRunWriter::create(&path).unwrap();
        let step = UpdaterStepMsg {
            verdict: "update".into(),
            check_verdict: "suspend".into(),
            outcome: "processed".into(),
            valid_beams: 400,
            detected_change_beams: 100,
            cells_added: 2,
            cells_removed: 1,
            cells_other: 0,
            registration: Some((true, 0.03, 0.01)),
            pose_recovery: String::new(),
        };
        w.updater_step(1_500_000_000, &step).unwrap();
        let values = [CHANGE_NONE, CHANGE_ADDED, CHANGE_REMOVED, CHANGE_OTHER, CHANGE_NONE, CHANGE_NONE];
        w.changes(2_000_000_000, &g, &values).unwrap();
        // A layer of the wrong size is refused, naming the topic.
        let e = w.changes(2_000_000_000, &g, &values[..5]).unwrap_err().to_string();
        assert!(e.contains("/updater/changes") && e.contains("5 values for a 3 × 2 grid"), "{e}");
        w.finish().unwrap();

        let msgs = messages(&path);
        assert_eq!(msgs.len(), 2);
        let (topic, schema, text, data) = &msgs[0];
        assert_eq!((topic.as_str(), schema.as_str()), ("/updater/step", "mapkeeper_msgs/msg/UpdaterStep"));
        assert!(text.contains("string check_verdict") && text.contains("MSG: std_msgs/Header"), "{text}");
        let mut r = CdrReader::new(data).unwrap();
        assert_eq!((r.i32("sec").unwrap(), r.u32("nanosec").unwrap()), (1, 500_000_000));
        assert_eq!(r.string("frame").unwrap(), "");
        for want in ["update", "suspend", "processed"] {
            assert_eq!(r.string("s").unwrap(), want);
        }
        assert_eq!((r.u32("n").unwrap(), r.u32("dc").unwrap()), (400, 100));
        assert_eq!(r.f64("share").unwrap(), 0.25);
        assert_eq!([r.u32("a").unwrap(), r.u32("r").unwrap(), r.u32("o").unwrap()], [2, 1, 0]);
        assert_eq!((r.u8("ran").unwrap(), r.u8("ok").unwrap()), (1, 1));
        assert_eq!(r.f64("shift").unwrap(), 0.03);
        assert!((r.f64("turn").unwrap() - 0.01f64.to_degrees()).abs() < 1e-12);
        assert_eq!(r.string("recovery").unwrap(), "");
        assert_eq!(r.remaining(), 0, "nothing after the last field");

        let (topic, schema, _, data) = &msgs[1];
        assert_eq!((topic.as_str(), schema.as_str()), ("/updater/changes", "nav_msgs/msg/OccupancyGrid"));
        let mut r = CdrReader::new(data).unwrap();
        assert_eq!(r.i32("sec").unwrap(), 2);
        r.u32("nanosec").unwrap();
        assert_eq!(r.string("frame").unwrap(), "map");
        r.i32("load sec").unwrap();
        r.u32("load nanosec").unwrap();
        assert_eq!(r.f32("resolution").unwrap(), 0.05);
        assert_eq!((r.u32("w").unwrap(), r.u32("h").unwrap()), (3, 2));
        let origin: [f64; 7] = r.f64_array("origin").unwrap();
        assert_eq!((origin[0], origin[1]), (1.0, 2.0));
        let n = r.sequence_len(1, 1, "data").unwrap();
        let cells: Vec<i8> = (0..n).map(|_| r.i8("cell").unwrap()).collect();
        assert_eq!(cells, values);
        std::fs::remove_dir_all(&dir).ok();
    }
}
