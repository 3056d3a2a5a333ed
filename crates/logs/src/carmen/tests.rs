//! Unit tests of `carmen`.

use super::*;
use crate::ImportOptions;

fn write(name: &str, text: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("mapkeeper-carmen-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("log.txt");
    std::fs::write(&p, text).unwrap();
    p
}

fn flaser(ranges: &[f64], pose: (f64, f64, f64), t: f64) -> String {
    let r: Vec<String> = ranges.iter().map(|r| r.to_string()).collect();
    let (x, y, th) = pose;
    format!("FLASER {} {} {x} {y} {th} {x} {y} {th} {t} host {t}\n", ranges.len(), r.join(" "))
}

#[test]
fn a_corrected_log_gives_reference_poses_and_rechained_odometry() {
    // Scan 0 at (1, 0, 0); raw odometry then moves 1 m forward; scan 1 is corrected to
    // (2, 0.1, 0.1); raw odometry then turns by 0.2 rad; scan 2 at (2, 0.1, 0.3).
    let mut text =
        String::from("# message formats defined: PARAM ODOM FLASER\nPARAM robot_frontlaser_offset 0.1 nohost 0\n");
    text += "ODOM 0 0 0 0 0 0 0.5 h 0.5\n";
    text += &flaser(&[1.0, 81.83, 81.83, 2.0], (1.0, 0.0, 0.0), 1.0);
    text += "ODOM 1 0 0 0 0 0 0 h 0\nODOM 1.5 0 0 0 0 0 1.5 h 1.5\nODOM 2 0 0 0 0 0 2 h 2\n";
    text += &flaser(&[1.0, 81.83, 3.0, 2.0], (2.0, 0.1, 0.1), 2.0);
    text += "ODOM 2 0.1 0.1 0 0 0 0 h 0\nODOM 2 0.1 0.3 0 0 0 3 h 3\n";
    text += &flaser(&[1.0, 2.0, 3.0, 2.0], (2.0, 0.1, 0.3), 3.0);
    text += "NEFF 1\n";
    let p = write("corrected", &text);
    let (log, report) = read(&p, &ImportOptions::default()).unwrap();
    let odom: Vec<Pose2> = log.odometry().map(|o| o.pose_in_odom).collect();
    assert_eq!(odom.len(), 3);
    assert!(odom[0] == Pose2::IDENTITY);
    assert!((odom[1].x - 1.0).abs() < 1e-12 && odom[1].y.abs() < 1e-12 && odom[1].yaw.abs() < 1e-12, "{:?}", odom[1]);
    assert!((odom[2].x - 1.0).abs() < 1e-12 && (odom[2].yaw - 0.2).abs() < 1e-12, "{:?}", odom[2]);
    let truth: Vec<Pose2> = log.truth().map(|t| t.pose_in_map).collect();
    assert_eq!(truth[1], Pose2::new(2.0, 0.1, 0.1));
    let s: Vec<_> = log.scans().collect();
    assert_eq!(s.len(), 3);
    assert_eq!(s[0].stamp_ns, 0, "time starts at the first scan (the ODOM before it is not used)");
    assert!((s[0].angle_min_rad + PI / 2.0).abs() < 1e-12 && (s[0].angle_increment_rad - PI / 4.0).abs() < 1e-12);
    assert_eq!(s[0].range_max_m, 81.83, "the repeated largest reading is the no-return value");
    assert_eq!(s[0].valid_count(), 2);
    assert_eq!(s[0].lidar_in_robot, Pose2::IDENTITY, "a corrected log's poses are the lidar's");
    assert!(report.notes.iter().any(|n| n.contains("robot_frontlaser_offset 0.1 m not applied")), "{:?}", report.notes);
    assert_eq!(report.truth_poses, 3);
    assert!(report.notes.iter().any(|n| n.contains("1 NEFF")), "{:?}", report.notes);
}

#[test]
fn a_line_over_the_limit_is_refused_not_split() {
    // Split in two, the rest read as a line of its own and every line number after it was
    // off by one. (The limit is 64 MiB in `read`; 64 bytes here.)
    let parse_with = |text: String| {
        let reader: Box<dyn BufRead> = Box::new(std::io::Cursor::new(text.into_bytes()));
        parse(reader, Path::new("log.txt"), StampFrom::Header, Damage { gz: false, salvage: false }, 64)
    };
    let line = |len: usize| format!("NOTE {}", "x".repeat(len - 5));
    let ok = parse_with(format!("ODOM 0 0 0 0 0 0 1.0 h 1.0\n{}\nODOM 0.1 0 0 0 0 0 2.0 h 2.0\n", line(64)));
    assert!(ok.is_ok(), "a line of exactly the limit, newline not counted");
    assert!(parse_with(format!("ODOM 0 0 0 0 0 0 1.0 h 1.0\n{}", line(64))).is_ok(), "at the end, no newline");
    for text in [
        format!("ODOM 0 0 0 0 0 0 1.0 h 1.0\n{}\nODOM 0.1 0 0 0 0 0 2.0 h 2.0\n", line(65)),
        format!("ODOM 0 0 0 0 0 0 1.0 h 1.0\n{}", line(65)),
    ] {
        let Err(e) = parse_with(text) else { panic!("a line over the limit was accepted") };
        let e = e.to_string();
        assert!(e.contains("log.txt") && e.contains("line 2") && e.contains("longer than 64 bytes"), "{e}");
    }
    assert_eq!(MAX_LINE_BYTES, 64 << 20, "what `read` passes");
}

#[test]
fn poses_that_overflow_are_refused_by_stream_and_reading() {
    // A corrected pose and the raw ODOM after it 2e308 apart: the increment re-chained
    // between them is infinite.
    // (A corrected log re-anchors ODOM at each scan's pose, as CARMEN's corrected logs do.)
    let mut text = String::from("ODOM 0 0 0 0 0 0 0.5 h 0.5\n");
    text += &flaser(&[1.0, 2.0, 3.0], (1e308, 0.0, 0.0), 1.0);
    text += "ODOM 1e308 0 0 0 0 0 1 h 1\nODOM -1e308 0 0 0 0 0 1.5 h 1.5\n";
    text += &flaser(&[1.0, 2.0, 3.0], (1.0, 0.0, 0.0), 2.0);
    text += "ODOM 1 0 0 0 0 0 2 h 2\n";
    let p = write("overflow", &text);
    let e = read(&p, &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("log.txt") && e.contains("reading 2") && e.contains("the pose is not finite"), "{e}");
    std::fs::remove_dir_all(p.parent().unwrap()).ok();
}

#[test]
fn a_raw_log_uses_odom_as_written_and_counts_backward_steps() {
    let mut text = String::from("ODOM 0 0 0 0 0 0 1.0 h 1.0\nODOM 0.1 0 0 0 0 0 2.0 h 2.0\n");
    text += "FLASER 3 1 2 3 0.2 0 0 0.1 0 0 2.0 h 2.0\nODOM 0.2 0 0 0 0 0 1.5 h 1.5\n";
    let p = write("raw", &text);
    let (log, report) = read(&p, &ImportOptions::default()).unwrap();
    assert_eq!(log.odometry().count(), 3);
    assert_eq!(log.truth().count(), 0);
    assert_eq!(report.backward_steps.len(), 1);
    assert_eq!(report.backward_steps[0].count, 1);
    assert!((report.backward_steps[0].largest_s - 0.5).abs() < 1e-9);
    assert!((log.scans().next().unwrap().angle_increment_rad - PI / 2.0).abs() < 1e-12);
}

/// The odometry poses and the notes of a log read with `kind`.
fn read_kind(name: &str, text: &str, kind: CarmenKind) -> Result<(Vec<Pose2>, usize, Vec<String>), String> {
    let p = write(name, text);
    let options = ImportOptions { carmen_kind: kind, ..ImportOptions::default() };
    let (log, report) = read(&p, &options).map_err(|e| e.to_string())?;
    Ok((log.odometry().map(|o| o.pose_in_odom).collect(), log.truth().count(), report.notes))
}

/// Three scans driven 1 m forward each, then turned: the raw log a robot records with its
/// lidar at the origin (both triplets the odometry pose), without `ODOM` lines.
fn raw_equal_triplets() -> String {
    [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.5)]
        .iter()
        .enumerate()
        .map(|(k, &pose)| flaser(&[1.0, 2.0, 3.0, 2.5], pose, 1.0 + k as f64))
        .collect()
}

