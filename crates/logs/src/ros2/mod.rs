//! ROS 2 bags in MCAP storage: a bare `.mcap` file, or a bag folder (`metadata.yaml` and its
//! `.mcap` files, read in the order `metadata.yaml` lists them, or by name).
//!
//! Messages are CDR (`cdr.rs`) and their types are known by their schema's name:
//!
//! - `sensor_msgs/msg/LaserScan` on any topic (or only [`ImportOptions::scan_topics`]): the
//!   lidars. `range_max` is inclusive in ROS, so the scan's exclusive limit is the next float
//!   above it.
//! - `nav_msgs/msg/Odometry`: odometry (the assembler picks `/odom`, the only such topic, or
//!   the `odom → base` transform of `/tf`; see [`crate::OdometryFrom`]).
//! - `tf2_msgs/msg/TFMessage` on `/tf` and `/tf_static`: the transforms (lidar mounts, and
//!   odometry from `/tf`).
//! - On [`ImportOptions::truth_topic`]: `geometry_msgs/msg/PoseStamped`,
//!   `geometry_msgs/msg/PoseWithCovarianceStamped` or `nav_msgs/msg/Odometry`, the reference.
//!
//! Every message is counted by topic; other types are skipped. Stamps are the messages'
//! `header.stamp` ([`StampFrom::Header`]) or the MCAP `log_time` ([`StampFrom::Record`]).
//!
//! The run writer ([`McapRunWriter`]) writes the other way: a run of the simulator or of a
//! replayed log as a bag that Foxglove Studio and `ros2 bag` read.

mod cdr;
mod msgs;
mod schemas;
mod writer;

pub use writer::{
    CHANGE_ADDED, CHANGE_NONE, CHANGE_OTHER, CHANGE_REMOVED, McapRunWriter, McapWriteError, UpdaterStepMsg,
    write_log_mcap,
};

use crate::assemble::{Assembler, RawOdometry, RawPose, RawScan, RawTransform, RosScanFields};
use crate::options::{ImportOptions, OdometryFrom, StampFrom};
use crate::report::ImportReport;
use crate::{ImportError, Rigid3};
use mapkeeper_grid::Pose2;
use mapkeeper_sensor::SensorLog;
use std::cell::Cell;
use std::cmp::Ordering;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

use std::rc::Rc;

/// The latest MCAP `log_time` read as a stamp (`--stamp record`): i64 nanoseconds' last instant,
/// in the year 2262. A later `log_time` is not a time (a corrupt or fuzzed record) and is refused
/// by name rather than carried into the stamp arithmetic.
pub const MAX_RECORD_STAMP_NS: u64 = i64::MAX as u64;

/// The largest record (a message, or a chunk's compressed bytes) read, bytes: a corrupt length
/// cannot make the reader allocate more (a 16384² occupancy grid still fits).
const RECORD_LIMIT: usize = 1 << 28;

/// Reads a ROS 2 bag in MCAP storage (a `.mcap` file or a bag folder).
pub fn read(path: &Path, options: &ImportOptions) -> Result<(SensorLog, ImportReport), ImportError> {
    let files = bag_files(path)?;
    let mut reader = BagReader { options, asm: Assembler::new(path, "ros2 mcap") };
    for file in &files {
        reader.read_file(path, file)?;
    }
    if path.is_dir() {
        let names: Vec<String> =
            files.iter().map(|f| f.file_name().unwrap_or_default().to_string_lossy().into_owned()).collect();
        reader.asm.note(format!("bag folder: read {} file(s): {}", files.len(), names.join(", ")));
    }
    reader.asm.finish(options)
}

