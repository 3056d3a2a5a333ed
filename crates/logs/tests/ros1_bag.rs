//! The ROS 1 bag reader against bags written by an independent test-only writer
//! (`support/ros1_writer.rs`).
#![allow(clippy::unwrap_used)]

#[path = "support/ros1_writer.rs"]
mod ros1_writer;

use mapkeeper_logs::{ImportError, ImportOptions, ImportReport, LogFormat, OdometryFrom, StampFrom, read_log, ros1};
use mapkeeper_sensor::SensorLog;
use ros1_writer::{Bag, BagWriter, Compression, laser_scan, odometry, tf_message};
use std::f64::consts::PI;
use std::path::PathBuf;

const S: u64 = 1_000_000_000;
const MS: u64 = 1_000_000;
/// The bag's clock starts here (ROS time, seconds since the epoch).
const T0: u64 = 1_700_000_000 * S;

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-ros1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{name}.bag"));
    std::fs::write(&p, bytes).unwrap();
    p
}

fn read(name: &str, bytes: &[u8], options: &ImportOptions) -> Result<(SensorLog, ImportReport), ImportError> {
    ros1::read(&write(name, bytes), options)
}

fn front_ranges(i: usize) -> [f32; 5] {
    [1.0 + i as f32 * 0.01, 2.0, 8.0, 9.0, f32::INFINITY]
}

/// The robot's bag: a front lidar on /scan_front (frame '/laser_front', mounted level), a rear
/// lidar on /scan_rear (frame 'laser_rear', upside down and facing back, through base_link →
/// plate → laser_rear), odometry on /odom, a camera topic nobody reads.
fn robot_bag(compression: Compression, writer: impl FnOnce(BagWriter) -> BagWriter) -> Bag {
    robot_bag_of(20, compression, writer)
}

/// The robot's bag with `n` scans of each lidar (and 5n/4 odometry messages).
fn robot_bag_of(n: u32, compression: Compression, writer: impl FnOnce(BagWriter) -> BagWriter) -> Bag {
    let mut w = writer(BagWriter::new(compression).chunk_bytes(900));
    let tf_static = w.connection("/tf_static", "tf2_msgs/TFMessage");
    let front = w.connection("/scan_front", "sensor_msgs/LaserScan");
    let rear = w.connection("/scan_rear", "sensor_msgs/LaserScan");
    let odom = w.connection("/odom", "nav_msgs/Odometry");
    let camera = w.connection("/camera/image_raw", "sensor_msgs/Image");
    w.write(
        tf_static,
        T0,
        &tf_message(&[
            (0, "/base_link", "laser_front", [0.25, 0.0, 0.2], [0.0, 0.0, 0.0]),
            (0, "base_link", "plate", [0.1, 0.0, 0.3], [0.0, 0.0, 0.0]),
            (0, "plate", "/laser_rear", [-0.3, 0.05, -0.1], [PI, 0.0, PI]),
        ]),
    );
    for i in 0..n * 5 / 4 {
        let t = T0 + u64::from(i) * 80 * MS;
        let pose = (0.1 * f64::from(i), 0.0, 0.02 * f64::from(i));
        w.write(odom, t + 2 * MS, &odometry(i, t, "odom", "base_link", pose));
        if i % 8 == 0 {
            w.write(camera, t + 3 * MS, &[7u8; 50]);
        }
    }
    for i in 0..n {
        let t = T0 + 10 * MS + u64::from(i) * 100 * MS;
        let f = laser_scan(i, t, "/laser_front", (-1.0, 1.0, 0.5), (0.05, 8.0), &front_ranges(i as usize));
        w.write(front, t + 5 * MS, &f);
        let r = laser_scan(i, t + 20 * MS, "laser_rear", (-0.3, 0.3, 0.2), (0.1, 12.0), &[3.0, 3.5, 4.0, 12.0]);
        w.write(rear, t + 25 * MS, &r);
    }
    w.finish()
}