#[test]
fn a_raw_log_with_equal_triplets_and_no_odom_lines_takes_the_laser_odometry() {
    // The case: read as corrected, this re-chained to zero motion with the odometry
    // as the "reference". It is raw: the odometry moves, and there is no reference.
    let (odom, truth, notes) = read_kind("raw-equal", &raw_equal_triplets(), CarmenKind::Auto).unwrap();
    assert_eq!(truth, 0);
    assert_eq!(odom.len(), 3);
    assert!((odom[1].x - 1.0).abs() < 1e-12 && (odom[2].x - 2.0).abs() < 1e-12, "{odom:?}");
    assert!((odom[2].yaw - 0.5).abs() < 1e-12);
    assert!(
        notes[0]
            .starts_with("raw log (all 3 laser messages have equal pose and odometry triplets, and there are no ODOM"),
        "{notes:?}"
    );
    assert!(notes[0].contains("the laser lines' odometry fields"), "{notes:?}");
}

#[test]
fn a_raw_log_with_differing_triplets_takes_the_odometry_triplet() {
    // The lidar 0.1 m ahead of the robot: pose triplet = lidar, odometry triplet = robot.
    let text = "FLASER 2 1 2 0.1 0 0 0 0 0 1.0 h 1.0\nFLASER 2 1 2 1.1 0 0 1 0 0 2.0 h 2.0\n";
    let (odom, truth, notes) = read_kind("raw-diff", text, CarmenKind::Auto).unwrap();
    assert_eq!((odom.len(), truth), (2, 0));
    assert!((odom[1].x - 1.0).abs() < 1e-12, "{odom:?}");
    assert!(notes[0].starts_with("raw log (2 of 2 laser messages have a pose triplet different"), "{notes:?}");
    // Asked to read it as corrected, it is refused, naming the line.
    let e = read_kind("raw-diff", text, CarmenKind::Corrected).unwrap_err();
    assert!(e.contains("line 1") && e.contains("triplets differ"), "{e}");
}