/// The `.mcap` files of a bag: `path` itself if it is a file; for a bag folder, the files its
/// `metadata.yaml` lists (`relative_file_paths`), or else every `.mcap` in it by name (numbers
/// in names compared as numbers, so `bag_10` follows `bag_9`).
pub fn bag_files(path: &Path) -> Result<Vec<PathBuf>, ImportError> {
    if !path.is_dir() {
        return Ok(vec![path.to_path_buf()]);
    }
    let meta = path.join("metadata.yaml");
    let text = match std::fs::read_to_string(&meta) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(e) => return Err(ImportError::io(&meta, e)),
    };
    if let Some(storage) = yaml_value(&text, "storage_identifier")
        && storage != "mcap"
    {
        return Err(ImportError::unusable(
            path,
            format!(
                "the bag's storage is '{storage}', not mcap: convert it with `ros2 bag convert` (storage_id: mcap)"
            ),
        ));
    }
    let files = match listed_files(&text) {
        Some(names) => {
            // Listed paths are relative to the bag folder: one that leaves it is refused, naming
            // the folder (the error must name what the user gave).
            if let Some(bad) =
                names.iter().find(|n| Path::new(n).components().any(|c| !matches!(c, std::path::Component::Normal(_))))
            {
                return Err(ImportError::unusable(
                    path,
                    format!("metadata.yaml lists '{bad}', which is not a path inside the bag folder"),
                ));
            }
            names.iter().map(|n| path.join(n)).collect()
        }
        None => folder_mcaps(path)?,
    };
    if files.is_empty() {
        return Err(ImportError::unusable(path, "a bag folder without .mcap files"));
    }
    for f in &files {
        let name = f.file_name().unwrap_or_default().to_string_lossy();
        if name.ends_with(".zstd") || name.ends_with(".lz4") {
            return Err(ImportError::unusable(
                f,
                "a file-compressed bag: decompress its files first (`zstd -d`), or re-record with chunk compression",
            ));
        }
        if !f.is_file() {
            return Err(ImportError::unusable(
                path,
                format!("metadata.yaml lists '{}', but it is not in the bag folder", f.display()),
            ));
        }
    }
    Ok(files)
}

/// The value of a top-level or nested `key: value` line of a YAML file (no YAML parser: the
/// first line with the key).
fn yaml_value<'a>(text: &'a str, key: &str) -> Option<&'a str> {
    text.lines().find_map(|l| {
        let rest = l.trim_start().strip_prefix(key)?.strip_prefix(':')?;
        Some(rest.trim().trim_matches(|c| c == '"' || c == '\''))
    })
}

/// `relative_file_paths` of a `metadata.yaml`, as a block list (`- a.mcap`) or a flow list
/// (`[a.mcap, b.mcap]`); `None` if it is missing or empty.
fn listed_files(text: &str) -> Option<Vec<String>> {
    let unquote = |s: &str| s.trim().trim_matches(|c| c == '"' || c == '\'').to_string();
    let mut lines = text.lines();
    let rest = lines.by_ref().find_map(|l| l.trim_start().strip_prefix("relative_file_paths:"))?.trim();
    let names: Vec<String> = if let Some(flow) = rest.strip_prefix('[') {
        flow.trim_end_matches(']').split(',').map(unquote).filter(|s| !s.is_empty()).collect()
    } else {
        lines.filter(|l| !l.trim().is_empty()).map_while(|l| l.trim_start().strip_prefix("- ").map(unquote)).collect()
    };
    (!names.is_empty()).then_some(names)
}

/// Every `.mcap` file of a folder in natural name order.
fn folder_mcaps(dir: &Path) -> Result<Vec<PathBuf>, ImportError> {
    let entries = std::fs::read_dir(dir).map_err(|e| ImportError::io(dir, e))?;
    let mut files = Vec::new();
    for e in entries {
        let p = e.map_err(|e| ImportError::io(dir, e))?.path();
        if p.is_file() && p.extension().is_some_and(|x| x == "mcap") {
            files.push(p);
        }
    }
    files.sort_by(|a, b| natural_cmp(&a.to_string_lossy(), &b.to_string_lossy()));
    Ok(files)
}

/// Compares names with their runs of digits as numbers; names equal that way (`bag_1` and
/// `bag_01`) are ordered as plain strings, so that the order never depends on the file
/// system's listing.
fn natural_cmp(a: &str, b: &str) -> Ordering {
    natural_cmp_numbers(a, b).then_with(|| a.cmp(b))
}