#[test]
fn two_lidars_one_upside_down_and_odometry_are_read() {
    let bag = robot_bag(Compression::None, |w| w);
    let (log, report) = read("robot", &bag.bytes, &ImportOptions::default()).unwrap();
    assert_eq!(report.format, "bag");
    assert_eq!(report.epoch_ns, T0, "time is re-based on the first odometry stamp");
    assert_eq!(report.scans, 40);
    assert_eq!(report.lidars.len(), 2);
    let (f, r) = (&report.lidars[0], &report.lidars[1]);
    assert_eq!((f.topic.as_str(), f.frame_id.as_str(), f.mirrored), ("/scan_front", "laser_front", false));
    assert_eq!((r.topic.as_str(), r.frame_id.as_str(), r.mirrored), ("/scan_rear", "laser_rear", true));
    assert!(r.mount_source.contains("/tf_static"), "{}", r.mount_source);
    let scans: Vec<_> = log.scans().collect();
    let front: Vec<_> = scans.iter().filter(|s| s.lidar_id == 0).collect();
    let rear: Vec<_> = scans.iter().filter(|s| s.lidar_id == 1).collect();
    assert_eq!((front.len(), rear.len()), (20, 20));
    for (i, s) in front.iter().enumerate() {
        assert_eq!(s.stamp_ns, 10 * MS + i as u64 * 100 * MS);
        assert_eq!(s.ranges_m, front_ranges(i).to_vec());
        assert_eq!((s.angle_min_rad, s.angle_increment_rad), (-1.0, 0.5));
        assert_eq!(s.range_min_m, 0.05);
        assert_eq!(s.range_max_m, 8.0f32.next_up(), "ROS's range_max is inclusive");
        assert_eq!(s.valid_count(), 3, "1.x, 2 and 8 (= range_max) valid; 9 and inf not");
        let m = s.lidar_in_robot;
        assert!((m.x - 0.25).abs() < 1e-12 && m.y.abs() < 1e-12 && m.yaw.abs() < 1e-12, "{m:?}");
    }
    for (i, s) in rear.iter().enumerate() {
        assert_eq!(s.stamp_ns, 30 * MS + i as u64 * 100 * MS);
        // Upside down: the angles are mirrored.
        assert_eq!(s.angle_min_rad, -f64::from(-0.3f32));
        assert_eq!(s.angle_increment_rad, -f64::from(0.2f32));
        assert_eq!(s.ranges_m, vec![3.0, 3.5, 4.0, 12.0]);
        assert_eq!(s.valid_count(), 4, "12 = range_max is valid");
        let m = s.lidar_in_robot;
        assert!((m.x + 0.2).abs() < 1e-12 && (m.y - 0.05).abs() < 1e-12, "{m:?}");
        assert!((m.yaw.abs() - PI).abs() < 1e-9, "facing back: {m:?}");
    }
    let odom: Vec<_> = log.odometry().collect();
    assert_eq!(report.odometry_source, "/odom");
    assert_eq!(odom.len(), 25);
    for (i, o) in odom.iter().enumerate() {
        assert_eq!(o.stamp_ns, i as u64 * 80 * MS);
        let p = o.pose_in_odom;
        assert!((p.x - 0.1 * i as f64).abs() < 1e-12 && p.y.abs() < 1e-12, "{p:?}");
        assert!((p.yaw - 0.02 * i as f64).abs() < 1e-12, "{p:?}");
    }
    assert_eq!(report.topics["/camera/image_raw"].messages, 4);
    assert_eq!(report.topics["/scan_front"].type_name, "sensor_msgs/LaserScan");
    assert_eq!(report.topics["/tf_static"].messages, 1);
    assert!(report.notes.iter().any(|n| n.contains("topics not used: /camera/image_raw (sensor_msgs/Image, 4)")));
    assert!(report.backward_steps.is_empty());
    assert!(!report.notes.iter().any(|n| n.contains("index")), "an intact index: {:?}", report.notes);
    // The log is a valid sensor log (it passes the JSON Lines reader's checks).
    let path = write("robot-jsonl", b"").with_extension("jsonl");
    log.write(&path).unwrap();
    assert_eq!(SensorLog::read(&path).unwrap().records.len(), log.records.len());
}

#[test]
fn every_compression_gives_the_same_log() {
    let (want, want_report) =
        read("plain", &robot_bag(Compression::None, |w| w).bytes, &ImportOptions::default()).unwrap();
    for c in Compression::ALL {
        let bag = robot_bag(c, |w| w);
        assert!(bag.chunk_pos.len() >= 5, "{c:?}: several chunks ({})", bag.chunk_pos.len());
        let (log, mut report) = read(&format!("{c:?}"), &bag.bytes, &ImportOptions::default()).unwrap();
        assert!(log.records == want.records, "{c:?}: the records differ");
        report.source.clone_from(&want_report.source);
        assert_eq!(report, want_report, "{c:?}");
    }
    // One big chunk of each, too.
    for c in Compression::ALL {
        let bag = robot_bag(c, |w| w.chunk_bytes(1 << 30));
        assert_eq!(bag.chunk_pos.len(), 1);
        assert_eq!(read(&format!("{c:?}-one"), &bag.bytes, &ImportOptions::default()).unwrap().0.records, want.records);
    }
}

#[test]
fn lz4_chunks_are_roslz4_frames() {
    // rosbag's own block size (1 MiB), and blocks stored uncompressed when they do not shrink.
    let (want, _) = read("lz4-64k", &robot_bag(Compression::Lz4, |w| w).bytes, &ImportOptions::default()).unwrap();
    let bag = robot_bag(Compression::Lz4, |w| w.lz4_block_size_id(6));
    let p = bag.chunk_pos[0] as usize;
    let frame = &bag.bytes[p..p + 200];
    let magic = frame.windows(4).position(|w| w == [0x04, 0x22, 0x4d, 0x18]).unwrap();
    // Version 01, independent blocks, a content checksum; 1 MiB blocks.
    assert_eq!(&frame[magic + 4..magic + 6], &[0x64, 0x60]);
    assert!(read("lz4-1m", &bag.bytes, &ImportOptions::default()).unwrap().0.records == want.records);
    let mut x = 88_172_645_463_325_252u64;
    let random: Vec<u8> = (0..3000)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 32) as u8
        })
        .collect();
    let stored = ros1_writer::roslz4_frame(&random, 4);
    assert_eq!(stored[7..11], (3000u32 | 0x8000_0000).to_le_bytes(), "an uncompressed block");
    let mut back = Vec::new();
    std::io::Read::read_to_end(&mut lz4_flex::frame::FrameDecoder::new(&stored[..]), &mut back).unwrap();
    assert!(back == random);
    assert_eq!(ros1_writer::xxh32(b""), 0x02CC_5D05, "xxh32 test vector");
    assert_eq!(ros1_writer::xxh32(b"abc"), 0x32D1_53FF, "xxh32 test vector");
}