#[test]
fn a_raw_log_with_odom_lines_that_do_not_re_anchor_uses_them_as_written() {
    // Equal triplets, and ODOM lines of continuous odometry (none equal to the scan before).
    let mut text = String::new();
    for k in 0..4 {
        let x = k as f64;
        text += &format!("ODOM {} 0 0 0 0 0 {} h {}\n", x + 0.05, x + 0.5, x + 0.5);
        text += &flaser(&[1.0, 2.0, 3.0, 2.5], (x + 0.1, 0.0, 0.0), 1.0 + x);
    }
    let (odom, truth, notes) = read_kind("raw-odom", &text, CarmenKind::Auto).unwrap();
    assert_eq!((odom.len(), truth), (4, 0));
    assert!((odom[3].x - 3.05).abs() < 1e-12, "{odom:?}");
    assert!(notes[0].contains("0 of the 3 scans followed by an ODOM line"), "{notes:?}");
    assert!(notes[0].starts_with("raw log") && notes[0].contains("the ODOM lines as written"), "{notes:?}");
}

#[test]
fn a_corrected_log_whose_odometry_equals_its_poses_is_still_corrected() {
    // Re-anchoring lines after each scan, raw odometry that agrees with the corrections.
    let mut text = String::new();
    for k in 0..3 {
        let x = k as f64;
        text += &flaser(&[1.0, 2.0, 3.0, 2.5], (x, 0.0, 0.0), 1.0 + x);
        text += &format!("ODOM {x} 0 0 0 0 0 0 h 0\nODOM {} 0 0 0 0 0 {} h {}\n", x + 1.0, x + 1.5, x + 1.5);
    }
    let (odom, truth, notes) = read_kind("corr-equal", &text, CarmenKind::Auto).unwrap();
    assert_eq!((odom.len(), truth), (3, 3));
    assert!((odom[2].x - 2.0).abs() < 1e-12, "{odom:?}");
    assert!(notes[0].starts_with("corrected log (") && notes[0].contains("3 of the 3 scans"), "{notes:?}");
    // Read as raw on request: no reference, the re-anchored ODOM lines as written, and a
    // warning that they are not continuous.
    let (odom, truth, notes) = read_kind("corr-equal", &text, CarmenKind::Raw).unwrap();
    assert_eq!((odom.len(), truth), (6, 0));
    assert!(notes[0].contains("the file looks corrected"), "{notes:?}");
}

