//! ROS 2 MCAP bags: the run writer read back by the reader, a bag built here with the `mcap`
//! crate's own writer and hand-encoded CDR (as another recorder would write it), and bad files.
#![allow(clippy::unwrap_used)]

use mapkeeper_grid::{CellCoord, CellState, GridGeometry, OccupancyGrid, Pose2, angle_diff};
use mapkeeper_logs::{ImportError, ImportOptions, LogFormat, McapRunWriter, StampFrom, detect_format, read_log, ros2};
use mapkeeper_sensor::{LaserScan, SensorLog, SweepTiming};
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-mcap-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn truth_options() -> ImportOptions {
    ImportOptions { truth_topic: Some("/truth".into()), ..ImportOptions::default() }
}

// ---------------------------------------------------------------------------------------------
// The run writer, read back.

/// What a run wrote, to compare with what is read back.
#[derive(Default)]
struct Run {
    scans: Vec<LaserScan>,
    odometry: Vec<(u64, Pose2)>,
    truth: Vec<(u64, Pose2)>,
}

const MS: u64 = 1_000_000;

fn lidar_scan(id: u32, k: u64) -> LaserScan {
    let n = 90;
    let mut ranges: Vec<f32> = (0..n).map(|i| 1.0 + 0.01 * i as f32 + 0.1 * k as f32).collect();
    ranges[7] = f32::INFINITY; // no return
    ranges[8] = 25.0; // beyond the maximum
    if id == 0 {
        LaserScan {
            stamp_ns: k * 100 * MS + 10 * MS,
            lidar_id: 0,
            lidar_in_robot: Pose2::new(0.3, 0.0, 0.0),
            angle_min_rad: -PI / 2.0,
            angle_increment_rad: PI / 180.0,
            range_min_m: 0.05,
            range_max_m: 20.0,
            ranges_m: ranges,
            sweep: None,
        }
    } else {
        // Upside down: the beams turn clockwise (a negative increment), facing back.
        LaserScan {
            stamp_ns: k * 100 * MS + 20 * MS,
            lidar_id: 1,
            lidar_in_robot: Pose2::new(-0.25, 0.1, PI),
            angle_min_rad: 1.2,
            angle_increment_rad: -0.02,
            range_min_m: 0.1,
            range_max_m: 12.5,
            ranges_m: ranges,
            sweep: None,
        }
    }
}

fn test_map() -> OccupancyGrid {
    let g = GridGeometry::new(5, 3, 0.05, Pose2::new(-1.0, -2.0, 0.0)).unwrap();
    let mut map = OccupancyGrid::filled(g, CellState::Free);
    map.set(CellCoord::new(1, 0), CellState::Occupied);
    map.set(CellCoord::new(4, 2), CellState::Unknown);
    map
}

/// Writes steps `from..to` of a run to `path`.
fn write_run(path: &Path, from: u64, to: u64, run: &mut Run) -> PathBuf {
    let mut w = McapRunWriter::create(path).unwrap();
    for k in from..to {
        let t = k * 100 * MS;
        let odom = Pose2::new(0.1 * k as f64, 0.02 * k as f64, 0.05 * k as f64);
        let truth = Pose2::new(1.0 + 0.1 * k as f64, 2.0, 0.3 + 0.05 * k as f64);
        w.odometry(t, odom).unwrap();
        w.true_pose(t, truth).unwrap();
        run.odometry.push((t, odom));
        run.truth.push((t, truth));
        for id in [0, 1] {
            let s = lidar_scan(id, k);
            w.scan(&s).unwrap();
            run.scans.push(s);
        }
        let cov = [[0.01, 0.001, 0.0], [0.001, 0.02, 0.0], [0.0, 0.0, 0.003]];
        w.estimate(t + 30 * MS, truth, Some(cov), Some(odom)).unwrap();
        w.particles(t + 30 * MS, &[truth, odom, Pose2::IDENTITY]).unwrap();
        if k == 5 {
            w.map(t + 40 * MS, &test_map()).unwrap();
        }
        if k % 10 == 9 {
            w.verdict(t + 50 * MS, "accepted").unwrap();
        }
    }
    w.finish().unwrap()
}

