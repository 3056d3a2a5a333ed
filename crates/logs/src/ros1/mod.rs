//! ROS 1 bags, format 2.0 (`rosbag record`; <http://wiki.ros.org/Bags/Format/2.0>).
//!
//! **The file.** The line `#ROSBAG V2.0\n`, then records, each `header_len: u32`, a header of
//! `name=value` fields (one of them `op`, the record's kind), `data_len: u32` and the data, all
//! little-endian (the `record` module). First comes the bag header (`op` 0x03: `index_pos`,
//! `conn_count`, `chunk_count`, padded to 4096 bytes); then chunks (0x05: `compression` `none`,
//! `bz2` or `lz4`, `size` uncompressed), each followed by one index data record (0x04) per
//! connection in it; then, from `index_pos`, the index section: a connection record (0x07) per
//! connection and a chunk info record (0x06) per chunk. Inside a chunk are connection records
//! (`conn` id and `topic` in the header; the data a run of fields `topic`, `type`, `md5sum`,
//! `message_definition`, `callerid`, `latching`) and message data records (0x02: `conn`, `time`
//! = the recorder's receive time, `secs: u32` then `nsecs: u32`; the data the message, ROS 1
//! serialised, the `msg` module). `lz4` chunks are LZ4 frames as `roslz4` writes them; `bz2`
//! chunks one bzip2 stream.
//!
//! **Reading.** The index is never needed: the reader walks the records in file order,
//! decompressing each chunk and decoding its messages as it goes (so a bag whose index is
//! missing or damaged reads the same). Connection records are collected from the chunks and
//! from the index section (read first when `index_pos` points at one, so a bag whose
//! connections are only there reads in one pass; a message met before its connection is kept
//! and decoded after the walk). Message types are known by the connection's `type` (the
//! `md5sum` is not checked):
//!
//! - `sensor_msgs/LaserScan` on any topic: a scan. `range_max` is inclusive in ROS and the
//!   sensor log's is exclusive, so the scan's limit is the next `f32` above it; the angles are
//!   `angle_min` and `angle_increment` (a ranges count that disagrees with `angle_max` by more
//!   than one beam is noted once per topic).
//! - `nav_msgs/Odometry` on any topic: odometry (`pose.pose`, projected on the plane).
//! - `tf2_msgs/TFMessage` or `tf/tfMessage` on `/tf` and `/tf_static`: transforms, each with its
//!   own header stamp.
//! - On [`ImportOptions::truth_topic`]: `geometry_msgs/PoseStamped`,
//!   `geometry_msgs/PoseWithCovarianceStamped` or `nav_msgs/Odometry`, as reference poses (that
//!   topic is then not an odometry topic).
//! - Anything else is counted and skipped.
//!
//! **Frames.** ROS 1 frame ids are often written with a leading `/` (`/base_link`); one leading
//! `/` is stripped from every frame id (scans, transform parents and children), so `/base_link`
//! and `base_link` are the same frame.
//!
//! **Stamps.** [`StampFrom::Header`]: each message's `header.stamp`; [`StampFrom::Record`]: the
//! message data record's `time`.
//!
//! **Damage.** Every length is checked against the bytes left before anything is allocated. A
//! record cut short, a field missing, a chunk that does not decompress to its `size`, a message
//! shorter or longer than its type are refused with the byte offset, the chunk and the message
//! named. A file that ends cleanly before the chunks its bag header counts is refused as
//! truncated. Only damage in the index section, after every chunk was read (at or past a valid
//! `index_pos`, or once the header's `chunk_count` chunks are in), is read past with a note; so
//! is an `index_pos` that is 0, past the end or not at an index record. With
//! [`ImportOptions::salvage`] the rest is read past too, each with a `salvaged:` note: a record
//! that cannot be read is skipped to the next record that reads as a chunk
//! (`BagFile::next_chunk`), a chunk that does not decompress or decode keeps the messages
//! before the damage, and a truncated file is read as far as it goes.

mod msg;
mod record;