#[test]
fn a_corrected_reading_without_odom_lines_is_refused() {
    let e = read_kind("corr-none", &raw_equal_triplets(), CarmenKind::Corrected).unwrap_err();
    assert!(e.contains("no ODOM lines") && e.contains("read it as raw"), "{e}");
    // Raw on request: the same as told from the file.
    assert_eq!(
        read_kind("corr-none", &raw_equal_triplets(), CarmenKind::Raw).unwrap().0,
        read_kind("corr-none", &raw_equal_triplets(), CarmenKind::Auto).unwrap().0
    );
}

/// A raw log of `n` scans 0.2 s apart with an ODOM line before each, stamps written by
/// `stamp(k, is_scan)`.
fn raw_log_stamped(n: usize, stamp: impl Fn(usize, bool) -> String) -> String {
    (0..n)
        .map(|k| {
            let x = 0.1 * k as f64;
            let (to, ts) = (stamp(k, false), stamp(k, true));
            format!("ODOM {x} 0 0 0 0 0 {to} h {to}\nFLASER 3 1 2 3 {x} 0 0 {x} 0 0 {ts} h {ts}\n")
        })
        .collect()
}

fn read_with(name: &str, text: &str, options: ImportOptions) -> Result<(SensorLog, ImportReport), String> {
    let p = write(name, text);
    let r = read(&p, &options).map_err(|e| e.to_string());
    std::fs::remove_dir_all(p.parent().unwrap()).ok();
    r
}

#[test]
fn stamps_that_step_back_many_times_are_ordered_by_line_with_a_note() {
    // Every other scan's stamp is 0.3 s early (a clock that jitters back and forth): sorted by
    // stamp, scans would swap places and odometry readings would land on the wrong scans.
    let text = raw_log_stamped(20, |k, scan| {
        let t = 1.0 + 0.2 * k as f64 + if scan { 0.1 } else { 0.0 };
        format!("{:.3}", if k % 2 == 1 { t - 0.3 } else { t })
    });
    let (log, report) = read_with("jitter", &text, ImportOptions::default()).unwrap();
    let note = report.notes.iter().find(|n| n.starts_with("timestamps not used")).expect("a note");
    assert!(note.contains("step back") && note.contains("ordered by line"), "{note}");
    assert!(report.backward_steps.is_empty(), "nothing left to clamp: {:?}", report.backward_steps);
    // Line order: each scan after the ODOM line before it, the odometry moving 0.1 m a scan.
    let kinds: Vec<char> = log
        .records
        .iter()
        .map(|r| match r {
            mapkeeper_sensor::LogRecord::Scan(_) => 's',
            _ => 'o',
        })
        .collect();
    assert_eq!(kinds.iter().collect::<String>(), "os".repeat(20));
    let stamps: Vec<u64> = log.scans().map(|s| s.stamp_ns).collect();
    assert!(stamps.windows(2).all(|w| w[1] > w[0]), "{stamps:?}");
    // Taken as written on request, with a note that says so (and the steps back clamped).
    let stamp = ImportOptions { time_source: TimeSource::Stamp, ..ImportOptions::default() };
    let (_, report) = read_with("jitter-stamp", &text, stamp).unwrap();
    assert!(report.notes.iter().any(|n| n.starts_with("timestamps taken as written")), "{:?}", report.notes);
    assert!(!report.backward_steps.is_empty());
}

#[test]
fn coarse_stamps_are_refused_without_a_rate_and_timed_from_one() {
    // %g of an epoch time: "1.13486e+09" on every line.
    let text = raw_log_stamped(30, |_, _| "1.13486e+09".into());
    let e = read_with("coarse", &text, ImportOptions::default()).unwrap_err();
    assert!(e.contains("line 1:") && e.contains("--rate HZ") && e.contains("printed to 10000 s"), "{e}");
    assert!(e.contains("every message has the same printed time") && e.contains("--time-source stamp"), "{e}");
    let rate = ImportOptions { rate_hz: Some(5.0), ..ImportOptions::default() };
    let (log, report) = read_with("coarse-rate", &text, rate).unwrap();
    let scans: Vec<u64> = log.scans().map(|s| s.stamp_ns).collect();
    let first = scans[0];
    assert_eq!(
        scans.iter().map(|t| t - first).collect::<Vec<_>>(),
        (0..30).map(|k| k * 200_000_000).collect::<Vec<u64>>()
    );
    let odo: Vec<f64> = log.odometry().map(|o| o.pose_in_odom.x).collect();
    assert_eq!(odo.len(), 30);
    assert!(report.notes.iter().any(|n| n.contains("spaced from --rate 5 Hz of FLASER")), "{:?}", report.notes);
    assert!(
        (report.duration_s - 5.9).abs() < 1e-6,
        "29 scan periods and the ODOM before the first: {}",
        report.duration_s
    );
}