fn assert_same_run(log: &SensorLog, run: &Run) {
    let scans: Vec<&LaserScan> = log.scans().collect();
    assert_eq!(scans.len(), run.scans.len());
    for (got, want) in scans.iter().zip(&run.scans) {
        assert_eq!((got.stamp_ns, got.lidar_id), (want.stamp_ns, want.lidar_id));
        // Angles travel as float32, as in ROS.
        assert_eq!(got.angle_min_rad, f64::from(want.angle_min_rad as f32));
        assert_eq!(got.angle_increment_rad, f64::from(want.angle_increment_rad as f32));
        assert_eq!((got.range_min_m, got.range_max_m), (want.range_min_m, want.range_max_m));
        assert_eq!(got.ranges_m.len(), want.ranges_m.len());
        assert!(got.ranges_m.iter().zip(&want.ranges_m).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(got.valid_count(), want.valid_count());
        let (m, w) = (got.lidar_in_robot, want.lidar_in_robot);
        assert!((m.x - w.x).abs() < 1e-15 && (m.y - w.y).abs() < 1e-15, "{m:?} {w:?}");
        assert!(angle_diff(m.yaw, w.yaw).abs() < 1e-12, "{m:?} {w:?}");
    }
    let check = |got: Vec<(u64, Pose2)>, want: &[(u64, Pose2)]| {
        assert_eq!(got.len(), want.len());
        for ((t, p), (u, q)) in got.iter().zip(want) {
            assert_eq!(t, u);
            assert!(p.x == q.x && p.y == q.y && angle_diff(p.yaw, q.yaw).abs() < 1e-12, "{p:?} {q:?}");
        }
    };
    check(log.odometry().map(|o| (o.stamp_ns, o.pose_in_odom)).collect(), &run.odometry);
    check(log.truth().map(|o| (o.stamp_ns, o.pose_in_map)).collect(), &run.truth);
}

#[test]
fn a_written_run_reads_back_the_same() {
    let dir = temp_dir("roundtrip");
    let mut run = Run::default();
    let path = write_run(&dir.join("run.mcap"), 0, 20, &mut run);
    assert_eq!(path, dir.join("run.mcap"));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "no temporary file is left");
    assert_eq!(detect_format(&path).unwrap(), LogFormat::Mcap);
    let (log, report) = ros2::read(&path, &truth_options()).unwrap();
    assert_same_run(&log, &run);
    assert_eq!(report.epoch_ns, 0);
    assert_eq!(report.odometry_source, "/odom");
    assert_eq!(report.truth_source.as_deref(), Some("/truth (geometry_msgs/msg/PoseStamped)"));
    assert_eq!(report.lidars.len(), 2);
    assert_eq!(report.lidars[1].topic, "/lidar_1/scan");
    assert_eq!(report.lidars[1].frame_id, "lidar_1");
    assert_eq!(report.lidars[1].mount_source, "/tf_static base_link -> lidar_1");
    assert!(!report.lidars[1].mirrored, "the mirror is in the scan's negative increment, not the mount");
    let counts: BTreeMap<&str, (&str, usize)> =
        report.topics.iter().map(|(t, c)| (t.as_str(), (c.type_name.as_str(), c.messages))).collect();
    assert_eq!(counts["/estimate"], ("geometry_msgs/msg/PoseWithCovarianceStamped", 20));
    assert_eq!(counts["/particlecloud"], ("geometry_msgs/msg/PoseArray", 20));
    assert_eq!(counts["/map"], ("nav_msgs/msg/OccupancyGrid", 1));
    assert_eq!(counts["/updater/verdict"], ("std_msgs/msg/String", 2));
    assert_eq!(counts["/tf"], ("tf2_msgs/msg/TFMessage", 40));
    assert_eq!(counts["/tf_static"], ("tf2_msgs/msg/TFMessage", 2));
    assert_eq!(counts["/odom"], ("nav_msgs/msg/Odometry", 20));
    // Through read_log, with the format detected.
    let imported = read_log(&path, None, &truth_options()).unwrap();
    assert_eq!(imported.log.records, log.records);
    assert_eq!(imported.path, path);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_scan_timing_in_the_ros_convention_reads_back_and_another_is_written_as_unknown() {
    let dir = temp_dir("timing");
    let path = dir.join("timed.mcap");
    let mut w = McapRunWriter::create(&path).unwrap();
    for k in 0..3 {
        w.odometry(k * 100 * MS, Pose2::new(0.1 * k as f64, 0.0, 0.0)).unwrap();
        // Lidar 0 stamps its first beam (ROS); lidar 1 its last (the simulator's convention).
        let mut a = lidar_scan(0, k);
        a.sweep = Some(SweepTiming { first_beam_s: 0.0, time_increment_s: 1.0 / 3600.0 });
        let mut b = lidar_scan(1, k);
        b.sweep = Some(SweepTiming::ending_at_stamp(b.ranges_m.len(), 1.0 / 3600.0));
        w.scan(&a).unwrap();
        w.scan(&b).unwrap();
    }
    w.finish().unwrap();
    let (log, report) = ros2::read(&path, &ImportOptions::default()).unwrap();
    for s in log.scans() {
        match s.lidar_id {
            0 => {
                let t = s.sweep.expect("lidar 0's timing");
                assert_eq!(t.first_beam_s, 0.0);
                assert!((t.time_increment_s - 1.0 / 3600.0).abs() < 1e-9, "{t:?}");
            }
            _ => assert_eq!(s.sweep, None, "a timing stamped at the last beam is not written"),
        }
    }
    assert!(report.notes.iter().any(|n| n.starts_with("3 scans carry a time_increment")), "{:?}", report.notes);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bag_folder_reads_the_same_as_the_bare_file() {
    let dir = temp_dir("folder");
    let mut whole = Run::default();
    let bare = write_run(&dir.join("whole.mcap"), 0, 20, &mut whole);
    // The same run split in two files, listed by metadata.yaml out of name order.
    let bag = dir.join("bag");
    std::fs::create_dir_all(&bag).unwrap();
    let mut parts = Run::default();
    write_run(&bag.join("run_10.mcap"), 0, 8, &mut parts);
    write_run(&bag.join("run_9.mcap"), 8, 20, &mut parts);
    std::fs::write(
        bag.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  relative_file_paths:\n    - run_10.mcap\n    - run_9.mcap\n  duration:\n    nanoseconds: 1900000000\n",
    )
    .unwrap();
    assert_eq!(detect_format(&bag).unwrap(), LogFormat::Mcap);
    let a = ros2::read(&bare, &truth_options()).unwrap().0;
    let imported = read_log(&bag, None, &truth_options()).unwrap();
    assert_eq!(imported.log.records, a.records);
    assert_eq!(imported.path, bag, "two files: the folder is the source");
    assert_same_run(&imported.log, &whole);
    let report = imported.report.unwrap();
    assert!(report.notes.iter().any(|n| n == "bag folder: read 2 file(s): run_10.mcap, run_9.mcap"), "{report:?}");
    // Without metadata.yaml's list, the files are read by name, numbers as numbers: the same.
    std::fs::write(bag.join("metadata.yaml"), "rosbag2_bagfile_information:\n  version: 5\n").unwrap();
    std::fs::rename(bag.join("run_10.mcap"), bag.join("run_1.mcap")).unwrap();
    std::fs::rename(bag.join("run_9.mcap"), bag.join("run_2.mcap")).unwrap();
    let b = ros2::read(&bag, &truth_options()).unwrap().0;
    assert_eq!(b.records, a.records);
    // A listed file that is missing, and an sqlite3 bag, are refused.
    std::fs::write(bag.join("metadata.yaml"), "relative_file_paths:\n  - run_1.mcap\n  - run_3.mcap\n").unwrap();
    let e = ros2::read(&bag, &truth_options()).unwrap_err().to_string();
    assert!(e.contains("run_3.mcap") && e.contains("not in the bag folder"), "{e}");
    assert!(e.starts_with(&format!("{}: ", bag.display())), "the error names the bag folder: {e}");
    // A listed path that leaves the folder is refused, naming the folder (found by fuzzing: an
    // absolute path made the error name only the listed path).
    for listed in ["/tmp/elsewhere.mcap", "../run_1.mcap", "sub/../../run_1.mcap"] {
        std::fs::write(bag.join("metadata.yaml"), format!("relative_file_paths:\n  - {listed}\n")).unwrap();
        let e = ros2::read(&bag, &truth_options()).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}: ", bag.display())), "{e}");
        assert!(e.contains(&format!("'{listed}', which is not a path inside the bag folder")), "{e}");
    }
    std::fs::write(bag.join("metadata.yaml"), "  storage_identifier: sqlite3\n").unwrap();
    let e = ros2::read(&bag, &truth_options()).unwrap_err().to_string();
    assert!(e.contains("'sqlite3'") && e.contains("ros2 bag convert"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_written_file_is_a_ros2_mcap_with_full_schemas_and_a_summary() {
    let dir = temp_dir("structure");
    let path = write_run(&dir.join("a.mcap"), 0, 12, &mut Run::default());
    let again = write_run(&dir.join("b.mcap"), 0, 12, &mut Run::default());
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(bytes, std::fs::read(&again).unwrap(), "the output is deterministic");
    let header = mcap::read::LinearReader::new(&bytes).unwrap().next().unwrap().unwrap();
    match header {
        mcap::records::Record::Header(h) => {
            assert_eq!(h.profile, "ros2");
            assert!(h.library.starts_with("mapkeeper-logs "), "{}", h.library);
        }
        other => panic!("first record {other:?}"),
    }
    let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary section");
    assert!(!summary.chunk_indexes.is_empty());
    assert!(summary.chunk_indexes.iter().all(|c| c.compression == "zstd"));
    // Per step /odom, /tf twice, /truth, two scans, /estimate, /particlecloud; two /tf_static,
    // one map, one verdict.
    assert_eq!(summary.stats.as_ref().unwrap().message_count, 12 * 8 + 2 + 1 + 1);
    for ch in summary.channels.values() {
        assert_eq!(ch.message_encoding, "cdr");
        let schema = ch.schema.as_ref().unwrap();
        assert_eq!(schema.encoding, "ros2msg");
        assert!(schema.name.contains("/msg/"), "{}", schema.name);
    }
    let scan_schema = summary.channels.values().find(|c| c.topic == "/lidar_0/scan").unwrap().schema.clone().unwrap();
    let text = String::from_utf8(scan_schema.data.to_vec()).unwrap();
    assert!(text.starts_with("std_msgs/Header header\n"), "{text}");
    assert!(text.contains(&format!("{}\nMSG: std_msgs/Header\n", "=".repeat(80))), "{text}");
    assert!(text.contains("\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n"), "{text}");
    // The map: 0 free, 100 occupied, -1 unknown, rows from the bottom; the cells end the message.
    let map =
        mcap::MessageStream::new(&bytes).unwrap().map(|m| m.unwrap()).find(|m| m.channel.topic == "/map").unwrap();
    let data = &map.data[..];
    let cells = &data[data.len() - 15..];
    assert_eq!(&data[data.len() - 19..data.len() - 15], &15u32.to_le_bytes());
    assert_eq!(cells[1], 100);
    assert_eq!(cells[2 * 5 + 4], 0xff);
    assert_eq!(cells.iter().filter(|&&c| c == 0).count(), 13);
    assert_eq!(&data[..4], &[0, 1, 0, 0], "CDR little endian");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_writer_dropped_without_finish_leaves_no_file() {
    let dir = temp_dir("dropped");
    let mut w = McapRunWriter::create(&dir.join("run.mcap")).unwrap();
    w.odometry(0, Pose2::IDENTITY).unwrap();
    drop(w);
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    let mut w = McapRunWriter::create(&dir.join("run.mcap")).unwrap();
    let e = w.true_pose(1 << 62, Pose2::IDENTITY).unwrap_err().to_string();
    assert!(e.contains("run.mcap") && e.contains("/truth") && e.contains("int32 seconds"), "{e}");
    let e = McapRunWriter::create(&dir.join("no/such/dir/run.mcap")).unwrap_err().to_string();
    assert!(e.contains("run.mcap"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------------------------------------
// A bag written with the mcap crate's own writer and CDR encoded by hand.

/// CDR, encoded by hand (independent of the crate's encoder).
struct Cdr(Vec<u8>, bool);

impl Cdr {
    fn new(big_endian: bool) -> Self {
        Cdr(vec![0, u8::from(!big_endian), 0, 0], big_endian)
    }
    fn raw(&mut self, le: &[u8]) {
        while !(self.0.len() - 4).is_multiple_of(le.len()) {
            self.0.push(0);
        }
        if self.1 {
            self.0.extend(le.iter().rev());
        } else {
            self.0.extend_from_slice(le);
        }
    }
    fn u32(&mut self, v: u32) -> &mut Self {
        self.raw(&v.to_le_bytes());
        self
    }
    fn i32(&mut self, v: i32) -> &mut Self {
        self.raw(&v.to_le_bytes());
        self
    }
    fn f32(&mut self, v: f32) -> &mut Self {
        self.raw(&v.to_le_bytes());
        self
    }
    fn f64s(&mut self, v: &[f64]) -> &mut Self {
        for x in v {
            self.raw(&x.to_le_bytes());
        }
        self
    }
    fn string(&mut self, s: &str) -> &mut Self {
        self.u32(s.len() as u32 + 1);
        self.0.extend_from_slice(s.as_bytes());
        self.0.push(0);
        self
    }
    fn header(&mut self, stamp_ns: u64, frame: &str) -> &mut Self {
        self.i32((stamp_ns / 1_000_000_000) as i32).u32((stamp_ns % 1_000_000_000) as u32).string(frame)
    }
}

/// A quaternion (x, y, z, w) from roll, pitch, yaw.
fn quaternion(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy]
}

fn tf_message(big_endian: bool, stamp_ns: u64, tfs: &[(&str, &str, [f64; 3], [f64; 4])]) -> Vec<u8> {
    let mut c = Cdr::new(big_endian);
    c.u32(tfs.len() as u32);
    for (parent, child, t, q) in tfs {
        c.header(stamp_ns, parent).string(child).f64s(t).f64s(q);
    }
    c.0
}

fn laser_scan(stamp_ns: u64, frame: &str, angle_min: f32, inc: f32, range_max: f32, ranges: &[f32]) -> Vec<u8> {
    timed_laser_scan(stamp_ns, frame, angle_min, inc, range_max, ranges, 0.0)
}

/// As [`laser_scan`], with a `time_increment` (seconds per beam).
fn timed_laser_scan(
    stamp_ns: u64,
    frame: &str,
    angle_min: f32,
    inc: f32,
    range_max: f32,
    ranges: &[f32],
    time_increment: f32,
) -> Vec<u8> {
    let mut c = Cdr::new(false);
    c.header(stamp_ns, frame);
    let angle_max = angle_min + inc * (ranges.len() as f32 - 1.0);
    for v in [angle_min, angle_max, inc, time_increment, 0.1, 0.02, range_max] {
        c.f32(v);
    }
    c.u32(ranges.len() as u32);
    for r in ranges {
        c.f32(*r);
    }
    c.u32(ranges.len() as u32);
    for _ in ranges {
        c.f32(100.0);
    }
    c.0
}

/// One message of a hand-built bag: topic, schema name, CDR bytes, log_time.
type Msg = (&'static str, &'static str, Vec<u8>, u64);

/// Writes `messages` with the mcap crate's writer (chunks compressed with `compression`).
fn mcap_file(path: &Path, compression: Option<mcap::Compression>, messages: &[Msg]) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new().profile("ros2").compression(compression).create(file).unwrap();
    let mut channels: BTreeMap<&str, Arc<mcap::Channel<'static>>> = BTreeMap::new();
    for (i, (topic, schema, data, log_time)) in messages.iter().enumerate() {
        let id = channels.len() as u16;
        let channel = channels
            .entry(*topic)
            .or_insert_with(|| {
                Arc::new(mcap::Channel {
                    id,
                    topic: topic.to_string(),
                    schema: Some(Arc::new(mcap::Schema {
                        id: id + 1,
                        name: schema.to_string(),
                        encoding: "ros2msg".into(),
                        data: Cow::Owned(b"# not parsed by the reader\n".to_vec()),
                    })),
                    message_encoding: "cdr".into(),
                    metadata: BTreeMap::new(),
                })
            })
            .clone();
        let m = mcap::Message {
            channel,
            sequence: i as u32,
            log_time: *log_time,
            publish_time: *log_time,
            data: Cow::Owned(data.clone()),
        };
        w.write(&m).unwrap();
    }
    w.finish().unwrap();
}

const T0: u64 = 1_700_000_000_000_000_000;
const TF: &str = "tf2_msgs/msg/TFMessage";
const SCAN: &str = "sensor_msgs/msg/LaserScan";

/// A bag as a ROS 2 robot records it: an upside-down lidar two frames from the base, odometry
/// only as `/tf`.
fn upside_down_bag() -> Vec<Msg> {
    // Static transforms in big endian, to read both byte orders in one file.
    let statics = tf_message(
        true,
        T0,
        &[
            ("base_link", "plate", [0.2, 0.0, 0.3], [0.0, 0.0, 0.0, 1.0]),
            ("plate", "laser", [0.1, -0.2, 0.0], quaternion(PI, 0.0, 0.5)),
        ],
    );
    let mut msgs: Vec<Msg> = vec![("/tf_static", TF, statics, T0)];
    for k in 0..10u64 {
        let t = T0 + k * 50 * MS;
        let odom = tf_message(
            false,
            t,
            &[("odom", "base_link", [0.05 * k as f64, 0.0, 0.0], quaternion(0.0, 0.0, 0.01 * k as f64))],
        );
        msgs.push(("/tf", TF, odom, t + MS));
        let ranges = [1.0, 2.0, f32::INFINITY, 3.0, 29.99];
        msgs.push(("/scan", SCAN, laser_scan(t + 10 * MS, "laser", -0.5, 0.25, 30.0, &ranges), t + 15 * MS));
        msgs.push(("/chatter", "std_msgs/msg/String", Cdr::new(false).string("hello").0.clone(), t + 20 * MS));
    }
    msgs
}

#[test]
fn a_time_increment_is_read_and_an_impossible_one_is_ignored_with_a_note() {
    let dir = temp_dir("time-increment");
    let ranges = [1.0, 2.0, 3.0, 4.0, 5.0];
    for (dt, timed) in [(1e-3f32, true), (0.5, false)] {
        let mut msgs = upside_down_bag();
        for m in msgs.iter_mut().filter(|m| m.0 == "/scan") {
            let stamp = m.3 - 5 * MS;
            m.2 = timed_laser_scan(stamp, "laser", -0.5, 0.25, 30.0, &ranges, dt);
        }
        let path = dir.join(format!("dt-{dt}.mcap"));
        mcap_file(&path, None, &msgs);
        let imported = read_log(&path, None, &ImportOptions::default()).unwrap();
        let scans: Vec<&LaserScan> = imported.log.scans().collect();
        assert_eq!(scans.len(), 10);
        let notes = imported.report.unwrap().notes;
        if timed {
            for s in &scans {
                let t = s.sweep.unwrap();
                assert!(t.first_beam_s == 0.0 && (t.time_increment_s - 1e-3).abs() < 1e-9, "{t:?}");
            }
        } else {
            // 4 × 0.5 s: a sweep of 2 s is not a lidar's; the scans are kept, their timing is not.
            assert!(scans.iter().all(|s| s.sweep.is_none()));
            assert!(
                notes.iter().any(|n| n.starts_with("/scan: the time_increment of 10 scans is ignored")),
                "{notes:?}"
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bag_from_another_writer_with_an_upside_down_lidar_and_odometry_from_tf() {
    let dir = temp_dir("independent");
    let path = dir.join("robot.mcap");
    mcap_file(&path, Some(mcap::Compression::Lz4), &upside_down_bag());
    let bytes = std::fs::read(&path).unwrap();
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    assert!(summary.chunk_indexes.iter().all(|c| c.compression == "lz4"));
    let (log, report) = ros2::read(&path, &ImportOptions::default()).unwrap();
    assert_eq!(report.epoch_ns, T0, "the first odometry transform");
    assert_eq!(report.odometry_source, "/tf odom -> base_link");
    assert_eq!(report.topics["/chatter"].messages, 10);
    assert!(report.lidars[0].mirrored);
    assert_eq!(report.lidars[0].mount_source, "/tf_static base_link -> laser");
    let scans: Vec<&LaserScan> = log.scans().collect();
    assert_eq!(scans.len(), 10);
    let s = scans[3];
    assert_eq!(s.stamp_ns, 3 * 50 * MS + 10 * MS);
    // Mirrored: angles negated, so the beams turn counter-clockwise in the base frame.
    assert_eq!((s.angle_min_rad, s.angle_increment_rad), (0.5, -0.25));
    let m = s.lidar_in_robot;
    assert!((m.x - 0.3).abs() < 1e-12 && (m.y + 0.2).abs() < 1e-12 && (m.yaw - 0.5).abs() < 1e-12, "{m:?}");
    // range_max 30 is inclusive in ROS: 29.99 is valid, the infinite reading is not.
    assert_eq!(s.range_max_m, 30.0f32.next_up());
    assert_eq!(s.valid_count(), 4);
    assert_eq!(s.range_min_m, 0.02);
    let odom: Vec<_> = log.odometry().collect();
    assert_eq!(odom.len(), 10);
    assert_eq!(odom[4].stamp_ns, 4 * 50 * MS);
    assert!((odom[4].pose_in_odom.x - 0.2).abs() < 1e-12 && (odom[4].pose_in_odom.yaw - 0.04).abs() < 1e-12);
    // The record clock: the scan's log_time, 5 ms after its header stamp, from the first /tf's
    // log_time (1 ms after its stamp).
    let opts = ImportOptions { stamp: StampFrom::Record, ..ImportOptions::default() };
    let (log, report) = ros2::read(&path, &opts).unwrap();
    assert_eq!(report.epoch_ns, T0 + MS);
    assert_eq!(log.scans().nth(3).unwrap().stamp_ns, 3 * 50 * MS + 15 * MS - MS);
    // A log_time past i64 nanoseconds (a corrupt record) is refused by the record clock, by
    // message, not carried into the stamp arithmetic (it overflowed there); the header clock
    // does not read it.
    let mut bag = upside_down_bag();
    let scan = bag.iter().position(|m| m.0 == "/scan").unwrap();
    bag[scan].3 = u64::MAX;
    let far = dir.join("far.mcap");
    mcap_file(&far, None, &bag);
    let e = ros2::read(&far, &opts).unwrap_err().to_string();
    assert!(e.contains("far.mcap") && e.contains(&format!("(log_time {} ns)", u64::MAX)), "{e}");
    assert!(e.contains("is past 9223372036854775807 ns"), "{e}");
    ros2::read(&far, &ImportOptions::default()).expect("the header clock reads the same file");
    // zstd chunks read the same.
    let zst = dir.join("robot-zstd.mcap");
    mcap_file(&zst, Some(mcap::Compression::Zstd), &upside_down_bag());
    let opts = ImportOptions::default();
    assert_eq!(ros2::read(&zst, &opts).unwrap().0.records, ros2::read(&path, &opts).unwrap().0.records);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_bag_written_by_rosbags_reads() {
    // tests/data/make_rosbags_bag.py wrote it with the `rosbags` Python library.
    let bag = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/rosbags_bag");
    assert_eq!(detect_format(&bag).unwrap(), LogFormat::Mcap);
    let imported = read_log(&bag, None, &ImportOptions::default()).unwrap();
    assert_eq!(imported.path, bag.join("rosbags_bag.mcap"), "one file: the file is the source");
    let (log, report) = (imported.log, imported.report.unwrap());
    assert_eq!(report.epoch_ns, T0);
    assert_eq!(report.odometry_source, "/odom");
    assert_eq!(report.topics["/chatter"].messages, 5);
    assert!(report.lidars[0].mirrored);
    let scans: Vec<&LaserScan> = log.scans().collect();
    assert_eq!(scans.len(), 5);
    let s = scans[2];
    assert_eq!(s.stamp_ns, 2 * 100 * MS + 10 * MS);
    assert_eq!((s.angle_min_rad, s.angle_increment_rad), (0.5, -0.25));
    let m = s.lidar_in_robot;
    assert!((m.x - 0.3).abs() < 1e-12 && (m.y + 0.2).abs() < 1e-12 && (m.yaw - 0.5).abs() < 1e-12, "{m:?}");
    assert_eq!(s.range_max_m, 10.0f32.next_up());
    assert_eq!(s.ranges_m, vec![1.0, 2.0, f32::INFINITY, 3.0, 10.0]);
    assert_eq!(s.valid_count(), 4, "10 m is range_max, inclusive in ROS");
    let o = log.odometry().nth(3).unwrap();
    assert_eq!(o.stamp_ns, 3 * 100 * MS);
    assert!((o.pose_in_odom.x - 0.3).abs() < 1e-12 && (o.pose_in_odom.yaw - 0.06).abs() < 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Bad files.

fn read_err(path: &Path, options: &ImportOptions) -> String {
    let e = ros2::read(path, options).unwrap_err();
    assert!(matches!(e, ImportError::Parse { .. } | ImportError::Unusable { .. } | ImportError::Io { .. }), "{e:?}");
    let s = e.to_string();
    assert!(s.starts_with(&path.display().to_string()), "the error names the file: {s}");
    s
}

#[test]
fn a_truncated_file_is_refused_at_every_cut() {
    let dir = temp_dir("truncated");
    let path = write_run(&dir.join("run.mcap"), 0, 6, &mut Run::default());
    let bytes = std::fs::read(&path).unwrap();
    let cut_path = dir.join("cut.mcap");
    let step = (bytes.len() / 400).max(1);
    let cuts: Vec<usize> = (0..bytes.len()).step_by(step).chain(bytes.len() - 40..bytes.len()).collect();
    let mut truncated = 0;
    for cut in cuts {
        std::fs::write(&cut_path, &bytes[..cut]).unwrap();
        let e = read_err(&cut_path, &truth_options());
        truncated += usize::from(e.contains("truncated"));
    }
    assert!(truncated > 100, "most cuts are named as truncation ({truncated})");
    // A flipped byte inside a compressed chunk fails its CRC or its decompression.
    let chunk = &mcap::Summary::read(&bytes).unwrap().unwrap().chunk_indexes[0];
    let mut bad = bytes.clone();
    bad[(chunk.chunk_start_offset + chunk.chunk_length / 2) as usize] ^= 0x55;
    std::fs::write(&cut_path, &bad).unwrap();
    read_err(&cut_path, &truth_options());
    // A record claiming a terabyte is refused before anything is allocated for it.
    let mut huge = b"\x89MCAP0\r\n\x01".to_vec();
    huge.extend_from_slice(&(1u64 << 40).to_le_bytes());
    std::fs::write(&cut_path, &huge).unwrap();
    let e = read_err(&cut_path, &truth_options());
    assert!(e.contains("a record of 1099511627776 bytes"), "{e}");
    std::fs::write(&cut_path, b"not an mcap file at all").unwrap();
    assert!(read_err(&cut_path, &truth_options()).contains("bad magic"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_scan_whose_ranges_run_past_the_message_is_refused() {
    let dir = temp_dir("seqlen");
    let path = dir.join("bad.mcap");
    let mut scan = laser_scan(T0, "base_link", -0.5, 0.25, 30.0, &[1.0, 2.0, 3.0]);
    // The ranges' length word follows the header (4 + 8 + 14 -> 28 after padding) and 7 floats.
    let at = 28 + 7 * 4;
    assert_eq!(&scan[at..at + 4], &3u32.to_le_bytes());
    scan[at..at + 4].copy_from_slice(&1_000_000_000u32.to_le_bytes());
    let odom = tf_message(false, T0, &[("odom", "base_link", [0.0; 3], [0.0, 0.0, 0.0, 1.0])]);
    mcap_file(&path, None, &[("/tf", TF, odom, T0), ("/scan", SCAN, scan, T0 + 7)]);
    let e = read_err(&path, &ImportOptions::default());
    assert!(
        e.contains(&format!("message 2 on /scan (log_time {} ns): sensor_msgs/msg/LaserScan: byte {at}: ranges: a sequence of 1000000000 elements", T0 + 7)),
        "{e}"
    );
    // A message cut short, and one with an unknown encapsulation.
    let short = laser_scan(T0, "base_link", -0.5, 0.25, 30.0, &[1.0, 2.0, 3.0])[..40].to_vec();
    mcap_file(&path, None, &[("/scan", SCAN, short, T0)]);
    assert!(read_err(&path, &ImportOptions::default()).contains("the message ends"));
    let mut xcdr = laser_scan(T0, "base_link", -0.5, 0.25, 30.0, &[1.0]);
    xcdr[1] = 0x07;
    mcap_file(&path, None, &[("/scan", SCAN, xcdr, T0)]);
    assert!(read_err(&path, &ImportOptions::default()).contains("encapsulation kind 0x0007"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_topic_of_the_wrong_type_and_a_missing_transform_are_refused() {
    let dir = temp_dir("wrongtype");
    let path = write_run(&dir.join("run.mcap"), 0, 3, &mut Run::default());
    let opts = ImportOptions { scan_topics: vec!["/truth".into()], ..ImportOptions::default() };
    let e = read_err(&path, &opts);
    assert!(
        e.contains("scan topic '/truth' has type 'geometry_msgs/msg/PoseStamped', not sensor_msgs/msg/LaserScan"),
        "{e}"
    );
    let opts = ImportOptions { truth_topic: Some("/particlecloud".into()), ..ImportOptions::default() };
    assert!(read_err(&path, &opts).contains("reference topic '/particlecloud' has type 'geometry_msgs/msg/PoseArray'"));
    let opts =
        ImportOptions { odometry: mapkeeper_logs::OdometryFrom::Topic("/truth".into()), ..ImportOptions::default() };
    assert!(read_err(&path, &opts).contains("odometry topic '/truth'"));
    // No /tf_static: the lidar's mount is unknown.
    let bag: Vec<Msg> = upside_down_bag().into_iter().filter(|m| m.0 != "/tf_static").collect();
    let p = dir.join("nomount.mcap");
    mcap_file(&p, None, &bag);
    let e = read_err(&p, &ImportOptions::default());
    assert!(e.contains("no transform from the base frame 'base_link' to the lidar frame 'laser'"), "{e}");
    // A NaN angle is caught by the scan's validation, with its place.
    let opts = ImportOptions::default();
    let odom = tf_message(false, T0, &[("odom", "base_link", [0.0; 3], [0.0, 0.0, 0.0, 1.0])]);
    let nan = laser_scan(T0, "base_link", f32::NAN, 0.25, 30.0, &[1.0, 2.0]);
    mcap_file(&p, None, &[("/tf", TF, odom, T0), ("/scan", SCAN, nan, T0 + 1)]);
    let e = read_err(&p, &opts);
    assert!(e.contains("message 2 (log_time") && e.contains("angle_min_rad must be finite"), "{e}");
    // A transform with a zero quaternion.
    let zero = tf_message(false, T0, &[("odom", "base_link", [0.0; 3], [0.0; 4])]);
    mcap_file(&p, None, &[("/tf", TF, zero, T0)]);
    assert!(read_err(&p, &opts).contains("the quaternion is zero"));
    std::fs::remove_dir_all(&dir).ok();
}