use crate::assemble::{Assembler, RawOdometry, RawPose, RawScan, RawTransform};
use crate::options::{ImportOptions, StampFrom};
use crate::report::ImportReport;
use crate::{ImportError, Rigid3};
use mapkeeper_grid::Pose2;
use mapkeeper_sensor::SensorLog;
use msg::{Header, Placement};
use record::{BagFile, Fields, Op, TopRecord};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The first line of a bag of format 2.0.
pub const MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// Reads a ROS 1 bag (format 2.0) into a sensor log.
pub fn read(path: &Path, options: &ImportOptions) -> Result<(SensorLog, ImportReport), ImportError> {
    let mut file = BagFile::open(path).map_err(|e| ImportError::io(path, e))?;
    let header = bag_header(&mut file, path)?;
    let mut walk = Walk::new(path, options, header);
    walk.preread_index(&mut file);
    file.seek(header.end).map_err(|m| ImportError::parse(path, format!("byte {}", header.end), m))?;
    walk.records(&mut file)?;
    walk.finish()
}

/// The bag header record's fields.
#[derive(Clone, Copy, Debug)]
struct BagHeader {
    /// Where the index section starts (0: not written).
    index_pos: u64,
    /// Connections, as the recorder counted them.
    conn_count: u32,
    /// Chunks, as the recorder counted them (0: not written).
    chunk_count: u32,
    /// Where the first record after the bag header starts.
    end: u64,
}

fn bag_header(file: &mut BagFile, path: &Path) -> Result<BagHeader, ImportError> {
    let head =
        file.bytes(MAGIC.len() as u64, "the '#ROSBAG V2.0' line").map_err(|m| ImportError::parse(path, "byte 0", m))?;
    if head != MAGIC {
        let message = if head.starts_with(b"#ROSBAG V") {
            let line = String::from_utf8_lossy(&head);
            format!("'{}': only ROS bag format 2.0 is read", line.trim_end())
        } else {
            "not a ROS bag: the file does not start with '#ROSBAG V2.0'".to_string()
        };
        return Err(ImportError::parse(path, "byte 0", message));
    }
    let at = file.pos;
    let place = format!("byte {at} (bag header)");
    let rec = file.next().map_err(|m| ImportError::parse(path, &place, m))?;
    if rec.op != Some(Op::BagHeader) {
        return Err(ImportError::parse(
            path,
            &place,
            format!("the first record has op 0x{:02x}, not a bag header (0x03)", rec.op_byte),
        ));
    }
    let field = |m: String| ImportError::parse(path, &place, format!("bag header: {m}"));
    Ok(BagHeader {
        index_pos: rec.fields.u64("index_pos").map_err(field)?,
        conn_count: rec.fields.u32("conn_count").map_err(field)?,
        chunk_count: rec.fields.u32("chunk_count").map_err(field)?,
        end: file.pos,
    })
}

/// What a connection's messages are to the reader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Scan,
    Odometry,
    Tf { is_static: bool },
    Truth(TruthType),
    Unused,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum TruthType {
    Odometry,
    PoseStamped,
    PoseWithCovariance,
}

const LASER_SCAN: &str = "sensor_msgs/LaserScan";
const ODOMETRY: &str = "nav_msgs/Odometry";
const POSE_STAMPED: &str = "geometry_msgs/PoseStamped";
const POSE_WITH_COVARIANCE: &str = "geometry_msgs/PoseWithCovarianceStamped";

fn kind_of(topic: &str, type_name: &str, options: &ImportOptions) -> Kind {
    if options.truth_topic.as_deref() == Some(topic) {
        match type_name {
            ODOMETRY => return Kind::Truth(TruthType::Odometry),
            POSE_STAMPED => return Kind::Truth(TruthType::PoseStamped),
            POSE_WITH_COVARIANCE => return Kind::Truth(TruthType::PoseWithCovariance),
            _ => {}
        }
    }
    match (type_name, topic) {
        (LASER_SCAN, _) => Kind::Scan,
        (ODOMETRY, _) => Kind::Odometry,
        ("tf2_msgs/TFMessage" | "tf/tfMessage", "/tf") => Kind::Tf { is_static: false },
        ("tf2_msgs/TFMessage" | "tf/tfMessage", "/tf_static") => Kind::Tf { is_static: true },
        _ => Kind::Unused,
    }
}

/// One connection: a topic of one type from one publisher.
#[derive(Clone, Debug)]
struct Connection {
    topic: String,
    type_name: String,
    kind: Kind,
}