#[test]
fn a_missing_or_damaged_index_is_walked_past() {
    for c in Compression::ALL {
        let bag = robot_bag(c, |w| w);
        let opts = ImportOptions::default();
        let (want, _) = read("intact", &bag.bytes, &opts).unwrap();
        let cut_in_index = bag.index_pos as usize + (bag.bytes.len() - bag.index_pos as usize) / 2;
        let cases: Vec<(&str, Vec<u8>, &str)> = vec![
            ("zeroed", bag.with_index_pos(0), "index_pos 0 is 0"),
            ("removed", bag.bytes[..bag.index_pos as usize].to_vec(), "the index is missing"),
            ("past-end", bag.with_index_pos(bag.bytes.len() as u64 + 100), "past the end of the file"),
            ("at-a-chunk", bag.with_index_pos(bag.chunk_pos[1]), "it points at a chunk record"),
            ("garbage", bag.with_index_pos(bag.chunk_pos[1] + 7), "does not point at an index record"),
            ("cut", bag.bytes[..cut_in_index].to_vec(), "the index section is cut short or damaged"),
        ];
        for (name, bytes, note) in cases {
            let (log, report) =
                read(&format!("index-{name}-{c:?}"), &bytes, &opts).unwrap_or_else(|e| panic!("{name} {c:?}: {e}"));
            assert_eq!(log.records, want.records, "{name} {c:?}");
            assert!(report.notes.iter().any(|n| n.contains(note)), "{name} {c:?}: {:?}", report.notes);
        }
    }
}

#[test]
fn connections_only_after_the_index_are_collected() {
    let (want, _) = read("with-conns", &robot_bag(Compression::Lz4, |w| w).bytes, &ImportOptions::default()).unwrap();
    let bag = robot_bag(Compression::Lz4, BagWriter::connections_only_in_index);
    let (log, report) = read("conns-in-index", &bag.bytes, &ImportOptions::default()).unwrap();
    assert_eq!(log.records, want.records);
    assert!(report.notes.is_empty() || !report.notes.iter().any(|n| n.contains("before their connection")));
    // Without a usable index_pos the messages wait for the connections at the end of the walk.
    let (log, report) = read("conns-in-index-zeroed", &bag.with_index_pos(0), &ImportOptions::default()).unwrap();
    assert_eq!(log.records, want.records);
    assert!(report.notes.iter().any(|n| n.contains("came before their connection record")), "{:?}", report.notes);
    // And with the index gone, those messages have no connection at all.
    let e = read("conns-gone", &bag.bytes[..bag.index_pos as usize], &ImportOptions::default()).unwrap_err();
    assert!(e.to_string().contains("no laser scans"), "{e}");
}

/// A bag with odometry only on /tf (odom → base_link, written with leading slashes), a lidar
/// in the base frame, and scan header stamps that step back twice.
fn tf_bag() -> Bag {
    let mut w = BagWriter::new(Compression::Bz2);
    let tf = w.connection("/tf", "tf/tfMessage");
    let scan = w.connection("/scan", "sensor_msgs/LaserScan");
    for i in 0..10u64 {
        let t = T0 + i * 100 * MS;
        let pose = [0.5 * i as f64, 0.1, 0.0];
        w.write(tf, t + MS, &tf_message(&[(t, "/odom", "/base_link", pose, [0.0, 0.0, 0.1 * i as f64])]));
    }
    for (i, ms) in [50u64, 150, 120, 250, 350, 300, 450].into_iter().enumerate() {
        let s = laser_scan(i as u32, T0 + ms * MS, "/base_link", (-0.5, 0.5, 0.5), (0.0, 5.0), &[1.0, 2.0, 3.0]);
        w.write(scan, T0 + (100 + 100 * i as u64) * MS, &s);
    }
    w.finish()
}

#[test]
fn odometry_comes_from_tf_without_an_odometry_topic() {
    let (log, report) = read("tf-odom", &tf_bag().bytes, &ImportOptions::default()).unwrap();
    assert_eq!(report.odometry_source, "/tf odom -> base_link", "leading slashes stripped");
    let odom: Vec<_> = log.odometry().collect();
    assert_eq!(odom.len(), 10);
    for (i, o) in odom.iter().enumerate() {
        assert_eq!(o.stamp_ns, i as u64 * 100 * MS);
        let p = o.pose_in_odom;
        assert!((p.x - 0.5 * i as f64).abs() < 1e-12 && (p.y - 0.1).abs() < 1e-12, "{p:?}");
        assert!((p.yaw - 0.1 * i as f64).abs() < 1e-12, "{p:?}");
    }
    assert_eq!(report.lidars[0].frame_id, "base_link");
    assert_eq!(report.topics["/tf"].type_name, "tf/tfMessage");
}