fn natural_cmp_numbers(a: &str, b: &str) -> Ordering {
    let (mut x, mut y) = (a.as_bytes(), b.as_bytes());
    loop {
        match (x.first(), y.first()) {
            (None, None) => return Ordering::Equal,
            (None, Some(_)) => return Ordering::Less,
            (Some(_), None) => return Ordering::Greater,
            (Some(c), Some(d)) if c.is_ascii_digit() && d.is_ascii_digit() => {
                let nx = x.iter().take_while(|c| c.is_ascii_digit()).count();
                let ny = y.iter().take_while(|c| c.is_ascii_digit()).count();
                let trim = |s: &[u8]| -> Vec<u8> { s.iter().copied().skip_while(|&c| c == b'0').collect() };
                let (dx, dy) = (trim(&x[..nx]), trim(&y[..ny]));
                let o = dx.len().cmp(&dy.len()).then_with(|| dx.cmp(&dy));
                if o != Ordering::Equal {
                    return o;
                }
                (x, y) = (&x[nx..], &y[ny..]);
            }
            (Some(c), Some(d)) => {
                if c != d {
                    return c.cmp(d);
                }
                (x, y) = (&x[1..], &y[1..]);
            }
        }
    }
}

/// A message type the reader knows, from its schema name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    LaserScan,
    Odometry,
    Tf,
    PoseStamped,
    PoseWithCovarianceStamped,
    Other,
}

impl Kind {
    /// The kind of a schema name (`pkg/msg/Type`, or `pkg/Type` as some converters write it).
    fn of(schema_name: &str) -> Kind {
        match schema_name.replace("/msg/", "/").as_str() {
            "sensor_msgs/LaserScan" => Kind::LaserScan,
            "nav_msgs/Odometry" => Kind::Odometry,
            "tf2_msgs/TFMessage" => Kind::Tf,
            "geometry_msgs/PoseStamped" => Kind::PoseStamped,
            "geometry_msgs/PoseWithCovarianceStamped" => Kind::PoseWithCovarianceStamped,
            _ => Kind::Other,
        }
    }
}

/// What a message is used for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Skip,
    Scan,
    Odometry,
    Truth,
    Tf { is_static: bool },
}

/// Counts the bytes read from a file, for the place of an error.
struct Counting<R> {
    inner: R,
    read: Rc<Cell<u64>>,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.read.set(self.read.get() + n as u64);
        Ok(n)
    }
}

/// Refuses an uncompressed chunk holding a record longer than what is left of the chunk.
///
/// The `mcap` crate (0.26, `sans_io/linear_reader.rs`) subtracts such a record's length from the
/// chunk's remaining bytes unchecked: with overflow checks (debug builds, the fuzz build) it
/// panics, without them the count wraps and a later length check refuses the file. Found by the
/// `ros2_mcap` fuzz target; this walk of the top-level records makes the refusal the same,
/// one line, in every build. It reads only record headers (9 bytes, and a chunk's fields) and
/// stops quietly where the file stops making sense: the `mcap` reader reports that.
fn check_plain_chunks(file: &Path) -> Result<(), ImportError> {
    use std::io::{Seek, SeekFrom};
    const CHUNK: u8 = 0x06;
    const FOOTER: u8 = 0x02;
    let f = std::fs::File::open(file).map_err(|e| ImportError::io(file, e))?;
    let size = f.metadata().map_err(|e| ImportError::io(file, e))?.len();
    let mut r = BufReader::with_capacity(1 << 12, f);
    let mut pos = 8u64; // the magic
    let mut head = [0u8; 9];
    let u64_at = |b: &[u8], at: usize| b.get(at..at + 8).and_then(|x| x.try_into().ok()).map(u64::from_le_bytes);
    while pos.saturating_add(9) <= size {
        if r.seek(SeekFrom::Start(pos)).is_err() || r.read_exact(&mut head).is_err() {
            return Ok(());
        }
        let (opcode, len) = (head[0], u64::from_le_bytes(head[1..9].try_into().unwrap_or_default()));
        if opcode == FOOTER {
            return Ok(());
        }
        // A chunk that runs past the end of the file is still streamed by the reader: check
        // what there is of it.
        let end = (pos + 9).saturating_add(len);
        if opcode == CHUNK && len.min(size - pos - 9) <= 1 << 20 {
            // start, end, uncompressed size (8 each), crc (4), compression (4 + n), records size (8), records.
            let mut body = vec![0u8; len.min(size - pos - 9) as usize];
            if r.read_exact(&mut body).is_err() {
                return Ok(());
            }
            let n = body.get(28..32).and_then(|x| x.try_into().ok()).map_or(0, u32::from_le_bytes) as usize;
            let at = 32usize.saturating_add(n);
            if n == 0
                && let Some(records) = u64_at(&body, at)
            {
                let mut left = records.min((body.len() - (at + 8).min(body.len())) as u64);
                let mut inner = at + 8;
                while left > 0 {
                    let Some(l) = u64_at(&body, inner + 1) else { break };
                    let need = l.checked_add(9);
                    if need.is_none_or(|need| need > left) {
                        return Err(ImportError::parse(
                            file,
                            format!("byte {}", pos + 9 + inner as u64),
                            format!(
                                "MCAP: a record of {l} bytes in an uncompressed chunk with {} bytes left: the chunk is damaged",
                                left.saturating_sub(9)
                            ),
                        ));
                    }
                    let need = need.unwrap_or(left);
                    left -= need;
                    inner += need as usize;
                }
            }
        }
        pos = end;
    }
    Ok(())
}

