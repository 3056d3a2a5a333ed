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
//! **Raw and corrected logs.** A *raw* log (what a robot records) holds odometry poses: the laser
//! lines' pose fields are the lidar's odometry pose and their odometry fields the robot's (equal
//! when the lidar sits at the robot's origin), and `ODOM` lines, if any, are the odometry as
//! the robot reported it. A *corrected* log (SLAM-corrected, as the Radish "-corrected" logs)
//! holds the same corrected pose in both triplets of every `FLASER`, and `ODOM` lines of raw
//! odometry re-anchored at each scan's corrected pose (an `ODOM` equal to the pose follows each
//! scan). [`CarmenKind::Auto`] tells them apart from what the file holds:
//!
//! - a laser message whose two triplets differ, or a `ROBOTLASER1`: **raw**;
//! - both triplets equal everywhere and no `ODOM` lines: **raw** (a lidar at the robot's origin;
//!   a corrected log keeps its raw odometry in `ODOM` lines, so one without them could not be
//!   localised anyway);
//! - both triplets equal everywhere and at least half of the scans followed by an `ODOM` are
//!   followed by one equal to their pose (the re-anchoring): **corrected**; fewer: **raw**.
//!
//! A raw log's odometry is its `ODOM` lines as written, or without them the laser lines'
//! odometry fields (one reading per scan); it has no reference. A corrected log is read as:
//! reference poses = the corrected poses; odometry = the raw odometry re-chained from the
//! increments `p_k⁻¹ ∘ q_{k+1}` (`p_k` the corrected pose of scan `k`, `q_{k+1}` the last `ODOM`
//! before scan `k + 1`), one reading at each scan's stamp, starting at the identity.
//! [`ImportOptions::carmen_kind`] overrides the decision; the import report's first note says
//! which kind was read and why.
//!
//! Negative timestamps (a few in real logs) read as 0, so where they are used they count as
//! steps back in the report.

use crate::assemble::{Assembler, RawOdometry, RawPose, RawScan};
use crate::options::{CarmenKind, ImportOptions, StampFrom, TimeSource};
use crate::report::ImportReport;
use crate::timing::{self, Spacing, StreamStamps};
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
    /// The printed step of the stamp, nanoseconds.
    quantum_ns: u64,
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
    line: usize,
    stamp_ns: u64,
    quantum_ns: u64,
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
    /// What salvaging a damaged file kept, if it had to.
    salvaged: Option<String>,
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
    let parsed = parse(reader, path, options.stamp, Damage { gz, salvage: options.salvage }, MAX_LINE_BYTES)?;
    assemble(parsed, path, options)
}

/// The longest line read, bytes (64 MiB): a laser line of 100,000 beams is about 1 MB.
const MAX_LINE_BYTES: usize = 64 << 20;

/// How a read error is met: whether the file is gzipped (named in the message), and whether to
/// salvage what came before it.
#[derive(Clone, Copy, Debug)]
struct Damage {
    gz: bool,
    salvage: bool,
}