#[test]
fn header_stamps_that_step_back_are_counted_and_record_stamps_can_be_used() {
    let bag = tf_bag();
    let (log, report) = read("backward", &bag.bytes, &ImportOptions::default()).unwrap();
    assert_eq!(report.backward_steps.len(), 1, "{:?}", report.backward_steps);
    let b = &report.backward_steps[0];
    assert_eq!((b.stream.as_str(), b.count), ("/scan", 2));
    assert!((b.largest_s - 0.05).abs() < 1e-9, "{}", b.largest_s);
    let stamps: Vec<u64> = log.scans().map(|s| s.stamp_ns / MS).collect();
    assert_eq!(stamps, vec![50, 150, 150, 250, 350, 350, 450]);
    // The recorder's clock never steps back.
    let opts = ImportOptions { stamp: StampFrom::Record, ..ImportOptions::default() };
    let (log, report) = read("backward-record", &bag.bytes, &opts).unwrap();
    assert!(report.backward_steps.is_empty());
    let stamps: Vec<u64> = log.scans().map(|s| s.stamp_ns / MS).collect();
    assert_eq!(stamps, vec![99, 199, 299, 399, 499, 599, 699], "record times, epoch the first /tf record (T0 + 1 ms)");
}

#[test]
fn reference_poses_come_from_the_truth_topic() {
    for (type_name, message) in [
        ("geometry_msgs/PoseStamped", ros1_writer::pose_stamped as fn(u64, (f64, f64, f64)) -> Vec<u8>),
        ("geometry_msgs/PoseWithCovarianceStamped", ros1_writer::pose_with_covariance_stamped),
        ("nav_msgs/Odometry", |t, p| odometry(0, t, "map", "base_link", p)),
    ] {
        let mut w = BagWriter::new(Compression::Lz4);
        let scan = w.connection("/scan", "sensor_msgs/LaserScan");
        let odom = w.connection("/wheel_odom", "nav_msgs/Odometry");
        let truth = w.connection("/ground_truth", type_name);
        for i in 0..5u64 {
            let t = T0 + i * 100 * MS;
            w.write(scan, t, &laser_scan(0, t, "base_link", (-0.5, 0.5, 0.5), (0.0, 5.0), &[1.0, 2.0, 3.0]));
            w.write(odom, t, &odometry(0, t, "odom", "base_link", (i as f64, 0.0, 0.0)));
            w.write(truth, t, &message(t, (10.0 + i as f64, 5.0, 1.0)));
        }
        let bag = w.finish();
        let opts = ImportOptions { truth_topic: Some("/ground_truth".into()), ..ImportOptions::default() };
        let (log, report) = read("truth", &bag.bytes, &opts).unwrap_or_else(|e| panic!("{type_name}: {e}"));
        assert_eq!(report.truth_source.as_deref(), Some(format!("/ground_truth ({type_name})").as_str()));
        assert_eq!(report.odometry_source, "/wheel_odom", "the truth topic is not an odometry topic");
        let truth: Vec<_> = log.truth().collect();
        assert_eq!(truth.len(), 5);
        let p = truth[3].pose_in_map;
        assert!((p.x - 13.0).abs() < 1e-12 && (p.y - 5.0).abs() < 1e-12 && (p.yaw - 1.0).abs() < 1e-12, "{p:?}");
        let opts = ImportOptions { truth_topic: Some("/gt".into()), ..ImportOptions::default() };
        let e = read("no-truth", &bag.bytes, &opts).unwrap_err().to_string();
        assert!(e.contains("truth topic '/gt' has no") && e.contains("/ground_truth"), "{e}");
    }
}

#[test]
fn a_beam_count_that_disagrees_with_angle_max_is_noted_once() {
    let mut w = BagWriter::new(Compression::None);
    let scan = w.connection("/scan", "sensor_msgs/LaserScan");
    let odom = w.connection("/odom", "nav_msgs/Odometry");
    for i in 0..3u64 {
        let t = T0 + i * 100 * MS;
        // angle_max says 3 beams, the scan has 6.
        w.write(scan, t, &laser_scan(0, t, "base_link", (-0.5, 0.5, 0.5), (0.0, 5.0), &[1.0; 6]));
        w.write(odom, t, &odometry(0, t, "odom", "base_link", (0.0, 0.0, 0.0)));
    }
    let (log, report) = read("beams", &w.finish().bytes, &ImportOptions::default()).unwrap();
    let notes: Vec<_> = report.notes.iter().filter(|n| n.contains("6 ranges")).collect();
    assert_eq!(notes.len(), 1, "{:?}", report.notes);
    assert!(
        notes[0].contains("/scan") && notes[0].contains("= 3.00") && notes[0].contains("message 1"),
        "{}",
        notes[0]
    );
    assert_eq!(log.scans().next().unwrap().ranges_m.len(), 6);
}

fn assert_refused(e: &ImportError, path: &std::path::Path, want: &[&str]) {
    let s = e.to_string();
    assert!(s.starts_with(&path.display().to_string()), "the file is named: {s}");
    for w in want {
        assert!(s.contains(w), "'{w}' in: {s}");
    }
}