/// One message being decoded: where it is, for errors.
struct At<'a> {
    file: &'a Path,
    place: String,
    type_name: &'a str,
}

impl At<'_> {
    fn err(&self, e: cdr::CdrError) -> ImportError {
        ImportError::parse(self.file, &self.place, format!("{}: {e}", self.type_name))
    }
}

/// Why [`read_messages`] stopped: the file, after `usize` messages, or the caller.
enum Stop {
    Mcap(mcap::McapError, usize),
    Import(ImportError),
}

/// Every message of an MCAP stream, in file order, handed to `each`. Only the records a
/// message needs are parsed (schemas, channels, messages, linked and checked by the `mcap`
/// crate's `ChannelAccumulator`); attachments, metadata, indexes and the summary are skipped
/// unparsed. (The `mcap` crate's own `MessageReader` parses every record, and 0.26 slices an
/// attachment whose declared lengths exceed its record unchecked: a panic, found by the
/// `ros2_mcap` fuzz target.)
fn read_messages<R: Read>(
    mut source: R,
    opts: mcap::sans_io::LinearReaderOptions,
    each: &mut dyn FnMut(&mcap::Message<'_>) -> Result<(), ImportError>,
) -> Result<(), Stop> {
    use mcap::records::{Record, op};
    use mcap::sans_io::LinearReadEvent;
    let mut reader = mcap::sans_io::LinearReader::new_with_options(opts);
    let mut channels = mcap::read::ChannelAccumulator::default();
    let mut count = 0usize;
    while let Some(event) = reader.next_event() {
        let (opcode, data) = match event.map_err(|e| Stop::Mcap(e, count))? {
            LinearReadEvent::ReadRequest(need) => {
                let n = loop {
                    match source.read(reader.insert(need)) {
                        Ok(n) => break n,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        Err(e) => return Err(Stop::Mcap(e.into(), count)),
                    }
                };
                reader.notify_read(n);
                continue;
            }
            LinearReadEvent::Record { opcode, data } => (opcode, data),
        };
        if !matches!(opcode, op::SCHEMA | op::CHANNEL | op::MESSAGE) {
            continue;
        }
        let fail = |e| Stop::Mcap(e, count);
        match mcap::parse_record(opcode, data).map_err(fail)? {
            Record::Schema { header, data } => channels.add_schema_from_slice(header, &data).map_err(fail)?,
            Record::Channel(c) => channels.add_channel(c).map_err(fail)?,
            Record::Message { header, data } => {
                let channel = channels
                    .get(header.channel_id)
                    .ok_or(Stop::Mcap(mcap::McapError::UnknownChannel(header.sequence, header.channel_id), count))?;
                let m = mcap::Message {
                    channel,
                    sequence: header.sequence,
                    log_time: header.log_time,
                    publish_time: header.publish_time,
                    data,
                };
                count += 1;
                each(&m).map_err(Stop::Import)?;
            }
            _ => {}
        }
    }
    Ok(())
}

struct BagReader<'a> {
    options: &'a ImportOptions,
    asm: Assembler,
}