/// Where a record is: its byte offset in the file and, inside a chunk, the chunk's number
/// (from 1) and the record's byte in the chunk's uncompressed data.
#[derive(Clone, Copy, Debug)]
struct Where {
    offset: u64,
    chunk: Option<(usize, usize)>,
}

impl Where {
    fn place(&self) -> String {
        match self.chunk {
            Some((c, pos)) => format!("byte {} (chunk {c}, byte {pos} of its uncompressed data)", self.offset),
            None => format!("byte {}", self.offset),
        }
    }

    fn short(&self) -> String {
        match self.chunk {
            Some((c, _)) => format!("chunk {c} at byte {}", self.offset),
            None => format!("byte {}", self.offset),
        }
    }
}

/// A message met before its connection record.
#[derive(Debug)]
struct Pending {
    conn: u32,
    record_ns: u64,
    data: Vec<u8>,
    at: Where,
}

/// The reader's state while walking the file.
struct Walk<'a> {
    path: &'a Path,
    options: &'a ImportOptions,
    header: BagHeader,
    asm: Assembler,
    conns: BTreeMap<u32, Connection>,
    /// Where the index section starts, if `index_pos` points at one.
    index_at: Option<u64>,
    /// Whether the walk met a record starting at `index_at` (so it is not inside a chunk).
    reached_index: bool,
    /// Records met, the bag header the first.
    records: usize,
    chunks: usize,
    chunk_infos: usize,
    message_records: u64,
    index_entries: u64,
    per_topic: BTreeMap<String, usize>,
    pending: Vec<Pending>,
    unused: BTreeMap<String, (String, usize)>,
    beam_notes: BTreeSet<String>,
    truth_poses: usize,
}

impl<'a> Walk<'a> {
    fn new(path: &'a Path, options: &'a ImportOptions, header: BagHeader) -> Self {
        Walk {
            path,
            options,
            header,
            asm: Assembler::new(path, "bag"),
            conns: BTreeMap::new(),
            index_at: None,
            reached_index: false,
            records: 1,
            chunks: 0,
            chunk_infos: 0,
            message_records: 0,
            index_entries: 0,
            per_topic: BTreeMap::new(),
            pending: Vec::new(),
            unused: BTreeMap::new(),
            beam_notes: BTreeSet::new(),
            truth_poses: 0,
        }
    }

    fn err(&self, place: impl Into<String>, message: impl Into<String>) -> ImportError {
        ImportError::parse(self.path, place, message)
    }

    /// Reads the connections of the index section if `index_pos` points at one; notes why not
    /// otherwise. Damage further into the index is left for the walk to meet and note.
    fn preread_index(&mut self, file: &mut BagFile) {
        let p = self.header.index_pos;
        let why = if p == 0 {
            Some("is 0 (the recording was not closed, or the index was removed)".to_string())
        } else if p > file.len {
            Some(format!("is past the end of the file ({} bytes): the index is missing", file.len))
        } else if p < self.header.end {
            Some(format!("points into the bag header (which ends at byte {})", self.header.end))
        } else if p == file.len {
            (self.header.conn_count > 0 || self.header.chunk_count > 0)
                .then(|| "is the end of the file: the index is missing".to_string())
        } else {
            self.index_connections(file, p).err()
        };
        match why {
            Some(why) => {
                self.asm.note(format!("the bag header's index_pos {p} {why}; the bag is read by walking its chunks"))
            }
            None => self.index_at = Some(p),
        }
    }

    /// The connection records from byte `p` on; an error if the first record there is not an
    /// index record.
    fn index_connections(&mut self, file: &mut BagFile, p: u64) -> Result<(), String> {
        file.seek(p)?;
        let first = file.next().map_err(|m| format!("does not point at an index record ({m})"))?;
        if !matches!(first.op, Some(Op::Connection | Op::ChunkInfo)) {
            let what = first.op.map_or(format!("op 0x{:02x}", first.op_byte), |o| format!("a {} record", o.name()));
            return Err(format!("does not point at an index record (it points at {what})"));
        }
        let mut rec = Ok(first);
        while let Ok(r) = rec {
            if r.op == Some(Op::Connection) {
                match connection(&r.fields, &r.data, self.options) {
                    Ok((id, c)) => _ = self.conns.entry(id).or_insert(c),
                    Err(_) => break,
                }
            }
            if file.pos >= file.len {
                break;
            }
            rec = file.next();
        }
        Ok(())
    }