/// Parses the lines of `reader`. With `damage.salvage`, a read error (a truncated or corrupt
/// gzip stream) ends the file where it happened, the partial line dropped, with a note.
/// A line longer than `max_line` bytes (its newline not counted) is refused.
fn parse(
    mut reader: Box<dyn BufRead>,
    path: &Path,
    stamp: StampFrom,
    damage: Damage,
    max_line: usize,
) -> Result<Parsed, ImportError> {
    let mut p = Parsed::default();
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    let mut text_bytes = 0u64;
    loop {
        buf.clear();
        // One byte past the longest line and its newline: enough to tell a line too long.
        let n = match (&mut reader).take(max_line as u64 + 2).read_until(b'\n', &mut buf) {
            Ok(n) => n,
            Err(e) => {
                let what = if damage.gz { "the gzip stream is truncated or corrupt" } else { "the file is damaged" };
                if damage.salvage {
                    p.salvaged = Some(format!(
                        "salvaged: read up to the damage ({what}: {e}): {line_no} complete lines, {text_bytes} bytes of text kept, \
the partial line and everything after it lost"
                    ));
                    break;
                }
                return Err(ImportError::parse(
                    path,
                    format!("line {}", line_no + 1),
                    format!("cannot read: {e} ({what}; --salvage reads up to the damage)"),
                ));
            }
        };
        if n == 0 {
            break;
        }
        text_bytes += n as u64;
        line_no += 1;
        if buf.strip_suffix(b"\n").unwrap_or(&buf).len() > max_line {
            // Not split in two: the rest would read as a line of its own, and every line number
            // after it would be off by one.
            return Err(ImportError::parse(
                path,
                format!("line {line_no}"),
                format!("longer than {max_line} bytes (a CARMEN line is a few kilobytes)"),
            ));
        }
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
                let (stamp_ns, quantum_ns) = f.stamp(7, stamp)?;
                let odom = Odom { line: line_no, stamp_ns, quantum_ns, pose: f.pose(1)? };
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

    /// The stamp: `ipc_timestamp` at `i` or `logger_timestamp` at `i + 2`, seconds, and its
    /// printed step, nanoseconds. A negative stamp (real logs have a few) reads as 0, so it
    /// counts as a step back where it is used.
    fn stamp(&self, i: usize, from: StampFrom) -> Result<(u64, u64), ImportError> {
        let (i, what) = match from {
            StampFrom::Header => (i, "ipc_timestamp"),
            StampFrom::Record => (i + 2, "logger_timestamp"),
        };
        let t = self.num(i, what)?;
        if t.abs() > 1.8e10 {
            return Err(self.err(format!("field {i} ({what}) is {t} s: expected at most 1.8e10 s")));
        }
        Ok(((t.max(0.0) * 1e9).round() as u64, timing::printed_quantum_ns(self.fields[i])))
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
        let (stamp_ns, quantum_ns) = self.stamp(n + 8, stamp)?;
        Ok(Laser {
            name,
            line: self.line,
            stamp_ns,
            quantum_ns,
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
        let (stamp_ns, quantum_ns) = self.stamp(at + 11, stamp)?;
        Ok(Laser {
            name: "ROBOTLASER1",
            line: self.line,
            stamp_ns,
            quantum_ns,
            angle_min: start,
            increment,
            ranges,
            pose: self.pose(at)?,
            robot: self.pose(at + 3)?,
            max_range: (max > 0.0).then_some(max as f32),
        })
    }
}

/// What a file holds that tells a raw log from a corrected one (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct KindEvidence {
    /// Laser messages.
    lasers: usize,
    /// Laser messages whose two triplets differ, or `ROBOTLASER1` messages, and the first one's line.
    differing: usize,
    first_differing_line: usize,
    /// `ODOM` lines.
    odom_lines: usize,
    /// Scans followed by at least one `ODOM` before the next scan, and those whose first such
    /// `ODOM` equals their pose (a corrected log's re-anchoring).
    followed: usize,
    anchors: usize,
}

impl KindEvidence {
    fn of(p: &Parsed) -> Self {
        let differs = |l: &&Laser| l.name == "ROBOTLASER1" || l.pose != l.robot;
        // The first ODOM after scan k − 1 (and before scan k), for k = 1 … n, in one pass (the
        // ODOM lines are in file order, so their scan counts never decrease).
        let mut first_after: Vec<Option<Pose2>> = vec![None; p.lasers.len() + 1];
        for (before, o) in &p.odometry {
            if let Some(slot) = first_after.get_mut(*before)
                && slot.is_none()
            {
                *slot = Some(o.pose);
            }
        }
        let followed = (1..=p.lasers.len()).filter(|&k| first_after[k].is_some()).count();
        let anchors = (1..=p.lasers.len()).filter(|&k| first_after[k] == Some(p.lasers[k - 1].robot)).count();
        Self {
            lasers: p.lasers.len(),
            differing: p.lasers.iter().filter(differs).count(),
            first_differing_line: p.lasers.iter().find(differs).map_or(0, |l| l.line),
            odom_lines: p.odometry.len(),
            followed,
            anchors,
        }
    }

    /// What the file says, in a sentence.
    fn said(&self) -> String {
        if self.differing > 0 {
            format!(
                "{} of {} laser messages have a pose triplet different from their odometry triplet (first at line {})",
                self.differing, self.lasers, self.first_differing_line
            )
        } else if self.odom_lines == 0 {
            format!(
                "all {} laser messages have equal pose and odometry triplets, and there are no ODOM lines",
                self.lasers
            )
        } else {
            format!(
                "all {} laser messages have equal pose and odometry triplets, and {} of the {} scans followed by an ODOM line are followed by one equal to their pose",
                self.lasers, self.anchors, self.followed
            )
        }
    }

    /// The kind the file shows.
    fn looks_corrected(&self) -> bool {
        self.differing == 0 && self.odom_lines > 0 && self.anchors > 0 && 2 * self.anchors >= self.followed
    }
}

/// The kind to read `p` as, and why (the import report's note); an error for a kind asked for
/// that the file cannot be.
fn decide_kind(
    p: &Parsed,
    asked: CarmenKind,
    odometry_from_scans: bool,
    path: &Path,
) -> Result<(bool, String), ImportError> {
    let e = KindEvidence::of(p);
    let looks = e.looks_corrected();
    let odometry = if e.odom_lines > 0 {
        "odometry = the ODOM lines as written"
    } else {
        "odometry = the laser lines' odometry fields, one reading per scan"
    };
    match asked {
        CarmenKind::Auto if looks => Ok((
            true,
            format!(
                "corrected log ({}): reference = the laser messages' corrected poses; odometry = raw increments re-chained",
                e.said()
            ),
        )),
        CarmenKind::Auto => Ok((false, format!("raw log ({}): {odometry}; no reference poses", e.said()))),
        CarmenKind::Raw => Ok((
            false,
            format!(
                "raw log (as asked; {}{}): {odometry}; no reference poses",
                e.said(),
                if looks {
                    ": the file looks corrected, so its ODOM lines are re-anchored at the scans, not continuous"
                } else {
                    ""
                }
            ),
        )),
        CarmenKind::Corrected if e.differing > 0 => Err(ImportError::parse(
            path,
            format!("line {}", e.first_differing_line),
            "read as a corrected log (as asked), but this laser message's pose and odometry triplets differ, which a corrected log's never do",
        )),
        CarmenKind::Corrected if e.odom_lines == 0 && !odometry_from_scans => Err(ImportError::parse(
            path,
            "the whole file",
            "read as a corrected log (as asked), but it has no ODOM lines: a corrected log's raw odometry is in them, and without it there is no odometry (read it as raw to take the poses as odometry, or make the odometry from the scans with --odometry-from-scans)",
        )),
        CarmenKind::Corrected => Ok((
            true,
            format!(
                "corrected log (as asked; {}): reference = the laser messages' corrected poses; odometry = raw increments re-chained",
                e.said()
            ),
        )),
    }
}

/// The file's no-return value: its largest reading if two or more beams hold exactly it.
fn no_return_value(lasers: &[Laser]) -> Option<f32> {
    let max = lasers.iter().flat_map(|l| l.ranges.iter().copied()).fold(f32::NEG_INFINITY, f32::max);
    let n = lasers.iter().flat_map(|l| l.ranges.iter()).filter(|&&r| r == max).count();
    (n >= 2).then_some(max)
}

fn assemble(mut p: Parsed, path: &Path, options: &ImportOptions) -> Result<(SensorLog, ImportReport), ImportError> {
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
    let (corrected, why) = decide_kind(&p, options.carmen_kind, options.odometry == OdometryFrom::Scans, path)?;
    a.note(why);
    if let Some(note) = settle_time(&mut p, corrected, path, options)? {
        a.note(note);
    }
    if let Some(s) = &p.salvaged {
        a.note(s.clone());
    }
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
            time_increment_s: 0.0,
            place: format!("line {}", l.line),
            record_ns: None,
        });
    }
    if let Some(v) = no_return {
        a.note(format!(
            "no-return value {v} m (the file's largest reading, held by several beams): those beams are invalid"
        ));
    }
    let raw_topic = add_odometry(&p, corrected, &mut a);
    for (k, n) in &p.skipped {
        a.note(format!("{n} {k} message(s) skipped"));
    }
    let mut options = options.clone();
    if options.odometry == OdometryFrom::Auto || options.odometry == OdometryFrom::Topic("ODOM".into()) {
        options.odometry = OdometryFrom::Topic(if corrected { RECHAINED.into() } else { raw_topic.into() });
    }
    a.finish(&options)
}