impl BagReader<'_> {
    /// Reads every message of `file` (part of the bag at `bag`).
    fn read_file(&mut self, bag: &Path, file: &Path) -> Result<(), ImportError> {
        check_plain_chunks(file)?;
        let f = std::fs::File::open(file).map_err(|e| ImportError::io(file, e))?;
        let read = Rc::new(Cell::new(0u64));
        let source = Counting { inner: BufReader::with_capacity(1 << 16, f), read: read.clone() };
        let opts = mcap::sans_io::LinearReaderOptions::default()
            .with_validate_chunk_crcs(true)
            .with_record_length_limit(RECORD_LIMIT);
        // Places in a bag folder name the file, as the assembler's errors name the folder.
        let prefix = if bag == file {
            String::new()
        } else {
            format!("{}: ", file.file_name().unwrap_or_default().to_string_lossy())
        };
        let mut index = 0usize;
        let mut each = |m: &mcap::Message<'_>| {
            index += 1;
            self.message(file, &prefix, index, m)
        };
        read_messages(source, opts, &mut each).map_err(|e| match e {
            Stop::Mcap(e, at) => mcap_error(file, at, read.get(), &e),
            Stop::Import(e) => e,
        })
    }

    fn message(&mut self, file: &Path, prefix: &str, index: usize, m: &mcap::Message<'_>) -> Result<(), ImportError> {
        let topic = m.channel.topic.as_str();
        let type_name = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
        self.asm.count_message(topic, type_name);
        let role = self.role(file, topic, type_name)?;
        if role == Role::Skip {
            return Ok(());
        }
        let at = At { file, place: format!("message {index} on {topic} (log_time {} ns)", m.log_time), type_name };
        if m.channel.message_encoding != "cdr" {
            return Err(ImportError::parse(
                file,
                &at.place,
                format!("{type_name} in encoding '{}': only ROS 2 CDR messages are read", m.channel.message_encoding),
            ));
        }
        let record_ns = self.record_ns(&at, m.log_time)?;
        let stamp = |header_ns: u64| match self.options.stamp {
            StampFrom::Header => header_ns,
            StampFrom::Record => m.log_time,
        };
        let data = &m.data[..];
        match role {
            Role::Skip => {}
            Role::Scan => {
                let s = msgs::laser_scan(data).map_err(|e| at.err(e))?;
                let fields = RosScanFields {
                    angle_min: s.angle_min,
                    angle_increment: s.angle_increment,
                    time_increment: s.time_increment,
                    range_min: s.range_min,
                    range_max: s.range_max,
                    ranges: s.ranges,
                };
                let place = format!("{prefix}message {index} (log_time {} ns)", m.log_time);
                let raw = RawScan::from_ros(topic, s.header.frame_id, stamp(s.header.stamp_ns), fields, place);
                self.asm.scan(RawScan { record_ns, ..raw });
            }
            Role::Odometry => {
                let o = msgs::odometry(data).map_err(|e| at.err(e))?;
                let pose = planar(&at, &o.pose)?;
                self.asm.odometry(RawOdometry {
                    topic: topic.to_string(),
                    stamp_ns: stamp(o.header.stamp_ns),
                    pose,
                    record_ns,
                });
            }
            Role::Truth => {
                let p = match Kind::of(type_name) {
                    Kind::Odometry => msgs::odometry(data),
                    Kind::PoseStamped => msgs::pose_stamped(data),
                    _ => msgs::pose_with_covariance_stamped(data),
                }
                .map_err(|e| at.err(e))?;
                let pose = planar(&at, &p.pose)?;
                let source = format!("{topic} ({type_name})");
                self.asm.truth(RawPose { stamp_ns: stamp(p.header.stamp_ns), pose, record_ns }, &source);
            }
            Role::Tf { is_static } => {
                for t in msgs::tf_message(data).map_err(|e| at.err(e))? {
                    let transform = rigid(&at, &t.pose)?;
                    self.asm.transform(RawTransform {
                        stamp_ns: stamp(t.header.stamp_ns),
                        parent: t.header.frame_id,
                        child: t.child_frame_id,
                        transform,
                        is_static,
                        record_ns,
                    });
                }
            }
        }
        Ok(())
    }

    /// A message's `log_time` as a record time: `None` past i64 nanoseconds (the year 2262), which
    /// is refused under `--stamp record`.
    fn record_ns(&self, at: &At<'_>, log_time: u64) -> Result<Option<u64>, ImportError> {
        if self.options.stamp == StampFrom::Record && log_time > MAX_RECORD_STAMP_NS {
            return Err(ImportError::parse(
                at.file,
                &at.place,
                format!(
                    "log_time {log_time} ns is past {MAX_RECORD_STAMP_NS} ns (the year 2262, the last time i64 \
                     nanoseconds hold): not a time, cannot stamp with --stamp record"
                ),
            ));
        }
        Ok((log_time <= MAX_RECORD_STAMP_NS).then_some(log_time))
    }

    /// What a message of `topic` with schema `type_name` is used for; a topic named in the
    /// options with the wrong type is refused.
    fn role(&self, file: &Path, topic: &str, type_name: &str) -> Result<Role, ImportError> {
        let kind = Kind::of(type_name);
        let o = self.options;
        let wrong = |role: &str, wanted: &str| {
            ImportError::unusable(
                file,
                format!("{role} topic '{topic}' has type '{type_name}', not {wanted}: choose another topic"),
            )
        };
        if o.scan_topics.iter().any(|t| t == topic) && kind != Kind::LaserScan {
            return Err(wrong("scan", "sensor_msgs/msg/LaserScan"));
        }
        let is_truth = o.truth_topic.as_deref() == Some(topic);
        if is_truth && !matches!(kind, Kind::Odometry | Kind::PoseStamped | Kind::PoseWithCovarianceStamped) {
            return Err(wrong(
                "reference",
                "geometry_msgs/msg/PoseStamped, geometry_msgs/msg/PoseWithCovarianceStamped or nav_msgs/msg/Odometry",
            ));
        }
        let odometry_topic = matches!(&o.odometry, OdometryFrom::Topic(t) if t == topic);
        if odometry_topic && kind != Kind::Odometry {
            return Err(wrong("odometry", "nav_msgs/msg/Odometry"));
        }
        Ok(match kind {
            _ if is_truth => Role::Truth,
            Kind::LaserScan if o.scan_topics.is_empty() || o.scan_topics.iter().any(|t| t == topic) => Role::Scan,
            Kind::Odometry if odometry_topic || o.odometry == OdometryFrom::Auto => Role::Odometry,
            Kind::Tf if topic == "/tf" => Role::Tf { is_static: false },
            Kind::Tf if topic == "/tf_static" => Role::Tf { is_static: true },
            _ => Role::Skip,
        })
    }
}