    /// Walks every record after the bag header.
    fn records(&mut self, file: &mut BagFile) -> Result<(), ImportError> {
        while file.pos < file.len {
            let offset = file.pos;
            self.records += 1;
            self.reached_index |= self.index_at == Some(offset);
            let rec = match file.next() {
                Ok(r) => r,
                Err(m) if self.options.salvage && !self.after_chunks() => {
                    if self.resync(file, offset, &m)? {
                        continue;
                    }
                    break;
                }
                Err(m) => return self.damaged_tail(offset, m),
            };
            let at = Where { offset, chunk: None };
            match rec.op {
                Some(Op::Chunk) => {
                    let offset_after = file.pos;
                    match self.chunk(rec) {
                        Ok(()) => {}
                        Err(e) if self.options.salvage => {
                            self.asm.note(format!(
                                "salvaged: chunk {} is damaged ({e}); its records before the damage were kept, the \
rest skipped, reading on at byte {offset_after}",
                                self.chunks
                            ));
                        }
                        Err(e) => return Err(e),
                    }
                }
                Some(Op::Connection) => match connection(&rec.fields, &rec.data, self.options) {
                    Ok((id, c)) => _ = self.conns.entry(id).or_insert(c),
                    // In the index section: noted (the chunks may describe the connection too).
                    Err(m) if self.after_chunks() => {
                        self.asm.note(format!("a connection record of the index at byte {offset} skipped: {m}"));
                    }
                    Err(m) => return Err(self.err(at.place(), m)),
                },
                Some(Op::MessageData) => self.message_record(&rec.fields, &rec.data, at)?,
                // The index is not needed to read the bag: an unreadable count is only noted.
                Some(Op::IndexData) => match rec.fields.u32("count") {
                    Ok(count) => self.index_entries += u64::from(count),
                    Err(m) => {
                        self.asm.note(format!("an index data record at byte {offset} has an unreadable count: {m}"))
                    }
                },
                Some(Op::ChunkInfo) => self.chunk_infos += 1,
                Some(Op::BagHeader) => return Err(self.err(at.place(), "a second bag header record")),
                None => self.asm.note(format!("a record of unknown op 0x{:02x} at byte {offset} skipped", rec.op_byte)),
            }
        }
        self.check_end(file.len)
    }

    /// With `--salvage`: a record at `offset` that cannot be read (`m`) before the index section.
    /// Moves the file to the next record that reads as a chunk and says what was skipped; false
    /// (and a note) if there is none.
    fn resync(&mut self, file: &mut BagFile, offset: u64, m: &str) -> Result<bool, ImportError> {
        let next = file.next_chunk(offset + 1).map_err(|e| self.err(format!("byte {offset}"), e))?;
        match next {
            Some(at) => {
                self.asm.note(format!(
                    "salvaged: the record at byte {offset} (after chunk {}) is damaged ({m}); bytes {offset}-{} skipped, \
reading on at the next chunk, byte {at}",
                    self.chunks,
                    at - 1
                ));
                file.seek(at).map_err(|e| self.err(format!("byte {at}"), e))?;
                Ok(true)
            }
            None => {
                self.asm.note(format!(
                    "salvaged: the record at byte {offset} (after chunk {}) is damaged ({m}) and no chunk follows; bytes \
{offset}-{} skipped",
                    self.chunks,
                    file.len.saturating_sub(1)
                ));
                file.seek(file.len).map_err(|e| self.err(format!("byte {}", file.len), e))?;
                Ok(false)
            }
        }
    }

    /// Whether the walk is in the index section, after every chunk: it met a record at a valid
    /// `index_pos`, or it has read the chunks the bag header counts.
    fn after_chunks(&self) -> bool {
        self.reached_index || (self.header.chunk_count > 0 && self.chunks >= self.header.chunk_count as usize)
    }

    /// A record at `offset` that cannot be read: read past with a note if it is in the index
    /// section after every chunk, refused otherwise.
    fn damaged_tail(&mut self, offset: u64, message: String) -> Result<(), ImportError> {
        if self.after_chunks() {
            self.asm.note(format!(
                "the index section is cut short or damaged at byte {offset} ({message}); the {} chunks before it were read",
                self.chunks
            ));
            return Ok(());
        }
        Err(self.err(format!("byte {offset} (record {}, after chunk {})", self.records, self.chunks), message))
    }

