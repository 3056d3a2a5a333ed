//! Unit tests of `assemble`.

use super::*;

fn scan(topic: &str, frame: &str, t: u64) -> RawScan {
    RawScan {
        topic: topic.into(),
        frame_id: frame.into(),
        stamp_ns: t,
        angle_min_rad: -1.0,
        angle_increment_rad: 0.5,
        range_min_m: 0.1,
        range_max_m: 20.0,
        ranges_m: vec![1.0; 5],
        time_increment_s: 0.0,
        place: format!("message at {t}"),
        record_ns: None,
    }
}

fn tf(parent: &str, child: &str, t: Rigid3, is_static: bool) -> RawTransform {
    RawTransform { stamp_ns: 0, parent: parent.into(), child: child.into(), transform: t, is_static, record_ns: None }
}

#[test]
fn mounts_chain_through_static_transforms_and_upside_down_lidars_are_mirrored() {
    let mut a = Assembler::new(Path::new("x.bag"), "test");
    a.transform(tf("base_link", "plate", Rigid3::from_xyz_rpy([0.2, 0.0, 0.3], [0.0, 0.0, 0.0]), true));
    a.transform(tf("plate", "laser", Rigid3::from_xyz_rpy([0.1, -0.2, 0.0], [std::f64::consts::PI, 0.0, 0.5]), true));
    a.scan(scan("/scan", "laser", 1_000_000_000));
    a.odometry(RawOdometry { topic: "/odom".into(), stamp_ns: 1_000_000_000, pose: Pose2::IDENTITY, record_ns: None });
    let (log, report) = a.finish(&ImportOptions::default()).unwrap();
    let s = log.scans().next().unwrap();
    assert!(
        (s.lidar_in_robot.x - 0.3).abs() < 1e-9 && (s.lidar_in_robot.y + 0.2).abs() < 1e-9,
        "{:?}",
        s.lidar_in_robot
    );
    // Roll π, yaw 0.5: the lidar's x axis points at 0.5 rad in the base frame and its beams
    // turn clockwise there, so the scan is mirrored (angles negated).
    assert!(report.lidars[0].mirrored);
    assert!((s.angle_min_rad - 1.0).abs() < 1e-12 && (s.angle_increment_rad + 0.5).abs() < 1e-12);
    assert!((s.lidar_in_robot.yaw - 0.5).abs() < 1e-9, "{}", s.lidar_in_robot.yaw);
    assert_eq!(s.stamp_ns, 0, "time is re-based on the first stamp");
    assert_eq!(report.epoch_ns, 1_000_000_000);
}

#[test]
fn missing_transform_and_unknown_topic_are_named() {
    let mut a = Assembler::new(Path::new("x.bag"), "test");
    a.scan(scan("/scan", "laser", 0));
    let e = a.finish(&ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("x.bag") && e.contains("'laser'") && e.contains("base_link"), "{e}");
    let mut a = Assembler::new(Path::new("x.bag"), "test");
    a.scan(scan("/scan", "base_link", 0));
    let opts = ImportOptions { scan_topics: vec!["/front".into()], ..ImportOptions::default() };
    let e = a.finish(&opts).unwrap_err().to_string();
    assert!(e.contains("'/front'") && e.contains("/scan"), "{e}");
}

#[test]
fn lidars_can_be_chosen_by_frame_from_one_topic() {
    let mut a = Assembler::new(Path::new("x.bag"), "test");
    for (k, frame) in ["front", "rear", "front", "rear"].into_iter().enumerate() {
        a.scan(scan("/scan", frame, k as u64 * 1_000));
    }
    a.known_mount("front", Pose2::new(0.3, 0.0, 0.0), "test");
    a.known_mount("rear", Pose2::new(-0.3, 0.0, std::f64::consts::PI), "test");
    a.odometry(RawOdometry { topic: "/odom".into(), stamp_ns: 0, pose: Pose2::IDENTITY, record_ns: None });
    let opts = ImportOptions { scan_frames: vec!["rear".into(), "front".into()], ..ImportOptions::default() };
    let (log, report) = a.finish(&opts).unwrap();
    assert_eq!(report.lidars.len(), 2);
    assert_eq!((report.lidars[0].frame_id.as_str(), report.lidars[0].topic.as_str()), ("rear", "/scan"));
    let ids: Vec<(u32, u64)> = log.scans().map(|s| (s.lidar_id, s.stamp_ns)).collect();
    assert_eq!(ids, vec![(1, 0), (0, 1_000), (1, 2_000), (0, 3_000)]);
    let e = a_err(&["left"]);
    assert!(e.contains("scan frame 'left'") && e.contains("front, rear"), "{e}");
}