/// A pose or transform as a rigid transform; a non-finite value or a zero quaternion is refused.
fn rigid(at: &At<'_>, p: &msgs::Pose) -> Result<Rigid3, ImportError> {
    Rigid3::from_translation_quaternion(p.position, p.orientation).ok_or_else(|| {
        ImportError::parse(
            at.file,
            &at.place,
            format!(
                "{}: position {:?} / orientation {:?} is not a pose (a value is not finite, or the quaternion is zero)",
                at.type_name, p.position, p.orientation
            ),
        )
    })
}

/// A pose projected on the plane.
fn planar(at: &At<'_>, p: &msgs::Pose) -> Result<Pose2, ImportError> {
    Ok(rigid(at, p)?.planar().0)
}

/// The message of an error of the `mcap` crate without what follows its first line: a parse
/// error of its `binrw` records prints a coloured backtrace there, whose one useful line
/// (`Error: …`) is kept.
fn first_line(s: &str) -> String {
    let mut plain = String::with_capacity(s.len());
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            // An ANSI escape: ESC [ parameters letter.
            for d in chars.by_ref() {
                if d.is_ascii_alphabetic() {
                    break;
                }
            }
        } else {
            plain.push(c);
        }
    }
    let mut lines = plain.lines().map(str::trim);
    let mut out = lines.next().unwrap_or_default().trim_end_matches(':').trim().to_string();
    if let Some(cause) = plain.lines().find_map(|l| l.trim().split_once("Error: ").map(|(_, e)| e.trim().to_string())) {
        out = if out.is_empty() { cause } else { format!("{out}: {cause}") };
    }
    out
}

