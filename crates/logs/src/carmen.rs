//! CARMEN logs (plain text or gzipped): `FLASER`, `RLASER`, `ROBOTLASER1`, `ODOM`, `PARAM`.
//!
//! One message per line, fields separated by white space; `#` starts a comment line.
//!
//! - `FLASER n r_1 … r_n x y θ odom_x odom_y odom_θ ipc_timestamp host logger_timestamp`
//!   (`RLASER` alike): beams from −π/2 counter-clockwise over 180°, one degree apart for 180 or
//!   181 beams, half a degree for 360 or 361 (in general π/n for even n, π/(n−1) for odd n). The
//!   first triplet is the lidar's pose, the second the robot's: the mount is `robot⁻¹ ∘ laser` of
//!   the first message. In a corrected log both hold the corrected lidar pose, so the mount is
//!   the identity and `robot_frontlaser_offset` is not applied again (a note says so): on
//!   Freiburg 079 a map built with its −0.04 m offset is measurably blurrier (7.8 % against
//!   7.2 % distinct hit cells per hit at 0.05 m).
//! - `ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n r_1 … r_n
//!   m e_1 … e_m laser_x laser_y laser_θ robot_x robot_y robot_θ tv rv fwd_safety side_safety
//!   turn_axis ipc_timestamp host logger_timestamp`: the geometry is given; the mount is
//!   `robot⁻¹ ∘ laser` of the first message.
//! - `ODOM x y θ tv rv accel ipc_timestamp host logger_timestamp`.
//! - `PARAM name value …`: `robot_frontlaser_offset`, `robot_rearlaser_offset` are compared
//!   with the mounts the poses give (a note when they differ).
//! - Other messages (`NEFF`, `SYNC`, `TRUEPOS`, …) are counted and skipped.
//!
//! **No return.** CARMEN writes "no return" as the sensor's largest reading. The largest reading
//! of the file, if at least two beams hold exactly it, is taken as the no-return value: it and
//! anything beyond it are invalid beams (`range_max`); otherwise `range_max` is just above the
//! largest reading.
//!
//! **Corrected logs** (SLAM-corrected, as the Radish "-corrected" logs): every `FLASER` holds the
//! same corrected pose in both triplets, and the `ODOM` lines hold raw odometry re-anchored at
//! each scan's corrected pose (an `ODOM` with timestamp 0 equal to the pose follows each scan).
//! Such a log is recognised (both triplets equal in every laser message) and read as:
//! reference poses = the corrected poses; odometry = the raw odometry re-chained from the
//! increments `p_k⁻¹ ∘ q_{k+1}` (`p_k` the corrected pose of scan `k`, `q_{k+1}` the last `ODOM`
//! before scan `k + 1`), one reading at each scan's stamp, starting at the identity. Otherwise
//! the `ODOM` lines are the odometry as written and the log has no reference.
//!
//! Negative timestamps (a few in real logs) read as 0, so where they are used they count as
//! steps back in the report.

