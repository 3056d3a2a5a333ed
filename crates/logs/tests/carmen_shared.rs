//! The CARMEN reader on the real logs of `../shared/data/carmen/` (skipped, with a note, when
//! that folder is absent): every scan, pose and the facts of the data's README.

#![allow(clippy::unwrap_used)]

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

/// `v` as C's `%g` prints it with an exponent: six significant digits, `1.13486e+09`.
fn percent_g(v: f64) -> String {
    let s = format!("{v:.5e}");
    let (mantissa, exponent) = s.split_once('e').unwrap();
    format!("{mantissa}e{:+03}", exponent.parse::<i32>().unwrap())
}

#[test]
fn intel_with_coarse_timestamps_converts_to_the_original_log_with_a_note() {
    // A public corrected log printed its stamps as %g of the epoch: one printed step is 10,000 s,
    // so every line of a 20-minute drive had the same time. Intel rewritten that way.
    use std::io::Read as _;
    let Some(path) = shared("intel-corrected.log.gz") else { return };
    let mut text = String::new();
    flate2::read::GzDecoder::new(std::fs::File::open(&path).unwrap()).read_to_string(&mut text).unwrap();
    let rewritten: String = text
        .lines()
        .map(|line| {
            let mut f: Vec<String> = line.split_whitespace().map(String::from).collect();
            let stamps = match f.first().map(String::as_str) {
                Some("FLASER") => {
                    let n: usize = f[1].parse().unwrap();
                    vec![n + 8, n + 10]
                }
                Some("ODOM") => vec![7, 9],
                _ => vec![],
            };
            for i in stamps {
                f[i] = percent_g(1.13486e9 + f[i].parse::<f64>().unwrap());
            }
            f.join(" ") + "\n"
        })
        .collect();
    assert!(rewritten.contains(" 1.13486e+09 h ") || rewritten.contains(" 1.13486e+09 "), "the stamps are %g");
    let dir = std::env::temp_dir().join(format!("mapkeeper-carmen-coarse-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let coarse = dir.join("intel-g.log");
    std::fs::write(&coarse, rewritten).unwrap();
    // Without a rate the time is lost, and the error says which line and which flag.
    let e = read_log(&coarse, None, &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("intel-g.log: line ") && e.contains("--rate HZ") && e.contains("909 of 909"), "{e}");
    // With the scan rate: the original's scans, odometry and reference, in the original's order.
    let options = ImportOptions { rate_hz: Some(0.34), ..ImportOptions::default() };
    let got = read_log(&coarse, None, &options).unwrap();
    let want = read_log(&path, None, &ImportOptions::default()).unwrap();
    let unstamped = |log: &mapkeeper_sensor::SensorLog| -> Vec<String> {
        log.records
            .iter()
            .map(|r| {
                let mut v = serde_json::to_value(r).unwrap();
                v.as_object_mut().unwrap().remove("stamp_ns");
                v.to_string()
            })
            .collect()
    };
    assert_eq!(unstamped(&got.log), unstamped(&want.log));
    let report = got.report.unwrap();
    let note = report.notes.iter().find(|n| n.starts_with("timestamps not used")).expect("the note");
    println!("note: {note}");
    assert!(note.contains("ordered by line") && note.contains("--rate 0.34 Hz of FLASER"), "{note}");
    assert!((report.duration_s - 909.0 / 0.34).abs() < 1.0, "{}", report.duration_s);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn freiburg_thinned_by_travel_keeps_one_scan_a_metre() {
    let Some(path) = shared("freiburg-079-corrected.log.gz") else { return };
    let whole = read_log(&path, None, &ImportOptions::default()).unwrap().log;
    for (thinning, lo, hi) in
        [(mapkeeper_logs::Thinning::EveryMetres(1.0), 350, 430), (mapkeeper_logs::Thinning::KeepEvery(10), 480, 480)]
    {
        let options = ImportOptions { thinning, ..ImportOptions::default() };
        let imported = read_log(&path, None, &options).unwrap();
        let log = imported.log;
        let n = log.scans().count();
        assert!((lo..=hi).contains(&n), "{thinning:?}: {n} scans");
        assert_eq!(log.odometry().count(), whole.odometry().count(), "odometry all kept");
        assert_eq!(log.truth().count(), whole.truth().count(), "reference all kept");
        let report = imported.report.unwrap();
        assert!(report.notes.iter().any(|n| n.contains(" of 4791 scans kept")), "{:?}", report.notes);
        if let mapkeeper_logs::Thinning::EveryMetres(m) = thinning {
            // Consecutive kept scans are at least m apart along the odometry's path.
            let odo: Vec<(u64, mapkeeper_grid::Pose2)> = log.odometry().map(|o| (o.stamp_ns, o.pose_in_odom)).collect();
            let kept: Vec<u64> = log.scans().map(|s| s.stamp_ns).collect();
            for w in kept.windows(2) {
                let path: f64 =
                    odo.windows(2).filter(|p| p[0].0 >= w[0] && p[1].0 <= w[1]).map(|p| p[0].1.distance(&p[1].1)).sum();
                assert!(path >= m - 1e-9, "{path} m between scans at {} and {} ns", w[0], w[1]);
            }
        }
    }
}
