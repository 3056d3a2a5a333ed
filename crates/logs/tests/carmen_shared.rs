//! The CARMEN reader on the real logs of `../shared/data/carmen/` (skipped, with a note, when
//! that folder is absent): every scan, pose and the facts of the data's README.

use mapkeeper_logs::{ImportOptions, LogFormat, detect_format, read_log};
use std::path::PathBuf;

fn shared(name: &str) -> Option<PathBuf> {
    mapkeeper_common::shared_data::path(&format!("data/carmen/{name}"), "the CARMEN tests on the real logs")
}

#[test]
fn the_three_shared_logs_read_with_the_readme_facts() {
    // (file, scans, beams, no-return value, lidar x in the base frame: the corrected poses are
    // the lidar's, so Freiburg's robot_frontlaser_offset is not applied again)
    for (name, scans, beams, no_return, mount_x) in [
        ("intel-corrected.log.gz", 910, 180, 81.83f32, 0.0),
        ("freiburg-079-corrected.log.gz", 4791, 360, 81.91, 0.0),
        ("aces-corrected.log.gz", 440, 180, 50.0, 0.0),
    ] {
        let Some(path) = shared(name) else { return };
        assert_eq!(detect_format(&path).unwrap(), LogFormat::Carmen);
        let imported = read_log(&path, None, &ImportOptions::default()).unwrap();
        let report = imported.report.unwrap();
        let log = imported.log;
        assert_eq!(log.scans().count(), scans, "{name}");
        assert_eq!(report.truth_poses, scans, "{name}: one reference pose per scan");
        assert_eq!(log.odometry().count(), scans, "{name}: one re-chained odometry reading per scan");
        let s = log.scans().next().unwrap();
        assert_eq!(s.ranges_m.len(), beams);
        assert_eq!(s.range_max_m, no_return, "{name}");
        assert_eq!(s.lidar_in_robot.x, mount_x, "{name}");
        assert!((s.angle_min_rad + std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        println!("{}", report.lines().join("\n"));
        // The re-chained odometry travels about as far as the reference (the same increments,
        // up to the drift SLAM corrected).
        let len = |v: Vec<mapkeeper_grid::Pose2>| v.windows(2).map(|w| w[0].distance(&w[1])).sum::<f64>();
        let odo = len(log.odometry().map(|o| o.pose_in_odom).collect());
        let truth = len(log.truth().map(|t| t.pose_in_map).collect());
        assert!((odo / truth - 1.0).abs() < 0.1, "{name}: odometry {odo:.1} m against reference {truth:.1} m");
    }
}

#[test]
fn intel_backward_timestamps_are_counted() {
    let Some(path) = shared("intel-corrected.log.gz") else { return };
    let report = read_log(&path, None, &ImportOptions::default()).unwrap().report.unwrap();
    let scan_steps: usize = report.backward_steps.iter().filter(|b| b.stream == "FLASER").map(|b| b.count).sum();
    assert_eq!(scan_steps, 4, "{:?}", report.backward_steps);
    let largest = report.backward_steps.iter().map(|b| b.largest_s).fold(0.0, f64::max);
    assert!(largest > 0.5 && largest < 0.9, "{largest}");
}