use crate::assemble::{Assembler, RawOdometry, RawPose, RawScan};
use crate::options::{ImportOptions, StampFrom};
use crate::report::ImportReport;
use crate::{ImportError, OdometryFrom};
use mapkeeper_grid::{Pose2, wrap_angle};
use mapkeeper_sensor::{MAX_BEAMS, SensorLog};
use std::f64::consts::PI;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Whether the first bytes of a file look like a CARMEN log (a line starting with a CARMEN
/// message name or a `#` comment naming message formats).
pub fn looks_like_carmen(head: &[u8]) -> bool {
    const NAMES: [&str; 8] = ["PARAM ", "ODOM ", "FLASER ", "RLASER ", "ROBOTLASER1 ", "TRUEPOS ", "SYNC ", "NEFF "];
    let text = String::from_utf8_lossy(head);
    text.lines().take(3).any(|l| l.starts_with("# message formats") || NAMES.iter().any(|n| l.starts_with(n)))
}

/// A laser message before the file's no-return value is known.
#[derive(Debug)]
struct Laser {
    name: &'static str,
    line: usize,
    stamp_ns: u64,
    angle_min: f64,
    increment: f64,
    ranges: Vec<f32>,
    /// (laser pose, robot pose) triplets.
    pose: Pose2,
    robot: Pose2,
    max_range: Option<f32>,
}

#[derive(Debug)]
struct Odom {
    stamp_ns: u64,
    pose: Pose2,
}

#[derive(Debug, Default)]
struct Parsed {
    lasers: Vec<Laser>,
    /// Each ODOM with the number of laser messages before it.
    odometry: Vec<(usize, Odom)>,
    front_offset: f64,
    rear_offset: f64,
    skipped: std::collections::BTreeMap<String, usize>,
}

/// Reads a CARMEN log.
pub fn read(path: &Path, options: &ImportOptions) -> Result<(SensorLog, ImportReport), ImportError> {
    let file = std::fs::File::open(path).map_err(|e| ImportError::io(path, e))?;
    let mut head = [0u8; 2];
    let gz = {
        let mut f = &file;
        f.read(&mut head).map_err(|e| ImportError::io(path, e))? == 2 && head == [0x1f, 0x8b]
    };
    let file = std::fs::File::open(path).map_err(|e| ImportError::io(path, e))?;
    let reader: Box<dyn BufRead> = if gz {
        Box::new(BufReader::new(flate2::read::MultiGzDecoder::new(file)))
    } else {
        Box::new(BufReader::new(file))
    };
    let parsed = parse(reader, path, options.stamp)?;
    assemble(parsed, path, options)
}

fn parse(mut reader: Box<dyn BufRead>, path: &Path, stamp: StampFrom) -> Result<Parsed, ImportError> {
    let mut p = Parsed::default();
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    loop {
        buf.clear();
        let n = (&mut reader)
            .take(64 << 20)
            .read_until(b'\n', &mut buf)
            .map_err(|e| ImportError::parse(path, format!("line {}", line_no + 1), format!("cannot read: {e}")))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let text = std::str::from_utf8(&buf)
            .map_err(|_| ImportError::parse(path, format!("line {line_no}"), "not UTF-8 text"))?;
        let fields: Vec<&str> = text.split_whitespace().collect();
        let Some(&kind) = fields.first() else { continue };
        if kind.starts_with('#') {
            continue;
        }
        let f = Fields { path, line: line_no, fields: &fields };
        match kind {
            "FLASER" | "RLASER" => p.lasers.push(f.flaser(if kind == "FLASER" { "FLASER" } else { "RLASER" }, stamp)?),
            "ROBOTLASER1" => p.lasers.push(f.robotlaser(stamp)?),
            "ODOM" => {
                let odom = Odom { stamp_ns: f.stamp(7, stamp)?, pose: f.pose(1)? };
                p.odometry.push((p.lasers.len(), odom));
            }
            "PARAM" => match fields.get(1).copied() {
                Some("robot_frontlaser_offset") => p.front_offset = f.num(2, "robot_frontlaser_offset")?,
                Some("robot_rearlaser_offset") => p.rear_offset = f.num(2, "robot_rearlaser_offset")?,
                _ => {}
            },
            other => *p.skipped.entry(other.to_string()).or_default() += 1,
        }
    }
    Ok(p)
}

/// The fields of one line, with typed access that names the line and field in errors.
struct Fields<'a> {
    path: &'a Path,
    line: usize,
    fields: &'a [&'a str],
}