/// An error of the MCAP container (not of a message in it).
fn mcap_error(file: &Path, after: usize, byte: u64, e: &mcap::McapError) -> ImportError {
    let what = match e {
        mcap::McapError::UnexpectedEof => {
            "the file ends in the middle of a record: it is truncated (the MCAP CLI's `mcap recover` can often save a \
recording cut short)"
                .to_string()
        }
        mcap::McapError::BadMagic => "not an MCAP file, or its end is missing (bad magic bytes)".to_string(),
        mcap::McapError::RecordTooLarge { len, .. } | mcap::McapError::ChunkTooLarge(len) => {
            format!(
                "a record of {len} bytes, more than the {} MiB this reader accepts (a corrupt length?)",
                RECORD_LIMIT >> 20
            )
        }
        other => {
            let mut s = first_line(&other.to_string());
            let mut source = std::error::Error::source(other);
            while let Some(c) = source {
                s.push_str(&format!(": {}", first_line(&c.to_string())));
                source = c.source();
            }
            s
        }
    };
    ImportError::parse(file, format!("byte {byte} (after message {after})"), format!("MCAP: {what}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metadata_lists_and_natural_order() {
        let yaml = "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n  relative_file_paths:\n    - run_0.mcap\n    - \"run_1.mcap\"\n  duration:\n    nanoseconds: 5\n";
        assert_eq!(listed_files(yaml).unwrap(), vec!["run_0.mcap", "run_1.mcap"]);
        assert_eq!(yaml_value(yaml, "storage_identifier"), Some("mcap"));
        assert_eq!(listed_files("relative_file_paths: [a.mcap, 'b.mcap']\n").unwrap(), vec!["a.mcap", "b.mcap"]);
        assert!(listed_files("relative_file_paths:\nfiles:\n").is_none());
        let mut names = vec!["bag_10.mcap", "bag_9.mcap", "bag_0.mcap", "a.mcap", "bag_09b.mcap"];
        names.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(names, vec!["a.mcap", "bag_0.mcap", "bag_9.mcap", "bag_09b.mcap", "bag_10.mcap"]);
        // Equal as numbers: one order whatever order they were listed in.
        let (mut one, mut two) = (vec!["bag_01.mcap", "bag_1.mcap"], vec!["bag_1.mcap", "bag_01.mcap"]);
        one.sort_by(|a, b| natural_cmp(a, b));
        two.sort_by(|a, b| natural_cmp(a, b));
        assert_eq!(one, two);
        assert_eq!(natural_cmp("bag_01.mcap", "bag_1.mcap"), Ordering::Less);
    }

    #[test]
    fn mcap_errors_become_one_plain_line() {
        let binrw = "Record parse failed: \n \u{1b}[1m╺━━┅ Backtrace ┅━━╸\u{1b}[22m\n\n 0: \u{1b}[1m\u{1b}[1mError: not enough bytes in reader\u{1b}[22m\n   at x.rs:1";
        assert_eq!(first_line(binrw), "Record parse failed: not enough bytes in reader");
        assert_eq!(first_line("bad magic"), "bad magic");
    }

    #[test]
    fn schema_names_with_or_without_msg() {
        assert_eq!(Kind::of("sensor_msgs/msg/LaserScan"), Kind::LaserScan);
        assert_eq!(Kind::of("sensor_msgs/LaserScan"), Kind::LaserScan);
        assert_eq!(Kind::of("tf2_msgs/msg/TFMessage"), Kind::Tf);
        assert_eq!(Kind::of("std_msgs/msg/String"), Kind::Other);
    }
}