    /// At the end of the file: refuses a bag with fewer chunks than its header counts; notes
    /// counts that disagree.
    fn check_end(&mut self, len: u64) -> Result<(), ImportError> {
        let (expected, read) = (self.header.chunk_count as usize, self.chunks);
        if expected > read && self.options.salvage {
            self.asm.note(format!(
                "salvaged: the file ends after {read} chunks, but its bag header counts {expected}: the bag is truncated"
            ));
        } else if expected > read {
            return Err(self.err(
                format!("byte {len} (end of file)"),
                format!(
                    "the file ends after {read} chunks, but its bag header counts {expected}: the bag is truncated"
                ),
            ));
        }
        if expected != read {
            self.asm.note(format!("the bag header counts {expected} chunks, the file holds {read}"));
        }
        if self.index_at.is_some() && self.chunk_infos != read {
            self.asm.note(format!("the index describes {} chunks, the file holds {read}", self.chunk_infos));
        }
        if self.index_entries != self.message_records && (self.index_entries > 0 || self.index_at.is_some()) {
            self.asm.note(format!(
                "the index data records list {} messages, the chunks hold {}",
                self.index_entries, self.message_records
            ));
        }
        Ok(())
    }

    /// Decompresses a chunk and reads its records.
    fn chunk(&mut self, rec: TopRecord) -> Result<(), ImportError> {
        self.chunks += 1;
        let c = self.chunks;
        let place = format!("byte {} (chunk {c})", rec.offset);
        let compression = rec.fields.string("compression").map_err(|m| self.err(&place, format!("chunk: {m}")))?;
        let size = rec.fields.u32("size").map_err(|m| self.err(&place, format!("chunk: {m}")))?;
        let data = record::decompress(&compression, &rec.data, size).map_err(|m| self.err(&place, m))?;
        let mut pos = 0;
        while pos < data.len() {
            let at = Where { offset: rec.offset, chunk: Some((c, pos)) };
            let (fields, body, next) = record::record_in(&data, pos).map_err(|m| self.err(at.place(), m))?;
            match fields.op().map_err(|m| self.err(at.place(), m))? {
                (_, Some(Op::Connection)) => self.add_connection(&fields, body, &at)?,
                (_, Some(Op::MessageData)) => self.message_record(&fields, body, at)?,
                (_, Some(op)) => return Err(self.err(at.place(), format!("a {} record inside a chunk", op.name()))),
                (b, None) => {
                    return Err(self.err(at.place(), format!("a record of unknown op 0x{b:02x} inside a chunk")));
                }
            }
            pos = next;
        }
        Ok(())
    }

    fn add_connection(&mut self, fields: &Fields, data: &[u8], at: &Where) -> Result<(), ImportError> {
        let (id, c) = connection(fields, data, self.options).map_err(|m| self.err(at.place(), m))?;
        self.conns.entry(id).or_insert(c);
        Ok(())
    }

    fn message_record(&mut self, fields: &Fields, data: &[u8], at: Where) -> Result<(), ImportError> {
        let field = |m: String| self.err(at.place(), format!("message data: {m}"));
        let conn = fields.u32("conn").map_err(field)?;
        let record_ns = fields.time_ns("time").map_err(field)?;
        self.message_records += 1;
        if self.conns.contains_key(&conn) {
            self.message(conn, record_ns, data, at)
        } else {
            self.pending.push(Pending { conn, record_ns, data: data.to_vec(), at });
            Ok(())
        }
    }
}

/// A connection record's id and connection.
fn connection(fields: &Fields, data: &[u8], options: &ImportOptions) -> Result<(u32, Connection), String> {
    let id = fields.u32("conn").map_err(|m| format!("connection: {m}"))?;
    let topic = fields.string("topic").map_err(|m| format!("connection {id}: {m}"))?;
    let inner = Fields::parse(data).map_err(|m| format!("connection {id} ({topic}): {m}"))?;
    let type_name = inner.string("type").map_err(|m| format!("connection {id} ({topic}): {m}"))?;
    let kind = kind_of(&topic, &type_name, options);
    Ok((id, Connection { topic, type_name, kind }))
}