impl Fields<'_> {
    fn err(&self, message: String) -> ImportError {
        ImportError::parse(self.path, format!("line {}", self.line), format!("{}: {message}", self.fields[0]))
    }

    fn num(&self, i: usize, what: &str) -> Result<f64, ImportError> {
        let s =
            self.fields.get(i).ok_or_else(|| self.err(format!("missing field {i} ({what}): the line is too short")))?;
        let v: f64 = s.parse().map_err(|_| self.err(format!("field {i} ({what}) is '{s}', not a number")))?;
        if !v.is_finite() {
            return Err(self.err(format!("field {i} ({what}) is '{s}', not finite")));
        }
        Ok(v)
    }

    fn count(&self, i: usize, what: &str) -> Result<usize, ImportError> {
        let v = self.num(i, what)?;
        if v < 0.0 || v.fract() != 0.0 || v > MAX_BEAMS as f64 {
            return Err(self.err(format!("field {i} ({what}) is {v}: expected a whole number from 0 to {MAX_BEAMS}")));
        }
        Ok(v as usize)
    }

    fn pose(&self, i: usize) -> Result<Pose2, ImportError> {
        Ok(Pose2::new(self.num(i, "x")?, self.num(i + 1, "y")?, wrap_angle(self.num(i + 2, "theta")?)))
    }

    /// The stamp: `ipc_timestamp` at `i` or `logger_timestamp` at `i + 2`, seconds. A negative
    /// stamp (real logs have a few) reads as 0, so it counts as a step back where it is used.
    fn stamp(&self, i: usize, from: StampFrom) -> Result<u64, ImportError> {
        let (i, what) = match from {
            StampFrom::Header => (i, "ipc_timestamp"),
            StampFrom::Record => (i + 2, "logger_timestamp"),
        };
        let t = self.num(i, what)?;
        if t.abs() > 1.8e10 {
            return Err(self.err(format!("field {i} ({what}) is {t} s: expected at most 1.8e10 s")));
        }
        Ok((t.max(0.0) * 1e9).round() as u64)
    }

    fn ranges(&self, from: usize, n: usize) -> Result<Vec<f32>, ImportError> {
        (from..from + n).map(|i| self.num(i, "range").map(|r| r as f32)).collect()
    }

    fn flaser(&self, name: &'static str, stamp: StampFrom) -> Result<Laser, ImportError> {
        let n = self.count(1, "num_readings")?;
        if n < 2 {
            return Err(self.err(format!("{n} readings: at least 2 are needed")));
        }
        let ranges = self.ranges(2, n)?;
        let increment = if n % 2 == 0 { PI / n as f64 } else { PI / (n - 1) as f64 };
        Ok(Laser {
            name,
            line: self.line,
            stamp_ns: self.stamp(n + 8, stamp)?,
            angle_min: -PI / 2.0,
            increment,
            ranges,
            pose: self.pose(n + 2)?,
            robot: self.pose(n + 5)?,
            max_range: None,
        })
    }

    fn robotlaser(&self, stamp: StampFrom) -> Result<Laser, ImportError> {
        let start = self.num(2, "start_angle")?;
        let increment = self.num(4, "angular_resolution")?;
        let max = self.num(5, "maximum_range")?;
        let n = self.count(8, "num_readings")?;
        let ranges = self.ranges(9, n)?;
        let m = self.count(9 + n, "num_remissions")?;
        let at = 10 + n + m;
        Ok(Laser {
            name: "ROBOTLASER1",
            line: self.line,
            stamp_ns: self.stamp(at + 11, stamp)?,
            angle_min: start,
            increment,
            ranges,
            pose: self.pose(at)?,
            robot: self.pose(at + 3)?,
            max_range: (max > 0.0).then_some(max as f32),
        })
    }
}

/// Whether both pose triplets of every laser message are the same (a corrected log).
fn is_corrected(lasers: &[Laser]) -> bool {
    !lasers.is_empty() && lasers.iter().all(|l| l.name != "ROBOTLASER1" && l.pose == l.robot)
}

/// The file's no-return value: its largest reading if two or more beams hold exactly it.
fn no_return_value(lasers: &[Laser]) -> Option<f32> {
    let max = lasers.iter().flat_map(|l| l.ranges.iter().copied()).fold(f32::NEG_INFINITY, f32::max);
    let n = lasers.iter().flat_map(|l| l.ranges.iter()).filter(|&&r| r == max).count();
    (n >= 2).then_some(max)
}

fn assemble(p: Parsed, path: &Path, options: &ImportOptions) -> Result<(SensorLog, ImportReport), ImportError> {
    let mut a = Assembler::new(path, "carmen");
    for l in &p.lasers {
        a.count_message(l.name, l.name);
    }
    for _ in &p.odometry {
        a.count_message("ODOM", "ODOM");
    }
    for (k, n) in &p.skipped {
        for _ in 0..*n {
            a.count_message(k, k);
        }
    }
    let corrected = is_corrected(&p.lasers);
    let no_return = no_return_value(&p.lasers);
    let largest = p.lasers.iter().flat_map(|l| l.ranges.iter().copied()).fold(0.0f32, f32::max);
    let file_max = no_return.unwrap_or_else(|| largest.next_up());
    for l in &p.lasers {
        if !a.has_mount(l.name) {
            let mount = if l.pose == l.robot { Pose2::IDENTITY } else { l.robot.between(&l.pose) };
            a.known_mount(l.name, mount, &format!("{} robot pose⁻¹ ∘ laser pose (first message)", l.name));
            let param = match l.name {
                "FLASER" => Some(("robot_frontlaser_offset", p.front_offset)),
                "RLASER" => Some(("robot_rearlaser_offset", p.rear_offset)),
                _ => None,
            };
            if let Some((name, offset)) = param.filter(|(_, o)| (o - mount.x).abs() > 1e-9) {
                a.note(format!(
                    "PARAM {name} {offset} m not applied: the {} poses place the lidar at ({:.3}, {:.3}) in the base frame{}",
                    l.name,
                    mount.x,
                    mount.y,
                    if corrected { " (a corrected log's poses are the lidar's own)" } else { "" }
                ));
            }
        }
        a.scan(RawScan {
            topic: l.name.to_string(),
            frame_id: l.name.to_string(),
            stamp_ns: l.stamp_ns,
            angle_min_rad: l.angle_min,
            angle_increment_rad: l.increment,
            range_min_m: 0.0,
            range_max_m: l.max_range.map_or(file_max, |m| m.min(file_max)),
            ranges_m: l.ranges.clone(),
            place: format!("line {}", l.line),
        });
    }
    if let Some(v) = no_return {
        a.note(format!(
            "no-return value {v} m (the file's largest reading, held by several beams): those beams are invalid"
        ));
    }
    if corrected {
        rechain(&p, &mut a);
    } else {
        for (_, o) in &p.odometry {
            a.odometry(RawOdometry { topic: "ODOM".into(), stamp_ns: o.stamp_ns, pose: o.pose });
        }
        a.note("laser poses differ from odometry poses: not a corrected log; ODOM used as written, no reference");
    }
    for (k, n) in &p.skipped {
        a.note(format!("{n} {k} message(s) skipped"));
    }
    let mut options = options.clone();
    if options.odometry == OdometryFrom::Auto || options.odometry == OdometryFrom::Topic("ODOM".into()) {
        options.odometry = OdometryFrom::Topic(if corrected { RECHAINED.into() } else { "ODOM".into() });
    }
    a.finish(&options)
}

