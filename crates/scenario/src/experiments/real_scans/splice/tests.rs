use super::*;
use mapkeeper_sensor::{LaserScan, LogHeader};

const SCAN_NS: u64 = 200_000_000;

/// A robot driving a wide arc at 0.5 m/s: a scan and a reference pose every 0.2 s, odometry
/// every 0.1 s (so every other odometry record falls between scans) in an odometry frame
/// rotated and shifted from the map frame. `n` scans, the first at 1 s.
pub(crate) fn arc_log(n: usize) -> SensorLog {
    let odom_in_map = Pose2::new(3.0, -2.0, 0.7);
    let map_in_odom = odom_in_map.inverse();
    let pose_at = |t_s: f64| {
        let (r, w) = (20.0, 0.5 / 20.0);
        Pose2::new(r * (w * t_s).sin(), r - r * (w * t_s).cos(), mapkeeper_grid::wrap_angle(w * t_s))
    };
    let mut records = Vec::new();
    for k in 0..2 * n {
        let stamp_ns = 1_000_000_000 + k as u64 * SCAN_NS / 2;
        let t_s = stamp_ns as f64 * 1e-9;
        records.push(LogRecord::Odom(OdometryReading { stamp_ns, pose_in_odom: map_in_odom.compose(&pose_at(t_s)) }));
        if k % 2 == 0 {
            records.push(LogRecord::Truth(TruePose { stamp_ns, pose_in_map: pose_at(t_s) }));
            records.push(LogRecord::Scan(LaserScan {
                stamp_ns,
                lidar_id: 0,
                lidar_in_robot: Pose2::IDENTITY,
                angle_min_rad: -1.0,
                angle_increment_rad: 0.5,
                range_min_m: 0.1,
                range_max_m: 30.0,
                ranges_m: vec![2.0, 3.0, k as f32 * 0.01 + 1.0, 4.0, 5.0],
                sweep: None,
            }));
        }
    }
    SensorLog { header: LogHeader::new(Default::default()), records }
}

fn odometry(log: &SensorLog) -> Vec<(u64, Pose2)> {
    log.odometry().map(|o| (o.stamp_ns, o.pose_in_odom)).collect()
}

fn scan_stamp(log: &SensorLog, k: usize) -> u64 {
    log.scans().nth(k).map_or(0, |s| s.stamp_ns)
}

/// Every kind of record strictly increasing in time.
fn assert_strictly_increasing(log: &SensorLog) {
    for kind in 0..3 {
        let stamps: Vec<u64> = log
            .records
            .iter()
            .filter(|r| {
                matches!((kind, r), (0, LogRecord::Scan(_)) | (1, LogRecord::Odom(_)) | (2, LogRecord::Truth(_)))
            })
            .map(LogRecord::stamp_ns)
            .collect();
        assert!(stamps.windows(2).all(|w| w[0] < w[1]), "kind {kind}: {stamps:?}");
    }
}

