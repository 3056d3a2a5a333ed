//! Replays the kept corpus of the log readers' fuzz targets (`fuzz/corpus/{ros1_bag, ros2_mcap,
//! carmen}/`, `docs/reliability.md`) through the property the targets check
//! (`fuzz/check/log_readers.rs`): no input panics a reader, with or without `--salvage`, and a
//! refusal is one line naming the file.
//!
//! The seed corpus is written by this file's ignored test from bags and logs made by the test
//! writers (`support/ros1_writer.rs`, `McapRunWriter`) and cut, patched and garbled:
//! `cargo test -p mapkeeper-logs --test fuzz_corpus -- --ignored write_seed_corpus`.
#![allow(clippy::unwrap_used)]

#[path = "../../../fuzz/check/log_readers.rs"]
mod log_readers;
#[path = "support/ros1_writer.rs"]
mod ros1_writer;

use mapkeeper_grid::{GridGeometry, OccupancyGrid, Pose2};
use mapkeeper_logs::McapRunWriter;
use mapkeeper_sensor::LaserScan;
use mapkeeper_testkit::corpus::{self, corpus_dir};
use ros1_writer::{BagWriter, Compression, laser_scan, odometry, tf_message};
use std::path::Path;

/// Replays `target`'s corpus through `property`; some inputs must be read and some refused.
fn replay(target: &str, reads_per_input: usize, property: fn(&[u8], &Path) -> usize) {
    let dir = log_readers::scratch_dir(&format!("replay-{target}"));
    let (mut ok, mut total) = (0, 0);
    corpus::replay(target, 10, |_, bytes| {
        ok += property(bytes, &dir);
        total += reads_per_input;
    });
    eprintln!("{target} corpus: {ok} of {total} reads accepted");
    assert!(ok > 0 && ok < total, "{target}: {ok} of {total} reads accepted: the corpus tests one side only");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ros1_bag_corpus_never_panics_and_refusals_name_the_file() {
    replay("ros1_bag", 2, log_readers::ros1_bag);
}

#[test]
fn ros2_mcap_corpus_never_panics_and_refusals_name_the_file() {
    replay("ros2_mcap", 2, log_readers::ros2_mcap);
}

#[test]
fn carmen_corpus_never_panics_and_refusals_name_the_file() {
    replay("carmen", 6, log_readers::carmen);
}

/// Small variants of a good input: cut at several places, bytes patched, and the whole.
fn damaged(good: &[u8]) -> Vec<(String, Vec<u8>)> {
    let n = good.len();
    let mut out = vec![("whole".to_string(), good.to_vec())];
    for (k, cut) in [13, n / 4, n / 2, n - n / 8, n - 1].into_iter().enumerate() {
        out.push((format!("cut{k}"), good[..cut.min(n)].to_vec()));
    }
    for (k, at) in [n / 3, n / 2, 2 * n / 3].into_iter().enumerate() {
        let mut b = good.to_vec();
        for x in &mut b[at..(at + 8).min(n)] {
            *x ^= 0xff;
        }
        out.push((format!("flip{k}"), b));
    }
    out
}

fn ros1_seed(compression: Compression, scans: u32) -> Vec<u8> {
    let mut w = BagWriter::new(compression).chunk_bytes(600);
    let tf_static = w.connection("/tf_static", "tf2_msgs/TFMessage");
    let scan = w.connection("/scan", "sensor_msgs/LaserScan");
    let odom = w.connection("/odom", "nav_msgs/Odometry");
    const T0: u64 = 1_700_000_000_000_000_000;
    w.write(tf_static, T0, &tf_message(&[(0, "base_link", "laser", [0.2, 0.0, 0.1], [0.0, 0.0, 0.0])]));
    for i in 0..scans {
        let t = T0 + u64::from(i) * 100_000_000;
        w.write(odom, t, &odometry(i, t, "odom", "base_link", (0.1 * f64::from(i), 0.0, 0.0)));
        w.write(scan, t + 1, &laser_scan(i, t, "laser", (-1.0, 1.0, 0.5), (0.05, 8.0), &[1.0, 2.0, 3.0, 4.0, 5.0]));
    }
    w.finish().bytes
}

fn mcap_seed(dir: &Path, name: &str, scans: u64) -> Vec<u8> {
    let path = dir.join(name);
    let mut w = McapRunWriter::create(&path).unwrap();
    for k in 0..scans {
        let t = 20_000_000 + k * 100_000_000;
        let s = LaserScan {
            stamp_ns: t,
            lidar_id: 0,
            lidar_in_robot: Pose2::new(0.2, 0.0, 0.0),
            angle_min_rad: -1.0,
            angle_increment_rad: 0.5,
            range_min_m: 0.05,
            range_max_m: 8.0,
            ranges_m: vec![1.0, 2.0, 3.0, 4.0, 5.0],
            sweep: None,
        };
        w.scan(&s).unwrap();
        w.odometry(t, Pose2::new(0.1 * k as f64, 0.0, 0.0)).unwrap();
        w.true_pose(t, Pose2::new(0.1 * k as f64, 0.0, 0.0)).unwrap();
        w.verdict(t, "update").unwrap();
    }
    let g = GridGeometry::new(4, 3, 0.5, Pose2::IDENTITY).unwrap();
    w.map(scans * 100_000_000, &OccupancyGrid::filled(g, mapkeeper_grid::CellState::Free)).unwrap();
    w.finish().unwrap();
    std::fs::read(&path).unwrap()
}

const CARMEN_CORRECTED: &str = "# a corrected log\n\
PARAM robot_front_laser_max 80.0 nohost 0.0\n\
FLASER 5 1.0 2.0 3.0 4.0 5.0 0.0 0.0 0.0 0.0 0.0 0.0 1.0 nohost 1.0\n\
ODOM 0.01 0.0 0.0 0.0 0.0 0.0 1.05 nohost 1.05\n\
FLASER 5 1.0 2.0 3.0 4.0 5.0 0.1 0.0 0.0 0.1 0.0 0.0 1.1 nohost 1.1\n\
ODOM 0.11 0.0 0.0 0.0 0.0 0.0 1.15 nohost 1.15\n\
FLASER 5 1.0 2.0 3.0 4.0 5.0 0.2 0.0 0.0 0.2 0.0 0.0 1.2 nohost 1.2\n";

const CARMEN_RAW: &str = "ODOM 0.0 0.0 0.0 0.0 0.0 0.0 0.95 nohost 0.95\n\
FLASER 5 1.0 2.0 3.0 4.0 5.0 0.0 0.0 0.0 0.5 0.1 0.2 1.0 nohost 1.0\n\
ODOM 0.1 0.0 0.0 0.0 0.0 0.0 1.05 nohost 1.05\n\
ROBOTLASER1 0 -1.0 2.0 0.5 8.0 0.01 0 5 1.0 2.0 3.0 4.0 5.0 0 0.1 0.0 0.0 0.6 0.1 0.2 0.0 0.0 0.0 0.0 0.0 1.1 nohost 1.1\n\
FLASER 5 1.0 2.0 3.0 4.0 5.0 0.2 0.0 0.0 0.7 0.1 0.2 1.2 nohost 1.2\n";

/// Writes the seed corpus (run by hand; see the module docs).
#[test]
#[ignore = "writes fuzz/corpus/: run by hand when the readers' inputs change"]
fn write_seed_corpus() {
    let scratch = log_readers::scratch_dir("seed");
    let write = |target: &str, name: &str, bytes: &[u8]| {
        let dir = corpus_dir(target);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(name), bytes).unwrap();
    };
    for (c, tag) in [(Compression::None, "none"), (Compression::Bz2, "bz2"), (Compression::Lz4, "lz4")] {
        for (name, b) in damaged(&ros1_seed(c, 4)) {
            write("ros1_bag", &format!("{tag}_{name}.bag"), &b);
        }
    }
    let bare = mcap_seed(&scratch, "seed.mcap", 4);
    for (name, b) in damaged(&bare) {
        write("ros2_mcap", &format!("file_{name}.mcap"), &b);
    }
    let yaml = b"rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  relative_file_paths:\n    - bag_0.mcap\n  duration:\n    nanoseconds: 400000000\n";
    for (name, y) in [
        ("listed", &yaml[..]),
        ("unlisted", b"rosbag2_bagfile_information:\n  version: 5\n"),
        ("sqlite", b"storage_identifier: sqlite3\n"),
    ] {
        let folder = [y, log_readers::FOLDER_SEPARATOR, &bare].concat();
        write("ros2_mcap", &format!("folder_{name}.bin"), &folder);
    }
    for (text, tag) in [(CARMEN_CORRECTED, "corrected"), (CARMEN_RAW, "raw")] {
        for (name, b) in damaged(text.as_bytes()) {
            write("carmen", &format!("{tag}_{name}.log"), &b);
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
}

/// Found by `ros2_mcap`: an uncompressed chunk whose record is longer than the rest of the
/// chunk made the `mcap` crate subtract past zero (a panic with overflow checks); the reader
/// now refuses it first, the same in every build.
#[test]
fn a_record_overrunning_an_uncompressed_chunk_is_refused_in_every_build() {
    let file = corpus_dir("ros2_mcap").join("regression_record_overruns_plain_chunk.mcap");
    let e = mapkeeper_logs::ros2::read(&file, &mapkeeper_logs::ImportOptions::default()).unwrap_err().to_string();
    assert_eq!(
        e,
        format!(
            "{}: byte 153: MCAP: a record of 255 bytes in an uncompressed chunk with 91 bytes left: the chunk is damaged",
            file.display()
        )
    );
}

/// Found by `ros2_mcap`: an attachment record shorter than the lengths it declares made the
/// `mcap` crate slice past its end (a panic in every build); the reader no longer parses
/// records it does not use, so the file is read as far as it makes sense and refused there.
#[test]
fn an_attachment_shorter_than_its_lengths_is_never_parsed() {
    let file = corpus_dir("ros2_mcap").join("regression_attachment_shorter_than_its_lengths.mcap");
    let e = mapkeeper_logs::ros2::read(&file, &mapkeeper_logs::ImportOptions::default()).unwrap_err().to_string();
    assert!(e.starts_with(&format!("{}: ", file.display())), "{e}");
    assert!(!e.contains('\n'), "{e}");
    println!("{e}");
}