#[test]
fn a_first_stamp_far_before_the_rest_is_refused_not_spread_over_decades() {
    // A negative first stamp (read as 0) before %g epoch stamps: not a spacing of 36 years a
    // line (which overflowed), a refusal naming the flag.
    let text = raw_log_stamped(20, |k, _| if k == 0 { "-1".into() } else { "1.13486e+09".into() });
    let e = read_with("far-first", &text, ImportOptions::default()).unwrap_err();
    assert!(e.contains("--rate HZ") && e.contains("too few or too far apart"), "{e}");
    let rate = ImportOptions { rate_hz: Some(2.0), ..ImportOptions::default() };
    let (log, _) = read_with("far-first-rate", &text, rate).unwrap();
    let t: Vec<u64> = log.scans().map(|s| s.stamp_ns).collect();
    assert!(t.windows(2).all(|w| w[1] > w[0]) && t[19] - t[0] < 20_000_000_000, "{t:?}");
}

#[test]
fn a_rate_given_for_a_log_whose_stamps_are_used_is_noted_as_unused() {
    let text = raw_log_stamped(10, |k, scan| format!("{:.3}", 1.0 + 0.2 * k as f64 + if scan { 0.1 } else { 0.0 }));
    let rate = ImportOptions { rate_hz: Some(5.0), ..ImportOptions::default() };
    let (log, report) = read_with("rate-unused", &text, rate).unwrap();
    assert!(report.notes.iter().any(|n| n == "--rate 5 is not used: the stamps time the log"), "{:?}", report.notes);
    assert_eq!(log.scans().next().unwrap().stamp_ns, 100_000_000, "the stamps, as written");
}

#[test]
fn fine_stamps_read_by_line_are_the_stamps() {
    let text = raw_log_stamped(10, |k, scan| format!("{:.3}", 1.0 + 0.2 * k as f64 + if scan { 0.1 } else { 0.0 }));
    let (by_stamp, report) = read_with("fine", &text, ImportOptions::default()).unwrap();
    assert!(!report.notes.iter().any(|n| n.contains("timestamps")), "{:?}", report.notes);
    let line = ImportOptions { time_source: TimeSource::Line, ..ImportOptions::default() };
    let (by_line, report) = read_with("fine-line", &text, line).unwrap();
    assert_eq!(by_stamp.records, by_line.records);
    assert!(report.notes.iter().any(|n| n.starts_with("timestamps not used (--time-source line)")));
}

#[test]
fn bad_lines_are_named() {
    for (text, want) in [
        ("FLASER 3 1 2\n", "line 1: FLASER: missing field"),
        ("ODOM 0 0 zero 0 0 0 1 h 1\n", "line 1: ODOM: field 3 (theta) is 'zero'"),
        ("ODOM 0 0 0 0 0 0 1 h 1\nFLASER 2.5 1 2\n", "line 2: FLASER: field 1 (num_readings) is 2.5"),
        ("ODOM 0 0 0 0 0 0 -2e10 h 1\n", "line 1: ODOM: field 7 (ipc_timestamp) is -20000000000"),
        ("ODOM 0 0 0 0 0 0 1 h 1\n", "no laser scans"),
    ] {
        let p = write("bad", text);
        let e = read(&p, &ImportOptions::default()).unwrap_err().to_string();
        assert!(e.contains(&p.display().to_string()) && e.contains(want), "{text:?}: {e}");
    }
}