/// Hands the odometry to the assembler: a corrected log's re-chained increments (and its
/// reference), else the `ODOM` lines as written, else the laser lines' odometry fields. Returns
/// the raw odometry's stream name.
fn add_odometry(p: &Parsed, corrected: bool, a: &mut Assembler) -> &'static str {
    let raw_topic = if p.odometry.is_empty() { LASER_ODOMETRY } else { "ODOM" };
    if corrected {
        rechain(p, a);
    } else if p.odometry.is_empty() {
        for l in &p.lasers {
            a.odometry(RawOdometry {
                topic: LASER_ODOMETRY.into(),
                stamp_ns: l.stamp_ns,
                pose: l.robot,
                record_ns: None,
            });
        }
    } else {
        for (_, o) in &p.odometry {
            a.odometry(RawOdometry { topic: "ODOM".into(), stamp_ns: o.stamp_ns, pose: o.pose, record_ns: None });
        }
    }
    raw_topic
}

/// One timed message of the file: a laser message (its index) or an `ODOM` line (its index).
#[derive(Clone, Copy)]
enum Timed {
    Laser(usize),
    Odom(usize),
}

/// Checks that the stamps of the streams the log's times come from (the laser messages, and a
/// raw log's `ODOM` lines as written) can order them (`timing`); where they cannot (or with
/// `--time-source line`), times the messages in line order instead. Returns the import report's
/// note, if there is one to make.
fn settle_time(
    p: &mut Parsed,
    corrected: bool,
    path: &Path,
    options: &ImportOptions,
) -> Result<Option<String>, ImportError> {
    // The lidars read (the scan topics asked for, else all) and a raw log's ODOM lines.
    let chosen = |name: &str| options.scan_topics.is_empty() || options.scan_topics.iter().any(|t| t == name);
    let mut timed: Vec<(usize, Timed)> =
        p.lasers.iter().enumerate().filter(|(_, l)| chosen(l.name)).map(|(i, l)| (l.line, Timed::Laser(i))).collect();
    let odom_used = !corrected && !p.odometry.is_empty();
    if odom_used {
        timed.extend(p.odometry.iter().enumerate().map(|(i, (_, o))| (o.line, Timed::Odom(i))));
    }
    timed.sort_by_key(|t| t.0);
    let stamp = |t: &Timed| match *t {
        Timed::Laser(i) => (p.lasers[i].stamp_ns, p.lasers[i].quantum_ns),
        Timed::Odom(i) => (p.odometry[i].1.stamp_ns, p.odometry[i].1.quantum_ns),
    };
    let name = |t: &Timed| match *t {
        Timed::Laser(i) => p.lasers[i].name,
        Timed::Odom(_) => "ODOM",
    };
    let reasons = distrusted(&timed, &name, &stamp);
    let unused_rate = options.rate_hz.map(|r| format!("--rate {r} is not used: the stamps time the log"));
    match options.time_source {
        TimeSource::Stamp if reasons.is_empty() => return Ok(unused_rate),
        TimeSource::Stamp => {
            return Ok(Some(format!(
                "timestamps taken as written (--time-source stamp) though they cannot order the messages ({}): scans and \
odometry may be paired wrongly{}",
                reasons.join("; "),
                unused_rate.map_or(String::new(), |r| format!("; {r}"))
            )));
        }
        TimeSource::Auto if reasons.is_empty() => return Ok(unused_rate),
        TimeSource::Auto | TimeSource::Line => {}
    }
    // The first lidar: the first scan topic asked for, else the first by name (lidar 0).
    let first_lidar = options.scan_topics.first().map(String::as_str).or_else(|| {
        let mut l: Vec<&str> = p.lasers.iter().map(|l| l.name).collect();
        l.sort_unstable();
        l.first().copied()
    });
    let scans: Vec<usize> = (0..timed.len()).filter(|&k| Some(name(&timed[k].1)) == first_lidar).collect();
    let stamps: Vec<u64> = timed.iter().map(|t| stamp(&t.1).0).collect();
    let quanta: Vec<u64> = timed.iter().map(|t| stamp(&t.1).1).collect();
    let quantum = timing::median(&quanta);
    let why = if reasons.is_empty() { "--time-source line".to_string() } else { reasons.join("; ") };
    let (times, spacing) = timing::by_order(&stamps, quantum, &scans, options.rate_hz).map_err(|k| {
        let changes = timing::changes(&stamps).len();
        ImportError::parse(
            path,
            format!("line {}", timed.get(k).map_or(0, |t| t.0)),
            format!(
                "the timestamps cannot order the messages ({why}), and the lines cannot be timed from them either: \
the printed time moves on {changes} time(s) over {} messages, too few or too far apart to space them; give the scan \
rate of {} with --rate HZ (or take the stamps as written with --time-source stamp)",
                stamps.len(),
                first_lidar.unwrap_or("the first lidar")
            ),
        )
    })?;
    for ((_, t), time) in timed.iter().zip(&times) {
        match *t {
            Timed::Laser(i) => p.lasers[i].stamp_ns = *time,
            Timed::Odom(i) => p.odometry[i].1.stamp_ns = *time,
        }
    }
    let duration = (times.last().copied().unwrap_or(0) - times.first().copied().unwrap_or(0)) as f64 * 1e-9;
    let spaced = match spacing {
        Spacing::Printed { anchors } => {
            format!("spaced evenly between the {anchors} lines where the printed time moves on")
        }
        Spacing::Rate(r) => format!("spaced from --rate {r} Hz of {}", first_lidar.unwrap_or("the first lidar")),
    };
    Ok(Some(format!(
        "timestamps not used ({why}): the {} timed messages are ordered by line (a CARMEN log is written in time \
order) and {spaced}: {duration:.1} s",
        times.len()
    )))
}