#[test]
fn the_odometry_carries_no_motion_across_the_cut_and_the_rest_is_untouched() {
    let log = arc_log(60);
    // At scan stamps (the drawn cuts' kind) and between records (an interpolated joint).
    for cut in [
        Cut { start_ns: scan_stamp(&log, 10), end_ns: scan_stamp(&log, 30) },
        Cut { start_ns: scan_stamp(&log, 10) + 37_000_000, end_ns: scan_stamp(&log, 30) + 61_000_000 },
    ] {
        let out = splice(&log, cut).unwrap_or_else(|e| panic!("{e}"));
        assert_strictly_increasing(&out);
        let odo = odometry(&out);
        let k = odo.partition_point(|o| o.0 <= cut.start_ns);
        let (before, after) = (odo[k - 1], odo[k]);
        assert_eq!(before.0, cut.start_ns, "an odometry record at t_a");
        assert_eq!(after.0, cut.start_ns + JOIN_NS, "the joint 1 ns later");
        assert_eq!(before.1, after.1, "no motion across the cut, exactly");
        // After the joint the odometry moves exactly as the log's did after t_b.
        let orig = odometry(&log);
        let j = orig.partition_point(|o| o.0 <= cut.end_ns);
        for (s, o) in odo[k + 1..].iter().zip(&orig[j..]) {
            assert_eq!(s.0, o.0 - cut.removed_ns());
        }
        for (s, o) in odo[k + 1..].windows(2).zip(orig[j..].windows(2)) {
            let (ds, dor) = (s[0].1.between(&s[1].1), o[0].1.between(&o[1].1));
            assert!(
                (ds.x - dor.x).abs() < 1e-9 && (ds.y - dor.y).abs() < 1e-9 && angle_diff(ds.yaw, dor.yaw).abs() < 1e-9
            );
        }
        // The records up to t_a are the log's, in order; nothing of the cut is left.
        let kept: Vec<&LogRecord> = log.records.iter().filter(|r| r.stamp_ns() <= cut.start_ns).collect();
        assert!(kept.iter().zip(&out.records).all(|(a, b)| *a == b));
        let outside = log.scans().filter(|s| cut.spliced_stamp(s.stamp_ns).is_some()).count();
        assert_eq!(out.scans().count(), outside, "no scan of the cut is left");
        // The scans after the cut are the log's, moved back; the reference keeps its poses.
        let later: Vec<&LaserScan> = log.scans().filter(|s| s.stamp_ns > cut.end_ns).collect();
        let moved: Vec<&LaserScan> = out.scans().filter(|s| s.stamp_ns > cut.start_ns).collect();
        assert_eq!(later.len(), moved.len());
        for (a, b) in later.iter().zip(&moved) {
            assert_eq!((a.stamp_ns - cut.removed_ns(), &a.ranges_m), (b.stamp_ns, &b.ranges_m));
        }
        let truth_after: Vec<Pose2> = log.truth().filter(|t| t.stamp_ns > cut.end_ns).map(|t| t.pose_in_map).collect();
        let out_after: Vec<Pose2> =
            out.truth().filter(|t| t.stamp_ns > cut.joint_ns()).map(|t| t.pose_in_map).collect();
        assert_eq!(truth_after, out_after);
        // The reference jumps within the joint: from its pose at t_a to its pose at t_b.
        let reference: Vec<StampedPose> =
            out.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
        let orig_ref: Vec<StampedPose> =
            log.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
        let at = |track: &[StampedPose], t| interpolate(track, t).unwrap_or_else(|| panic!("no pose at {t}"));
        assert_eq!(at(&reference, cut.start_ns), at(&orig_ref, cut.start_ns));
        assert_eq!(at(&reference, cut.joint_ns()), at(&orig_ref, cut.end_ns));
        // The first scan after the cut comes one of the log's scan periods (+ 1 ns) after t_a's
        // scan when the cut is at scan stamps.
        if cut.start_ns % SCAN_NS == 0 {
            assert_eq!(moved[0].stamp_ns - cut.start_ns, SCAN_NS + JOIN_NS);
        }
        assert_eq!(out.header.meta["splice"]["end_ns"], serde_json::json!(cut.end_ns));
    }
}

#[test]
fn a_cut_of_one_nanosecond_moves_nothing_in_time() {
    let log = arc_log(20);
    let t = scan_stamp(&log, 5);
    let cut = Cut { start_ns: t, end_ns: t + 1 };
    let out = splice(&log, cut).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(cut.removed_ns(), 0);
    assert_eq!(out.scans().count(), log.scans().count());
    assert_strictly_increasing(&out);
}

#[test]
fn bad_cuts_are_errors_naming_the_problem() {
    let log = arc_log(20);
    let (first, last) = (scan_stamp(&log, 0), scan_stamp(&log, 19));
    let cases = [
        (Cut { start_ns: first + SCAN_NS, end_ns: first + SCAN_NS }, "not after its start"),
        (Cut { start_ns: first + 3 * SCAN_NS, end_ns: first + SCAN_NS }, "not after its start"),
        (Cut { start_ns: first - 1, end_ns: first + SCAN_NS }, "inside the log's scans"),
        (Cut { start_ns: first, end_ns: last }, "inside the log's scans"),
        (Cut { start_ns: first, end_ns: u64::MAX }, "inside the log's scans"),
        (Cut { start_ns: u64::MAX - 1, end_ns: u64::MAX }, "inside the log's scans"),
    ];
    for (cut, want) in cases {
        let e = splice(&log, cut).map(|_| ()).unwrap_err().to_string();
        assert!(e.starts_with("splice: ") && e.contains(want), "{cut:?}: {e}");
    }
    // Odometry that stops before the cut's end; a reference that starts after its start.
    let mut short = log.clone();
    short.records.retain(|r| !matches!(r, LogRecord::Odom(o) if o.stamp_ns > first + 5 * SCAN_NS));
    let cut = Cut { start_ns: first + SCAN_NS, end_ns: first + 8 * SCAN_NS };
    let e = splice(&short, cut).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("odometry records") && e.contains("do not span"), "{e}");
    let mut late = log.clone();
    late.records.retain(|r| !matches!(r, LogRecord::Truth(t) if t.stamp_ns < first + 2 * SCAN_NS));
    let e = splice(&late, cut).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("reference records"), "{e}");
    let mut none = log.clone();
    none.records.retain(|r| !matches!(r, LogRecord::Odom(_)));
    let e = splice(&none, cut).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("odometry records (none)"), "{e}");
    // Without any reference the splice works, and adds none.
    let mut blind = log.clone();
    blind.records.retain(|r| !matches!(r, LogRecord::Truth(_)));
    assert_eq!(splice(&blind, cut).map(|l| l.truth().count()).ok(), Some(0));
}