impl Walk<'_> {
    /// Decodes one message of connection `conn` (known) and hands it to the assembler.
    fn message(&mut self, conn: u32, record_ns: u64, data: &[u8], at: Where) -> Result<(), ImportError> {
        let Some(c) = self.conns.get(&conn).cloned() else { return Ok(()) };
        self.asm.count_message(&c.topic, &c.type_name);
        let k = {
            let k = self.per_topic.entry(c.topic.clone()).or_default();
            *k += 1;
            *k
        };
        let place = format!("message {k} on {} ({})", c.topic, at.short());
        let path = self.path;
        let fail = |m: String| ImportError::parse(path, &place, m);
        let by_record = self.options.stamp == StampFrom::Record;
        let stamp = |h: &Header| if by_record { record_ns } else { h.stamp_ns };
        match c.kind {
            Kind::Scan => {
                let s = msg::laser_scan(data).map_err(fail)?;
                let t = stamp(&s.header);
                self.scan(s, (t, record_ns), &c.topic, format!("message {k} ({})", at.short()));
            }
            Kind::Odometry => {
                let o = msg::odometry(data).map_err(fail)?;
                let pose = planar(&o.pose).map_err(fail)?;
                self.asm.odometry(RawOdometry {
                    topic: c.topic.clone(),
                    stamp_ns: stamp(&o.header),
                    pose,
                    record_ns: Some(record_ns),
                });
            }
            Kind::Truth(t) => {
                let p = match t {
                    TruthType::Odometry => msg::odometry(data),
                    TruthType::PoseStamped => msg::pose_stamped(data),
                    TruthType::PoseWithCovariance => msg::pose_with_covariance_stamped(data),
                }
                .map_err(fail)?;
                let pose = planar(&p.pose).map_err(fail)?;
                self.truth_poses += 1;
                self.asm.truth(
                    RawPose { stamp_ns: stamp(&p.header), pose, record_ns: Some(record_ns) },
                    &format!("{} ({})", c.topic, c.type_name),
                );
            }
            Kind::Tf { is_static } => {
                for (i, t) in msg::tf_message(data).map_err(fail)?.into_iter().enumerate() {
                    let transform = Rigid3::from_translation_quaternion(t.transform.position, t.transform.orientation)
                        .ok_or_else(|| fail(format!("transform {}: {BAD_QUATERNION}", i + 1)))?;
                    let (parent, child) = (msg::frame(&t.header.frame_id), msg::frame(&t.child_frame_id));
                    self.asm.transform(RawTransform {
                        stamp_ns: stamp(&t.header),
                        parent,
                        child,
                        transform,
                        is_static,
                        record_ns: Some(record_ns),
                    });
                }
            }
            Kind::Unused => self.unused.entry(c.topic.clone()).or_insert_with(|| (c.type_name.clone(), 0)).1 += 1,
        }
        Ok(())
    }

    /// Hands a scan to the assembler; notes (once per topic) a ranges count that disagrees with
    /// `angle_max`.
    fn scan(&mut self, s: msg::Scan, (stamp_ns, record_ns): (u64, u64), topic: &str, place: String) {
        let (min, max, inc) = (f64::from(s.angle_min), f64::from(s.angle_max), f64::from(s.angle_increment));
        let expected = (max - min) / inc + 1.0;
        let n = s.ranges.len();
        if inc != 0.0
            && expected.is_finite()
            && (n as f64 - expected).abs() > 1.0
            && self.beam_notes.insert(topic.into())
        {
            self.asm.note(format!(
                "{topic}: {n} ranges, but (angle_max - angle_min) / angle_increment + 1 = {expected:.2} ({place}); \
the beams' angles are taken from angle_min and angle_increment"
            ));
        }
        self.asm.scan(RawScan {
            topic: topic.to_string(),
            frame_id: msg::frame(&s.header.frame_id),
            stamp_ns,
            angle_min_rad: min,
            angle_increment_rad: inc,
            range_min_m: s.range_min,
            range_max_m: s.range_max.next_up(),
            ranges_m: s.ranges,
            time_increment_s: f64::from(s.time_increment),
            place,
            record_ns: Some(record_ns),
        });
    }

    /// Decodes the messages met before their connection, adds the notes and builds the log.
    fn finish(mut self) -> Result<(SensorLog, ImportReport), ImportError> {
        let pending = std::mem::take(&mut self.pending);
        let (mut late, mut orphans) = (0usize, BTreeMap::<u32, usize>::new());
        for p in pending {
            if self.conns.contains_key(&p.conn) {
                late += 1;
                self.message(p.conn, p.record_ns, &p.data, p.at)?;
            } else {
                *orphans.entry(p.conn).or_default() += 1;
            }
        }
        if late > 0 {
            self.asm
                .note(format!("{late} messages came before their connection record; they were decoded after the walk"));
        }
        if !orphans.is_empty() {
            let list: Vec<String> = orphans.iter().map(|(c, n)| format!("{n} of connection {c}")).collect();
            self.asm.note(format!("messages with no connection record skipped: {}", list.join(", ")));
        }
        if let Some(t) = &self.options.truth_topic
            && self.truth_poses == 0
        {
            let topics: Vec<String> = self.per_topic.keys().cloned().collect();
            return Err(ImportError::unusable(
                self.path,
                format!(
                    "truth topic '{t}' has no {POSE_STAMPED}, {POSE_WITH_COVARIANCE} or {ODOMETRY} messages; \
the bag's topics: [{}]",
                    topics.join(", ")
                ),
            ));
        }
        if !self.unused.is_empty() {
            let list: Vec<String> = self.unused.iter().map(|(t, (ty, n))| format!("{t} ({ty}, {n})")).collect();
            self.asm.note(format!("topics not used: {}", list.join(", ")));
        }
        let c = self.header.conn_count as usize;
        if c > 0 && c != self.conns.len() {
            self.asm.note(format!("the bag header counts {c} connections, the bag describes {}", self.conns.len()));
        }
        self.asm.finish(self.options)
    }
}