#[test]
fn truncated_bags_are_refused_with_the_file_and_place() {
    for c in Compression::ALL {
        // A small bag (three chunks): every cut of the uncompressed one, every third of the others.
        let bag = robot_bag_of(4, c, |w| w);
        let step = if c == Compression::None { 1 } else { 3 };
        // One file, cut shorter and shorter in place.
        let path = write(&format!("cut-{c:?}"), &bag.bytes);
        let file = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        let (mut refused, mut read_ok) = (0, 0);
        for cut in (0..bag.bytes.len()).step_by(step).rev() {
            file.set_len(cut as u64).unwrap();
            match ros1::read(&path, &ImportOptions::default()) {
                Err(e) => {
                    assert!((cut as u64) < bag.last_chunk_end, "{c:?} cut at {cut}: refused after the last chunk: {e}");
                    let s = e.to_string();
                    assert!(s.starts_with(&path.display().to_string()), "{c:?} cut at {cut}: {s}");
                    assert!(s.contains("byte "), "{c:?} cut at {cut}: the place is named: {s}");
                    refused += 1;
                }
                Ok((_, report)) => {
                    assert!(
                        (cut as u64) >= bag.last_chunk_end,
                        "{c:?} cut at {cut} (last chunk ends at {}) read",
                        bag.last_chunk_end
                    );
                    assert!(report.notes.iter().any(|n| n.contains("index")), "{c:?} cut at {cut}: {:?}", report.notes);
                    read_ok += 1;
                }
            }
        }
        assert!(refused > 100 && read_ok > 10, "{c:?}: {refused} refused, {read_ok} read");
    }
    // The places name the chunk.
    let bag = robot_bag(Compression::Bz2, |w| w);
    let cut = bag.chunk_pos[2] as usize + 60;
    let path = write("cut-chunk", &bag.bytes[..cut]);
    let e = ros1::read(&path, &ImportOptions::default()).unwrap_err();
    assert_refused(
        &e,
        &path,
        &[&format!("byte {} (record", bag.chunk_pos[2]), "after chunk 2", "runs past the end of the file"],
    );
    // A cut between two chunks: the bag header counts more chunks than the file holds.
    let path = write("cut-between", &bag.bytes[..bag.chunk_pos[3] as usize]);
    let e = ros1::read(&path, &ImportOptions::default()).unwrap_err();
    assert_refused(&e, &path, &["(end of file)", "the file ends after 3 chunks, but its bag header counts"]);
}

#[test]
fn a_wrong_message_type_on_the_scan_topic_is_refused() {
    // The connection says LaserScan; the messages are odometry.
    let mut w = BagWriter::new(Compression::Lz4);
    let scan = w.connection("/scan", "sensor_msgs/LaserScan");
    w.write(scan, T0, &odometry(0, T0, "odom", "base_link", (1.0, 2.0, 3.0)));
    let bag = w.finish();
    let path = write("odom-as-scan", &bag.bytes);
    let e = ros1::read(&path, &ImportOptions::default()).unwrap_err();
    assert_refused(
        &e,
        &path,
        &[&format!("message 1 on /scan (chunk 1 at byte {})", bag.chunk_pos[0]), "sensor_msgs/LaserScan"],
    );
    // The scan topic chosen is of another type.
    let mut w = BagWriter::new(Compression::None);
    let cloud = w.connection("/scan", "sensor_msgs/PointCloud2");
    let other = w.connection("/scan_2d", "sensor_msgs/LaserScan");
    w.write(cloud, T0, &[0u8; 30]);
    w.write(other, T0, &laser_scan(0, T0, "base_link", (-0.5, 0.5, 0.5), (0.0, 5.0), &[1.0, 2.0, 3.0]));
    let path = write("cloud", &w.finish().bytes);
    let opts = ImportOptions { scan_topics: vec!["/scan".into()], ..ImportOptions::default() };
    let e = ros1::read(&path, &opts).unwrap_err();
    assert_refused(&e, &path, &["scan topic '/scan' has no laser scans", "/scan_2d"]);
}

#[test]
fn a_message_too_short_is_refused_with_its_place() {
    let mut w = BagWriter::new(Compression::Bz2).chunk_bytes(1 << 30);
    let scan = w.connection("/scan", "sensor_msgs/LaserScan");
    let odom = w.connection("/odom", "nav_msgs/Odometry");
    for i in 0..3u64 {
        let t = T0 + i * 100 * MS;
        let mut s = laser_scan(0, t, "base_link", (-0.5, 0.5, 0.5), (0.0, 5.0), &[1.0, 2.0, 3.0]);
        if i == 2 {
            s.truncate(s.len() - 6);
        }
        w.write(scan, t, &s);
        let mut o = odometry(0, t, "odom", "base_link", (0.0, 0.0, 0.0));
        if i == 1 {
            o.truncate(100);
        }
        w.write(odom, t, &o);
    }
    let path = write("short", &w.finish().bytes);
    let e = ros1::read(&path, &ImportOptions::default()).unwrap_err();
    assert_refused(&e, &path, &["message 2 on /odom (chunk 1 at byte 4109)", "too short for a nav_msgs/Odometry"]);
}

#[test]
fn an_absurd_string_length_in_a_message_is_refused() {
    let mut w = BagWriter::new(Compression::Lz4);
    let scan = w.connection("/scan", "sensor_msgs/LaserScan");
    let mut s = laser_scan(0, T0, "base_link", (-0.5, 0.5, 0.5), (0.0, 5.0), &[1.0, 2.0, 3.0]);
    s[12..16].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
    w.write(scan, T0, &s);
    let bag = w.finish();
    let path = write("absurd-frame-id", &bag.bytes);
    let e = ros1::read(&path, &ImportOptions::default()).unwrap_err();
    let place = format!("message 1 on /scan (chunk 1 at byte {})", bag.chunk_pos[0]);
    assert_refused(&e, &path, &[&place, "'header.frame_id' needs 4294967280 bytes"]);
}