/// Why each stream of `timed` (line, message) whose stamps cannot order it cannot
/// (`StreamStamps::distrust`); `name` and `stamp` give a message's stream and (stamp, printed step).
fn distrusted(
    timed: &[(usize, Timed)],
    name: &impl Fn(&Timed) -> &'static str,
    stamp: &impl Fn(&Timed) -> (u64, u64),
) -> Vec<String> {
    let mut names: Vec<&str> = timed.iter().map(|t| name(&t.1)).collect();
    names.sort_unstable();
    names.dedup();
    names
        .iter()
        .filter_map(|n| {
            let msgs: Vec<&(usize, Timed)> = timed.iter().filter(|t| name(&t.1) == *n).collect();
            let stamps: Vec<u64> = msgs.iter().map(|t| stamp(&t.1).0).collect();
            let quanta: Vec<u64> = msgs.iter().map(|t| stamp(&t.1).1).collect();
            StreamStamps::of(n, &stamps, &quanta, |i| format!("line {}", msgs[i].0)).distrust()
        })
        .collect()
}

/// The name of a raw log's odometry stream when it has no `ODOM` lines.
pub const LASER_ODOMETRY: &str = "the laser lines' odometry fields";

/// The name of the re-chained odometry stream of a corrected log.
pub const RECHAINED: &str = "ODOM (raw increments re-chained at the scans)";