const BAD_QUATERNION: &str = "the rotation quaternion is zero or not finite";

/// A pose projected on the plane.
fn planar(p: &Placement) -> Result<Pose2, String> {
    let r = Rigid3::from_translation_quaternion(p.position, p.orientation).ok_or(BAD_QUATERNION)?;
    Ok(r.planar().0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_kinds_follow_type_and_topic() {
        let o = ImportOptions { truth_topic: Some("/gt".into()), ..ImportOptions::default() };
        assert_eq!(kind_of("/front", LASER_SCAN, &o), Kind::Scan);
        assert_eq!(kind_of("/wheel", ODOMETRY, &o), Kind::Odometry);
        assert_eq!(kind_of("/gt", ODOMETRY, &o), Kind::Truth(TruthType::Odometry), "the truth topic is not odometry");
        assert_eq!(kind_of("/gt", POSE_STAMPED, &o), Kind::Truth(TruthType::PoseStamped));
        assert_eq!(kind_of("/gt", POSE_WITH_COVARIANCE, &o), Kind::Truth(TruthType::PoseWithCovariance));
        assert_eq!(kind_of("/pose", POSE_STAMPED, &o), Kind::Unused);
        assert_eq!(kind_of("/tf", "tf2_msgs/TFMessage", &o), Kind::Tf { is_static: false });
        assert_eq!(kind_of("/tf_static", "tf2_msgs/TFMessage", &o), Kind::Tf { is_static: true });
        assert_eq!(kind_of("/tf", "tf/tfMessage", &o), Kind::Tf { is_static: false });
        assert_eq!(kind_of("/robot/tf", "tf2_msgs/TFMessage", &o), Kind::Unused);
        assert_eq!(kind_of("/camera", "sensor_msgs/Image", &o), Kind::Unused);
    }

    #[test]
    fn places_name_the_byte_and_the_chunk() {
        let at = Where { offset: 4109, chunk: Some((3, 120)) };
        assert_eq!(at.place(), "byte 4109 (chunk 3, byte 120 of its uncompressed data)");
        assert_eq!(at.short(), "chunk 3 at byte 4109");
        assert_eq!(Where { offset: 9, chunk: None }.place(), "byte 9");
        let p = Placement { position: [1.0, 2.0, 3.0], orientation: [0.0, 0.0, 0.0, 2.0] };
        assert_eq!(planar(&p).unwrap(), Pose2::new(1.0, 2.0, 0.0), "the quaternion is normalised");
        let zero = Placement { orientation: [0.0; 4], ..p };
        assert_eq!(planar(&zero).unwrap_err(), BAD_QUATERNION);
    }
}