/// The name of the re-chained odometry stream of a corrected log.
pub const RECHAINED: &str = "ODOM (raw increments re-chained at the scans)";

/// A corrected log's reference poses and re-chained raw odometry (see the module docs).
fn rechain(p: &Parsed, a: &mut Assembler) {
    let mut odom = Pose2::IDENTITY;
    for (k, l) in p.lasers.iter().enumerate() {
        if k > 0 {
            let prev = &p.lasers[k - 1];
            // The last ODOM after scan k − 1 and before scan k (the re-anchoring line, equal to
            // scan k − 1's pose, if it is the only one: no motion).
            let q = p.odometry.iter().rev().find(|(before, _)| *before == k).map_or(prev.robot, |(_, o)| o.pose);
            odom = odom.compose(&prev.robot.between(&q));
        }
        a.odometry(RawOdometry { topic: RECHAINED.into(), stamp_ns: l.stamp_ns, pose: odom });
        a.truth(RawPose { stamp_ns: l.stamp_ns, pose: l.robot }, "the corrected poses of the laser messages");
    }
    // A re-anchoring line: the first ODOM after a scan, equal to that scan's pose.
    let anchors = (1..=p.lasers.len())
        .filter(|&k| {
            p.odometry.iter().find(|(before, _)| *before == k).is_some_and(|(_, o)| o.pose == p.lasers[k - 1].robot)
        })
        .count();
    a.note(format!(
        "corrected log: reference = the laser messages' corrected poses; odometry = raw increments re-chained, one reading per \
scan ({} ODOM lines read, {anchors} of them re-anchoring lines equal to the scan before)",
        p.odometry.len()
    ));
}

#[cfg(test)]
mod tests {
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
        assert!(
            (odom[1].x - 1.0).abs() < 1e-12 && odom[1].y.abs() < 1e-12 && odom[1].yaw.abs() < 1e-12,
            "{:?}",
            odom[1]
        );
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
        assert!(
            report.notes.iter().any(|n| n.contains("robot_frontlaser_offset 0.1 m not applied")),
            "{:?}",
            report.notes
        );
        assert_eq!(report.truth_poses, 3);
        assert!(report.notes.iter().any(|n| n.contains("1 NEFF")), "{:?}", report.notes);
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

    #[test]
    fn gzipped_logs_read_the_same() {
        use std::io::Write;
        let text = "ODOM 0 0 0 0 0 0 1.0 h 1.0\nFLASER 3 1 2 3 0 0 0 0 0 0 1.0 h 1.0\n";
        let plain = write("plain", text);
        let gz = plain.with_extension("gz");
        let mut enc =
            flate2::write::GzEncoder::new(std::fs::File::create(&gz).unwrap(), flate2::Compression::default());
        enc.write_all(text.as_bytes()).unwrap();
        enc.finish().unwrap();
        let a = read(&plain, &ImportOptions::default()).unwrap().0;
        let b = read(&gz, &ImportOptions::default()).unwrap().0;
        assert_eq!(a.records, b.records);
        assert_eq!(crate::detect_format(&gz).unwrap(), crate::LogFormat::Carmen);
    }
}