/// A corrected log's reference poses and re-chained raw odometry (see the module docs).
fn rechain(p: &Parsed, a: &mut Assembler) {
    // The last ODOM after scan k − 1 and before scan k, for k = 1 … n, in one pass (the
    // re-anchoring line, equal to scan k − 1's pose, if it is the only one: no motion).
    let mut last_before: Vec<Option<Pose2>> = vec![None; p.lasers.len() + 1];
    for (before, o) in &p.odometry {
        if let Some(slot) = last_before.get_mut(*before) {
            *slot = Some(o.pose);
        }
    }
    let mut odom = Pose2::IDENTITY;
    for (k, l) in p.lasers.iter().enumerate() {
        if k > 0 {
            let prev = &p.lasers[k - 1];
            let q = last_before[k].unwrap_or(prev.robot);
            odom = odom.compose(&prev.robot.between(&q));
        }
        a.odometry(RawOdometry { topic: RECHAINED.into(), stamp_ns: l.stamp_ns, pose: odom, record_ns: None });
        a.truth(
            RawPose { stamp_ns: l.stamp_ns, pose: l.robot, record_ns: None },
            "the corrected poses of the laser messages",
        );
    }
    a.note(format!("re-chained odometry: one reading per scan from {} ODOM lines", p.odometry.len()));
}

#[cfg(test)]
mod tests;