#[test]
fn drawn_cuts_jump_half_a_metre_to_five_with_room_around_and_repeat_with_their_seed() {
    let log = arc_log(400);
    let p = CutParams { count: 12, before_s: 2.0, after_s: 4.0, ..CutParams::default() };
    let draws = draw_cuts(&log, "arc", &p, 7).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(draws.len(), 12);
    let reference: Vec<StampedPose> =
        log.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
    for d in &draws {
        // A cut that moved nothing cannot be drawn: the robot is moved ≥ 0.5 m.
        assert!(d.jump_m >= 0.5 && d.jump_m <= 5.0, "{d:?}");
        assert!((d.jump_m - d.from.distance(&d.to)).abs() < 1e-12);
        assert!(d.window_start_ns + 2_000_000_000 <= d.cut.start_ns && d.scans_before > p.before_scans);
        assert!(d.cut.end_ns + 4_000_000_000 <= d.window_end_ns && d.scans_after >= p.after_scans);
        let spliced = d.spliced(&log).unwrap_or_else(|e| panic!("{e}"));
        let truth: Vec<StampedPose> =
            spliced.truth().map(|t| StampedPose { stamp_ns: t.stamp_ns, pose: t.pose_in_map }).collect();
        let (a, b) = (interpolate(&truth, d.cut.start_ns), interpolate(&truth, d.cut.joint_ns()));
        let jump = a.zip(b).map_or(0.0, |(a, b)| a.distance(&b));
        assert!((jump - d.jump_m).abs() < 1e-9 && jump >= 0.5, "{jump} {d:?}");
        assert_eq!(Some(d.to), interpolate(&reference, d.cut.end_ns));
        // The paired window lasts as long, from the same scan.
        let unspliced = d.unspliced(&log);
        let span =
            |l: &SensorLog| l.scans().last().map_or(0, |s| s.stamp_ns) - l.scans().next().map_or(0, |s| s.stamp_ns);
        assert!(span(&unspliced) <= span(&spliced) && span(&spliced) - span(&unspliced) < SCAN_NS);
        assert_eq!(unspliced.scans().count(), spliced.scans().count());
        assert_eq!(unspliced.records.first(), spliced.records.first());
    }
    assert_eq!(draw_cuts(&log, "arc", &p, 7).ok(), Some(draws.clone()));
    assert_ne!(draw_cuts(&log, "arc", &p, 8).ok(), Some(draws));
}

#[test]
fn a_log_with_no_room_for_a_cut_is_an_error_naming_it() {
    let log = arc_log(30);
    let e = draw_cuts(&log, "short", &CutParams { before_s: 5.0, ..CutParams::default() }, 1).unwrap_err().to_string();
    assert!(e.starts_with("short: cut 0: no two scans") && e.contains("0.5-5 m"), "{e}");
    let mut blind = log.clone();
    blind.records.retain(|r| !matches!(r, LogRecord::Truth(_)));
    let e = draw_cuts(&blind, "blind", &CutParams::default(), 1).unwrap_err().to_string();
    assert!(e.contains("blind: no scan with a reference pose"), "{e}");
    let e = draw_cuts(&log, "x", &CutParams { count: 0, ..CutParams::default() }, 1).unwrap_err().to_string();
    assert_eq!(e, "parameter cuts.count is invalid: must be ≥ 1, got 0");
}

#[test]
fn cut_parameters_are_checked() {
    let bad = [
        (CutParams { min_jump_m: 0.0, ..CutParams::default() }, "min_jump_m"),
        (CutParams { max_jump_m: f64::NAN, ..CutParams::default() }, "max_jump_m"),
        (CutParams { before_s: -1.0, ..CutParams::default() }, "before_s"),
        (CutParams { after_s: f64::INFINITY, ..CutParams::default() }, "after_s"),
        (CutParams { after_scans: 0, ..CutParams::default() }, "after_scans"),
        (CutParams { before_scans: 0, ..CutParams::default() }, "before_scans"),
        (CutParams { max_tries: 0, ..CutParams::default() }, "max_tries"),
    ];
    for (p, name) in bad {
        assert_eq!(p.validate().map_err(|e| e.name), Err(name.to_string()));
    }
    assert_eq!(CutParams::default().validate(), Ok(()));
}