fn a_err(frames: &[&str]) -> String {
    let mut a = Assembler::new(Path::new("x.bag"), "test");
    a.scan(scan("/scan", "front", 0));
    a.scan(scan("/scan", "rear", 0));
    let opts =
        ImportOptions { scan_frames: frames.iter().map(|f| f.to_string()).collect(), ..ImportOptions::default() };
    a.finish(&opts).unwrap_err().to_string()
}

#[test]
fn backward_stamps_are_clamped_and_counted() {
    let mut a = Assembler::new(Path::new("x.log"), "test");
    for t in [10, 20, 15, 30, 5, 40] {
        a.scan(scan("/scan", "base_link", t * 1_000_000));
    }
    a.transform(tf("odom", "base_link", Rigid3::IDENTITY, false));
    let (log, report) = a.finish(&ImportOptions::default()).unwrap();
    assert_eq!(report.backward_steps.len(), 1);
    assert_eq!(report.backward_steps[0].count, 2);
    assert!((report.backward_steps[0].largest_s - 0.025).abs() < 1e-12);
    let stamps: Vec<u64> = log.scans().map(|s| s.stamp_ns).collect();
    // The odometry transform at 0 s is the log's first stamp; a stamp that steps back lands
    // 1 ns after the one before.
    assert_eq!(stamps, vec![10_000_000, 20_000_000, 20_000_001, 30_000_000, 30_000_001, 40_000_000]);
    assert_eq!(report.odometry_source, "/tf odom -> base_link");
}

#[test]
fn stamps_that_cannot_order_the_messages_without_record_times_are_refused_naming_the_flag() {
    // A frozen clock and no record times to order the messages by: refused, unless the
    // stamps are asked for as written.
    let frozen = || {
        let mut a = Assembler::new(Path::new("x.bag"), "test");
        for _ in 0..10 {
            a.scan(scan("/scan", "base_link", 5_000));
            a.odometry(RawOdometry { topic: "/odom".into(), stamp_ns: 5_000, pose: Pose2::IDENTITY, record_ns: None });
        }
        a
    };
    let e = frozen().finish(&ImportOptions::default()).unwrap_err().to_string();
    assert!(e.starts_with("x.bag: ") && e.contains("9 of 9 consecutive stamps repeat"), "{e}");
    assert!(e.contains("no record times") && e.contains("--time-source stamp"), "{e}");
    let stamp = ImportOptions { time_source: TimeSource::Stamp, ..ImportOptions::default() };
    let (log, report) = frozen().finish(&stamp).unwrap();
    assert_eq!(log.scans().count(), 10);
    assert!(report.notes.iter().any(|n| n.starts_with("header stamps taken as written")), "{:?}", report.notes);
}

#[test]
fn a_stream_the_import_does_not_read_cannot_re_time_the_log() {
    // /scan is sane, /scan_rear's driver clock is frozen. Read without /scan_rear, nothing
    // is re-timed; read with it, its stamps are judged (and, with no record times, refused).
    let build = || {
        let mut a = Assembler::new(Path::new("x.bag"), "test");
        for k in 0..10u64 {
            a.scan(scan("/scan", "base_link", k * 1_000));
            a.scan(scan("/scan_rear", "base_link", 5_000));
            a.odometry(RawOdometry {
                topic: "/odom".into(),
                stamp_ns: k * 1_000,
                pose: Pose2::IDENTITY,
                record_ns: None,
            });
        }
        a
    };
    let front = ImportOptions { scan_topics: vec!["/scan".into()], ..ImportOptions::default() };
    let (log, report) = build().finish(&front).unwrap();
    assert_eq!(log.scans().count(), 10);
    assert!(!report.notes.iter().any(|n| n.contains("header stamps")), "{:?}", report.notes);
    let e = build().finish(&ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("/scan_rear: 9 of 9 consecutive stamps repeat"), "{e}");
}

#[test]
fn thinning_keeps_every_nth_scan_or_one_per_distance_travelled() {
    let build = || {
        let mut a = Assembler::new(Path::new("x.bag"), "test");
        for k in 0..10u64 {
            a.scan(scan("/scan", "base_link", k * 1_000));
            // The odometry drives 0.3 m between scans.
            let pose = Pose2::new(0.3 * k as f64, 0.0, 0.0);
            a.odometry(RawOdometry { topic: "/odom".into(), stamp_ns: k * 1_000, pose, record_ns: None });
        }
        a
    };
    let stamps = |t: Thinning| -> Vec<u64> {
        let opts = ImportOptions { thinning: t, ..ImportOptions::default() };
        build().finish(&opts).unwrap().0.scans().map(|s| s.stamp_ns / 1_000).collect()
    };
    assert_eq!(stamps(Thinning::KeepEvery(3)), vec![0, 3, 6, 9]);
    assert_eq!(stamps(Thinning::EveryMetres(1.0)), vec![0, 4, 8], "0.3 m a scan: 1.2 m between kept");
    assert_eq!(stamps(Thinning::All).len(), 10);
    let (log, report) =
        build().finish(&ImportOptions { thinning: Thinning::KeepEvery(5), ..ImportOptions::default() }).unwrap();
    assert_eq!(log.odometry().count(), 10, "odometry all kept");
    assert_eq!((report.scans, report.lidars[0].scans), (2, 2), "the report counts the scans kept");
    assert!(report.notes.iter().any(|n| n == "--keep-every 5: 2 of 10 scans kept (odometry and reference all kept)"));
    let e = build().finish(&ImportOptions { thinning: Thinning::KeepEvery(0), ..ImportOptions::default() });
    assert!(e.unwrap_err().to_string().contains("expected a whole number from 1"));
}