#[test]
fn a_missing_transform_for_a_lidar_frame_is_refused() {
    let mut w = BagWriter::new(Compression::None);
    let scan = w.connection("/scan", "sensor_msgs/LaserScan");
    let odom = w.connection("/odom", "nav_msgs/Odometry");
    w.write(scan, T0, &laser_scan(0, T0, "/laser", (-0.5, 0.5, 0.5), (0.0, 5.0), &[1.0, 2.0, 3.0]));
    w.write(odom, T0, &odometry(0, T0, "odom", "base_link", (0.0, 0.0, 0.0)));
    let path = write("no-tf", &w.finish().bytes);
    let e = ros1::read(&path, &ImportOptions::default()).unwrap_err();
    assert_refused(&e, &path, &["no transform from the base frame 'base_link' to the lidar frame 'laser'"]);
}

/// The bag with the bytes at `at` replaced.
fn patched(bag: &Bag, at: usize, with: &[u8]) -> Vec<u8> {
    let mut b = bag.bytes.clone();
    b[at..at + with.len()].copy_from_slice(with);
    b
}

#[test]
fn absurd_lengths_and_broken_chunks_are_refused() {
    let bag = robot_bag(Compression::Lz4, |w| w);
    let c1 = bag.chunk_pos[1] as usize;
    let opts = ImportOptions::default();
    let cases: Vec<(&str, Vec<u8>, Vec<String>)> = vec![
        (
            "header-len",
            patched(&bag, c1, &u32::MAX.to_le_bytes()),
            vec![format!("byte {c1} (record"), "record header of 4294967295 bytes runs past the end".into()],
        ),
        (
            "field-len",
            patched(&bag, c1 + 4, &0xFFFF_FF00u32.to_le_bytes()),
            vec![format!("byte {c1}"), "runs past the end of the header".into()],
        ),
        ("magic", patched(&bag, 0, b"#ROSBAG V1.2"), vec!["byte 0: '#ROSBAG V1.2': only ROS bag format 2.0".into()]),
        ("not-a-bag", patched(&bag, 0, b"hello"), vec!["byte 0: not a ROS bag".into()]),
        (
            "no-chunk-count",
            patched(&bag, find(&bag.bytes, b"chunk_count="), b"CHUNK_COUNT="),
            vec!["byte 13 (bag header): bag header: no 'chunk_count' field".into()],
        ),
        (
            "empty",
            Vec::new(),
            vec!["byte 0: the '#ROSBAG V2.0' line of 13 bytes runs past the end of the file (0 bytes left)".into()],
        ),
    ];
    for (name, bytes, want) in cases {
        let path = write(&format!("absurd-{name}"), &bytes);
        let e = ros1::read(&path, &opts).unwrap_err();
        assert_refused(&e, &path, &want.iter().map(String::as_str).collect::<Vec<_>>());
    }
    // A corrupt LZ4 frame: flip bytes in the middle of the first chunk's data.
    let end = bag.chunk_pos[1] as usize;
    let mut bytes = bag.bytes.clone();
    for b in &mut bytes[end - 150..end - 120] {
        *b ^= 0x5a;
    }
    let path = write("corrupt-lz4", &bytes);
    let e = ros1::read(&path, &opts).unwrap_err();
    assert_refused(&e, &path, &[&format!("byte {} (chunk 1)", bag.chunk_pos[0]), "lz4 chunk"]);
}

/// The robot's bag in one uncompressed chunk, patched by `patch` (given the chunk's offset).
fn bag_with_chunk_fields(patch: impl Fn(&mut Vec<u8>, usize)) -> (Bag, Vec<u8>) {
    let bag = robot_bag(Compression::None, |w| w.chunk_bytes(1 << 30));
    let mut bytes = bag.bytes.clone();
    patch(&mut bytes, bag.chunk_pos[0] as usize);
    (bag, bytes)
}

fn find(hay: &[u8], needle: &[u8]) -> usize {
    hay.windows(needle.len()).position(|w| w == needle).unwrap()
}

