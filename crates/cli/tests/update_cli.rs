//! End-to-end test of `mapkeeper update` on a hand-built log: the synchronisation window flag
//! (checked, naming the flag) and the output files, `recoveries.csv` among them.
// Helpers outside `#[test]` functions unwrap too: a failure is a test failure.
#![allow(clippy::unwrap_used)]

mod common;

use common::{mapkeeper, s, scratch};

use mapkeeper_grid::{Pose2, map_io};
use mapkeeper_sensor::{LaserScan, LogHeader, LogRecord, LogWriter, OdometryReading, TruePose};
use mapkeeper_testkit::rooms::ten_by_ten_centred;

/// A whole turn of beams from `robot` in `ten_by_ten_centred()` (inner wall faces at ±4.9 m).
fn scan(stamp_ns: u64, lidar_id: u32, robot: Pose2) -> LaserScan {
    let inc = 2.0 * std::f64::consts::PI / 360.0;
    let ranges_m = (0..360)
        .map(|k| {
            let a = robot.yaw - std::f64::consts::PI + f64::from(k) * inc;
            let (dx, dy) = (a.cos(), a.sin());
            let tx = if dx > 0.0 { (4.9 - robot.x) / dx } else { (-4.9 - robot.x) / dx };
            let ty = if dy > 0.0 { (4.9 - robot.y) / dy } else { (-4.9 - robot.y) / dy };
            tx.min(ty) as f32
        })
        .collect();
    LaserScan {
        stamp_ns,
        lidar_id,
        lidar_in_robot: Pose2::IDENTITY,
        angle_min_rad: -std::f64::consts::PI,
        angle_increment_rad: inc,
        range_min_m: 0.05,
        range_max_m: 20.0,
        ranges_m,
        sweep: None,
    }
}

#[test]
fn update_groups_unsynchronised_lidars_and_writes_the_pose_recoveries() {
    let dir = scratch("update-cli", "sync");
    let map = dir.join("room.yaml");
    map_io::save_map(&ten_by_ten_centred(), &map).unwrap();
    let log_dir = dir.join("log");
    std::fs::create_dir_all(&log_dir).unwrap();
    let mut w = LogWriter::create(&log_dir.join("log.jsonl"), &LogHeader::new(serde_json::Map::new())).unwrap();
    // The robot stands at (1, 0.5); the "true" poses the updater is given (--true-poses) are
    // 1.6 m and 0.6 rad off, so the check says Lost and pose updating finds the right pose.
    let robot = Pose2::new(1.0, 0.5, 0.0);
    let t = 1_000_000_000u64;
    w.write(&LogRecord::Odom(OdometryReading { stamp_ns: t, pose_in_odom: Pose2::IDENTITY })).unwrap();
    w.write(&LogRecord::Truth(TruePose { stamp_ns: t, pose_in_map: Pose2::new(2.2, -0.4, 0.6) })).unwrap();
    w.write(&LogRecord::Scan(scan(t, 0, robot))).unwrap();
    w.write(&LogRecord::Scan(scan(t + 20_000_000, 1, robot))).unwrap();
    w.finish().unwrap();
    let run = |out: &str, window: &str| {
        mapkeeper(&[
            "update",
            "--map",
            s(&map),
            "--log",
            s(&log_dir),
            "--true-poses",
            "--sync-window-s",
            window,
            "--out",
            s(&dir.join(out)),
        ])
    };
    for bad in ["-0.1", "nan", "inf"] {
        let o = run("bad", bad);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && e.contains("--sync-window-s"), "{bad}: {e}");
        assert!(!dir.join("bad").exists());
    }
    // Default-like window: the two scans 20 ms apart are one step.
    let o = run("grouped", "0.05");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let steps = std::fs::read_to_string(dir.join("grouped/scans.csv")).unwrap();
    assert_eq!(steps.lines().count(), 2, "{steps}");
    assert!(steps.lines().nth(1).unwrap().starts_with("1.020000000,processed,lost,"), "{steps}");
    let rec = std::fs::read_to_string(dir.join("grouped/recoveries.csv")).unwrap();
    let rows: Vec<&str> = rec.lines().collect();
    assert_eq!(rows[0], "time_s,verdict,result,x_m,y_m,yaw_rad,reason");
    assert_eq!(rows.len(), 2, "{rec}");
    assert!(rows[1].starts_with("1.020000000,lost,recovered,1.0"), "{rec}");
    // Window 0: one step per scan.
    let o = run("exact", "0");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let steps = std::fs::read_to_string(dir.join("exact/scans.csv")).unwrap();
    assert_eq!(steps.lines().count(), 3, "{steps}");
    std::fs::remove_dir_all(&dir).unwrap();
}