#[test]
fn bad_scans_are_refused_with_their_place() {
    let mut a = Assembler::new(Path::new("x.log"), "test");
    let mut s = scan("/scan", "base_link", 0);
    s.angle_increment_rad = 0.0;
    s.place = "line 7".into();
    a.scan(s);
    a.odometry(RawOdometry { topic: "/odom".into(), stamp_ns: 0, pose: Pose2::IDENTITY, record_ns: None });
    let e = a.finish(&ImportOptions::default()).unwrap_err().to_string();
    assert!(e.starts_with("x.log: line 7 (/scan): scan:"), "{e}");
}

#[test]
fn a_log_without_odometry_is_refused_naming_the_flag_that_makes_it_from_the_scans() {
    let scans_only = || {
        let mut a = Assembler::new(Path::new("demo.bag"), "test");
        for k in 0..3 {
            a.scan(scan("/scan", "laser", k * 1_000));
        }
        a
    };
    let opts = ImportOptions { base_frame: "laser".into(), ..ImportOptions::default() };
    let e = scans_only().finish(&opts).unwrap_err().to_string();
    assert!(e.contains("demo.bag") && e.contains("no odometry") && e.contains("--odometry-from-scans"), "{e}");
    // An odometry topic or the /tf edge asked for by name: the flag is named too.
    for odometry in [OdometryFrom::Topic("/odom".into()), OdometryFrom::Tf] {
        let e = scans_only().finish(&ImportOptions { odometry, ..opts.clone() }).unwrap_err().to_string();
        assert!(e.contains("--odometry-from-scans"), "{e}");
    }
    // Asked to make it from the scans: a log without odometry, said so in the report.
    let scans = ImportOptions { odometry: OdometryFrom::Scans, ..opts.clone() };
    let (log, report) = scans_only().finish(&scans).unwrap();
    assert_eq!((log.scans().count(), log.odometry().count()), (3, 0));
    assert_eq!((report.odometry_source.as_str(), report.odometry_messages), (SCANS_TO_COME, 0));
    assert!(report.scan_odometry.is_none() && !report.notes.iter().any(|n| n.contains("not used")));
    // --every-m thins by the odometry's travel, which is not there yet: refused, naming both.
    let e = scans_only()
        .finish(&ImportOptions { thinning: Thinning::EveryMetres(0.5), ..scans.clone() })
        .unwrap_err()
        .to_string();
    assert!(e.contains("--every-m") && e.contains("--odometry-from-scans") && e.contains("--keep-every"), "{e}");
}

#[test]
fn odometry_from_the_scans_replaces_the_logs_own_with_a_note() {
    let mut a = Assembler::new(Path::new("r.bag"), "test");
    a.scan(scan("/scan", "base_link", 0));
    a.odometry(RawOdometry { topic: "/odom".into(), stamp_ns: 0, pose: Pose2::IDENTITY, record_ns: None });
    a.transform(tf("odom", "base_link", Rigid3::IDENTITY, false));
    let (log, mut report) =
        a.finish(&ImportOptions { odometry: OdometryFrom::Scans, ..ImportOptions::default() }).unwrap();
    assert_eq!(log.odometry().count(), 0);
    let note = report.notes.iter().find(|n| n.contains("not used")).unwrap();
    assert!(note.contains("1 readings of /odom") && note.contains("1 transforms /tf odom -> base_link"), "{note}");
    // The caller's odometry goes into the report, its printed lines and the log's header.
    let made = crate::ScanOdometrySummary { steps: 1, matched: 0, refused: 0, ..Default::default() };
    report.set_scan_odometry(made);
    assert_eq!((report.odometry_source.as_str(), report.odometry_messages), (ImportReport::SCAN_ODOMETRY_SOURCE, 1));
    assert!(report.lines().iter().any(|l| l.contains("odometry made by scan matching: 1 steps")));
    assert!(report.log_header().meta["scan_odometry"]["steps"] == 1);
}