#[test]
fn bad_chunk_headers_are_refused() {
    let opts = ImportOptions::default();
    type Patch = Box<dyn Fn(&mut Vec<u8>, usize)>;
    let cases: Vec<(&str, Patch, &str)> = vec![
        (
            "zstd",
            Box::new(|b: &mut Vec<u8>, at| {
                let p = at + find(&b[at..], b"compression=none") + 12;
                b[p..p + 4].copy_from_slice(b"zstd");
            }),
            "compression 'zstd' is not one of none, bz2, lz4",
        ),
        (
            "no-size",
            Box::new(|b: &mut Vec<u8>, at| {
                let p = at + find(&b[at..], b"size=");
                b[p..p + 4].copy_from_slice(b"SIZE");
            }),
            "chunk: no 'size' field",
        ),
        (
            "size",
            Box::new(|b: &mut Vec<u8>, at| {
                let p = at + find(&b[at..], b"size=") + 5;
                b[p..p + 4].copy_from_slice(&u32::MAX.to_le_bytes());
            }),
            "header says 4294967295 bytes, more than the 256 MiB",
        ),
        (
            "size-small",
            Box::new(|b: &mut Vec<u8>, at| {
                let p = at + find(&b[at..], b"size=") + 5;
                b[p..p + 4].copy_from_slice(&7u32.to_le_bytes());
            }),
            "decompresses to more than the 7 bytes its header says",
        ),
    ];
    for (name, patch, want) in cases {
        let (bag, bytes) = bag_with_chunk_fields(patch);
        let path = write(&format!("chunk-{name}"), &bytes);
        let e = ros1::read(&path, &opts).unwrap_err();
        assert_refused(&e, &path, &[&format!("byte {} (chunk 1)", bag.chunk_pos[0]), want]);
    }
    // A message record inside the chunk without its 'conn' field.
    let (bag, bytes) = bag_with_chunk_fields(|b, at| {
        let p = at + find(&b[at..], b"conn=\x01\x00\x00\x00\x0d\x00\x00\x00time=");
        b[p..p + 4].copy_from_slice(b"CONN");
    });
    let path = write("msg-no-conn", &bytes);
    let e = ros1::read(&path, &opts).unwrap_err();
    assert_refused(
        &e,
        &path,
        &[&format!("byte {} (chunk 1, byte ", bag.chunk_pos[0]), "message data: no 'conn' field"],
    );
}

#[test]
fn read_log_detects_and_reads_bags() {
    let path = write("detect", &robot_bag(Compression::Bz2, |w| w).bytes);
    assert_eq!(mapkeeper_logs::detect_format(&path).unwrap(), LogFormat::Ros1Bag);
    let imported = read_log(&path, None, &ImportOptions::default()).unwrap();
    assert_eq!(imported.report.as_ref().unwrap().scans, 40);
    assert_eq!(imported.log.scans().count(), 40);
    let opts = ImportOptions { odometry: OdometryFrom::Topic("/nope".into()), ..ImportOptions::default() };
    let e = read_log(&path, Some(LogFormat::Ros1Bag), &opts).unwrap_err().to_string();
    assert!(e.contains("odometry topic '/nope'") && e.contains("/odom"), "{e}");
}

/// (stamp, ranges) of every scan of a log, to compare what a salvaged read kept.
fn scan_keys(log: &SensorLog) -> Vec<(u32, u64, Vec<u32>)> {
    log.scans().map(|s| (s.lidar_id, s.stamp_ns, s.ranges_m.iter().map(|r| r.to_bits()).collect())).collect()
}

/// `rosbag record`'s damage of the issue: the second chunk's record header length garbled
/// ("record header of 528281152 bytes runs past the end of the file"). Refused as it was without
/// `--salvage`; with it the chunks before and after are read and a note says which bytes were
/// skipped.
#[test]
fn a_damaged_chunk_header_is_read_past_with_salvage() {
    let salvage = ImportOptions { salvage: true, ..ImportOptions::default() };
    for c in Compression::ALL {
        let bag = robot_bag(c, |w| w);
        let whole = scan_keys(&read("whole", &bag.bytes, &ImportOptions::default()).unwrap().0);
        // A chunk of scans: the second last (the first chunks hold /tf_static and odometry).
        let k = bag.chunk_pos.len() - 2;
        let c1 = bag.chunk_pos[k] as usize;
        let bytes = patched(&bag, c1, &528_281_152u32.to_le_bytes());
        let path = write(&format!("salvage-header-{c:?}"), &bytes);
        let e = ros1::read(&path, &ImportOptions::default()).unwrap_err();
        assert_refused(&e, &path, &[&format!("byte {c1} (record"), "record header of 528281152 bytes"]);
        let (log, report) = ros1::read(&path, &salvage).unwrap();
        let got = scan_keys(&log);
        assert!(!got.is_empty() && got.len() < whole.len(), "{c:?}: {} of {} scans", got.len(), whole.len());
        assert!(got.iter().all(|k| whole.contains(k)), "{c:?}: a scan that is not in the bag");
        let next = bag.chunk_pos[k + 1];
        let want = format!("bytes {c1}-{} skipped, reading on at the next chunk, byte {next}", next - 1);
        assert!(
            report.notes.iter().any(|n| n.starts_with("salvaged:") && n.contains(&want)),
            "{c:?}: {:?}",
            report.notes
        );
    }
}