/// A gzipped raw log of 80 scans, its path and the scans read from it whole.
fn gz_log(name: &str) -> (std::path::PathBuf, Vec<u8>, Vec<mapkeeper_sensor::LaserScan>) {
    use std::io::Write;
    let text: String = (0..80)
        .map(|k| {
            let r: Vec<f64> = (0..90).map(|b| 1.0 + ((k * 7 + b * 13) % 97) as f64 / 10.0).collect();
            flaser(&r, (0.05 * k as f64, 0.0, 0.001 * k as f64), 1.0 + 0.1 * k as f64)
        })
        .collect();
    let p = write(name, "").with_extension("gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(text.as_bytes()).unwrap();
    let bytes = enc.finish().unwrap();
    std::fs::write(&p, &bytes).unwrap();
    let scans = read(&p, &ImportOptions::default()).unwrap().0.scans().cloned().collect();
    (p, bytes, scans)
}

#[test]
fn a_gzip_cut_anywhere_is_an_error_or_with_salvage_a_prefix_and_a_note() {
    let (p, bytes, whole) = gz_log("cut");
    let salvage = ImportOptions { salvage: true, ..ImportOptions::default() };
    let mut salvaged = 0;
    for cut in (1..bytes.len()).step_by(bytes.len() / 97).chain([bytes.len() - 1, bytes.len() - 4, bytes.len() - 8]) {
        std::fs::write(&p, &bytes[..cut]).unwrap();
        let e = read(&p, &ImportOptions::default()).unwrap_err().to_string();
        assert!(e.contains(&p.display().to_string()), "cut at {cut}: {e}");
        assert!(e.contains("truncated or corrupt") || e.contains("no laser scans"), "cut at {cut}: {e}");
        match read(&p, &salvage) {
            Ok((log, report)) => {
                // The same scans as the whole file's first ones (range_max aside: the
                // file's largest reading decides it).
                let got: Vec<_> = log.scans().map(|s| (s.stamp_ns, s.ranges_m.clone())).collect();
                let first: Vec<_> = whole.iter().take(got.len()).map(|s| (s.stamp_ns, s.ranges_m.clone())).collect();
                assert!(got.len() <= whole.len() && got == first, "cut at {cut}: not a prefix");
                assert!(
                    report.notes.iter().any(|n| n.starts_with("salvaged: read up to the damage")),
                    "{:?}",
                    report.notes
                );
                salvaged += 1;
            }
            Err(e) => assert!(e.to_string().contains("no laser scans"), "cut at {cut}: {e}"),
        }
    }
    assert!(salvaged >= 80, "{salvaged} cuts salvaged");
}

#[test]
fn a_corrupt_gzip_byte_is_an_error_unless_it_changed_nothing() {
    let (p, bytes, whole) = gz_log("corrupt");
    let mut refused = 0;
    // The compressed data: after the 10-byte header, before the 8-byte trailer.
    for at in (10..bytes.len() - 8).step_by((bytes.len() - 18) / 101) {
        let mut b = bytes.clone();
        b[at] ^= 0x5a;
        std::fs::write(&p, &b).unwrap();
        match read(&p, &ImportOptions::default()) {
            Ok((log, _)) => {
                assert!(log.scans().cloned().collect::<Vec<_>>() == whole, "byte {at}: silently different")
            }
            Err(e) => {
                assert!(e.to_string().contains(&p.display().to_string()), "byte {at}: {e}");
                refused += 1;
            }
        }
    }
    assert!(refused >= 90, "{refused} corruptions refused");
}

#[test]
fn gzipped_logs_read_the_same() {
    use std::io::Write;
    let text = "ODOM 0 0 0 0 0 0 1.0 h 1.0\nFLASER 3 1 2 3 0 0 0 0 0 0 1.0 h 1.0\n";
    let plain = write("plain", text);
    let gz = plain.with_extension("gz");
    let mut enc = flate2::write::GzEncoder::new(std::fs::File::create(&gz).unwrap(), flate2::Compression::default());
    enc.write_all(text.as_bytes()).unwrap();
    enc.finish().unwrap();
    let a = read(&plain, &ImportOptions::default()).unwrap().0;
    let b = read(&gz, &ImportOptions::default()).unwrap().0;
    assert_eq!(a.records, b.records);
    assert_eq!(crate::detect_format(&gz).unwrap(), crate::LogFormat::Carmen);
}