/// Damage anywhere in the chunks: with `--salvage` every read either succeeds with scans the bag
/// holds (compressed chunks carry checksums, so a corrupt byte costs its chunk, never a wrong
/// scan) and a note, or is refused naming the file; without it, a compressed bag is refused or
/// read unchanged. Truncation between chunks is noted, not refused, with `--salvage`.
#[test]
fn salvage_reads_past_damage_at_many_offsets() {
    let salvage = ImportOptions { salvage: true, ..ImportOptions::default() };
    for c in [Compression::Bz2, Compression::Lz4] {
        let bag = robot_bag_of(12, c, |w| w);
        let whole = scan_keys(&read("whole", &bag.bytes, &ImportOptions::default()).unwrap().0);
        let (from, to) = (bag.chunk_pos[0] as usize, bag.last_chunk_end as usize);
        let (mut salvaged, mut refused) = (0, 0);
        for at in (from..to).step_by((to - from) / 150) {
            let mut bytes = bag.bytes.clone();
            bytes[at] ^= 0x5a;
            let path = write(&format!("salvage-flip-{c:?}"), &bytes);
            match ros1::read(&path, &ImportOptions::default()) {
                Ok((log, _)) => assert_eq!(scan_keys(&log), whole, "{c:?} byte {at}: read, and different"),
                Err(e) => assert!(e.to_string().starts_with(&path.display().to_string()), "{c:?} byte {at}: {e}"),
            }
            match ros1::read(&path, &salvage) {
                Ok((log, report)) => {
                    let got = scan_keys(&log);
                    assert!(got.iter().all(|k| whole.contains(k)), "{c:?} byte {at}: a scan that is not in the bag");
                    if got != whole {
                        assert!(report.notes.iter().any(|n| n.starts_with("salvaged:")), "{c:?} byte {at}: no note");
                        salvaged += 1;
                    }
                }
                Err(e) => {
                    assert!(e.to_string().starts_with(&path.display().to_string()), "{c:?} byte {at}: {e}");
                    refused += 1;
                }
            }
        }
        // Refused: damage in the first chunk, which holds /tf_static (no lidar mount without it).
        assert!(salvaged >= 30 && refused <= 20, "{c:?}: {salvaged} salvaged, {refused} refused");
        // Cut between two chunks: a prefix, and the truncation noted.
        let n = bag.chunk_pos.len();
        let path = write(&format!("salvage-cut-{c:?}"), &bag.bytes[..bag.chunk_pos[n - 1] as usize]);
        let (log, report) = ros1::read(&path, &salvage).unwrap();
        let got = scan_keys(&log);
        assert!(!got.is_empty() && got[..] == whole[..got.len()], "{c:?}: not a prefix");
        let want = format!("salvaged: the file ends after {} chunks, but its bag header counts {n}", n - 1);
        assert!(report.notes.iter().any(|note| note.contains(&want)), "{:?}", report.notes);
    }
}

/// The robot's bag with every header stamp frozen at T0 (a driver whose clock never moved): the
/// recorder's times still order the messages.
fn frozen_header_bag() -> Bag {
    let mut w = BagWriter::new(Compression::None).chunk_bytes(900);
    let front = w.connection("/scan", "sensor_msgs/LaserScan");
    let odom = w.connection("/odom", "nav_msgs/Odometry");
    for i in 0..12u32 {
        let t = T0 + u64::from(i) * 100 * MS;
        let pose = (0.1 * f64::from(i), 0.0, 0.0);
        w.write(odom, t, &odometry(i, T0, "odom", "base_link", pose));
        let f = laser_scan(i, T0, "base_link", (-1.0, 1.0, 0.5), (0.05, 8.0), &front_ranges(i as usize));
        w.write(front, t + 10 * MS, &f);
    }
    w.finish()
}

#[test]
fn header_stamps_that_cannot_order_the_messages_give_way_to_record_times_with_a_note() {
    use mapkeeper_logs::TimeSource;
    let bag = frozen_header_bag();
    let (log, report) = read("frozen", &bag.bytes, &ImportOptions::default()).unwrap();
    let note = report.notes.iter().find(|n| n.starts_with("header stamps not used")).expect("a note");
    assert!(note.contains("/scan: 11 of 11 consecutive stamps repeat") && note.contains("record time"), "{note}");
    let scans: Vec<u64> = log.scans().map(|s| s.stamp_ns / MS).collect();
    assert_eq!(scans, (0..12).map(|i| 10 + 100 * i).collect::<Vec<u64>>(), "record times, epoch the first /odom");
    // Each scan follows its odometry reading, as recorded (sorted by the frozen stamps, every
    // odometry reading came before every scan).
    let order: Vec<&str> = log
        .records
        .iter()
        .map(|r| match r {
            mapkeeper_sensor::LogRecord::Scan(_) => "s",
            _ => "o",
        })
        .take(4)
        .collect();
    assert_eq!(order, ["o", "s", "o", "s"]);
    // As written, on request: the frozen stamps, and a note that says what that costs.
    let stamp = ImportOptions { time_source: TimeSource::Stamp, ..ImportOptions::default() };
    let (log, report) = read("frozen-stamp", &bag.bytes, &stamp).unwrap();
    assert!(log.scans().all(|s| s.stamp_ns == 0));
    assert!(report.notes.iter().any(|n| n.starts_with("header stamps taken as written")), "{:?}", report.notes);
    // A sane bag by its order on request: the record times, as --stamp record gives them.
    let line = ImportOptions { time_source: TimeSource::Line, ..ImportOptions::default() };
    let sane = robot_bag(Compression::None, |w| w);
    let by_line = read("sane-line", &sane.bytes, &line).unwrap();
    let record = ImportOptions { stamp: StampFrom::Record, ..ImportOptions::default() };
    let by_record = read("sane-record", &sane.bytes, &record).unwrap();
    assert_eq!(by_line.0.records, by_record.0.records);
    assert!(by_line.1.notes.iter().any(|n| n.starts_with("header stamps not used (--time-source line)")));
    // A sane bag as it is: its header stamps, no note.
    let (_, report) = read("sane", &sane.bytes, &ImportOptions::default()).unwrap();
    assert!(!report.notes.iter().any(|n| n.contains("header stamps")), "{:?}", report.notes);
}
