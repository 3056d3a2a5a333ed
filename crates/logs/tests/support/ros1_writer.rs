//! A test-only writer of ROS bags, format 2.0, written from the format description
//! (<http://wiki.ros.org/Bags/Format/2.0>) independently of the reader: the magic line, a bag
//! header padded to 4096 bytes, chunks (`none`, `bz2`, or `lz4` framed as `roslz4` frames them)
//! each followed by its index data records, then the index section of connection and chunk info
//! records. Also a ROS 1 serialiser for the message types the reader decodes.
#![allow(dead_code, clippy::unwrap_used)]

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;

/// How chunks are compressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compression {
    None,
    Bz2,
    Lz4,
}

impl Compression {
    pub const ALL: [Compression; 3] = [Compression::None, Compression::Bz2, Compression::Lz4];

    fn name(self) -> &'static str {
        match self {
            Compression::None => "none",
            Compression::Bz2 => "bz2",
            Compression::Lz4 => "lz4",
        }
    }
}

/// A written bag and where its parts are.
#[derive(Clone, Debug)]
pub struct Bag {
    pub bytes: Vec<u8>,
    /// Where the index section starts.
    pub index_pos: u64,
    /// Where the bag header's `index_pos` value (8 bytes) is.
    pub index_pos_at: usize,
    /// Where each chunk record starts.
    pub chunk_pos: Vec<u64>,
    /// Where the last chunk record ends (its index data records follow).
    pub last_chunk_end: u64,
}

impl Bag {
    /// The bag with its header's `index_pos` replaced.
    pub fn with_index_pos(&self, pos: u64) -> Vec<u8> {
        let mut b = self.bytes.clone();
        b[self.index_pos_at..self.index_pos_at + 8].copy_from_slice(&pos.to_le_bytes());
        b
    }
}

struct ChunkInfo {
    pos: u64,
    start_ns: u64,
    end_ns: u64,
    counts: BTreeMap<u32, u32>,
}

/// Writes a bag in memory.
pub struct BagWriter {
    compression: Compression,
    chunk_threshold: usize,
    lz4_block_size_id: u8,
    connections_in_chunks: bool,
    conns: Vec<(String, String)>,
    written: BTreeSet<u32>,
    chunk: Vec<u8>,
    chunk_index: BTreeMap<u32, Vec<(u64, u32)>>,
    chunk_times: Option<(u64, u64)>,
    out: Vec<u8>,
    infos: Vec<ChunkInfo>,
    last_chunk_end: u64,
}

fn time_bytes(ns: u64) -> [u8; 8] {
    let mut b = [0u8; 8];
    b[..4].copy_from_slice(&((ns / 1_000_000_000) as u32).to_le_bytes());
    b[4..].copy_from_slice(&((ns % 1_000_000_000) as u32).to_le_bytes());
    b
}

fn fields(list: &[(&str, &[u8])]) -> Vec<u8> {
    let mut h = Vec::new();
    for (name, value) in list {
        h.extend(((name.len() + 1 + value.len()) as u32).to_le_bytes());
        h.extend(name.as_bytes());
        h.push(b'=');
        h.extend(*value);
    }
    h
}

fn record(out: &mut Vec<u8>, header: &[(&str, &[u8])], data: &[u8]) {
    let h = fields(header);
    out.extend((h.len() as u32).to_le_bytes());
    out.extend(h);
    out.extend((data.len() as u32).to_le_bytes());
    out.extend(data);
}

impl BagWriter {
    pub fn new(compression: Compression) -> Self {
        BagWriter {
            compression,
            chunk_threshold: 1024,
            lz4_block_size_id: 4,
            connections_in_chunks: true,
            conns: Vec::new(),
            written: BTreeSet::new(),
            chunk: Vec::new(),
            chunk_index: BTreeMap::new(),
            chunk_times: None,
            out: Vec::new(),
            infos: Vec::new(),
            last_chunk_end: 0,
        }
    }

    /// Chunks are closed once they hold at least this many bytes.
    pub fn chunk_bytes(mut self, n: usize) -> Self {
        self.chunk_threshold = n;
        self
    }

    /// The LZ4 frames' block size: id 4 to 7 for 64 KiB to 4 MiB (rosbag writes 6, 1 MiB; the
    /// tests use 4, as a debug build of the decoder spends its time clearing the block buffer).
    pub fn lz4_block_size_id(mut self, id: u8) -> Self {
        self.lz4_block_size_id = id;
        self
    }

    /// Connection records only in the index section (not in the chunks).
    pub fn connections_only_in_index(mut self) -> Self {
        self.connections_in_chunks = false;
        self
    }

    pub fn connection(&mut self, topic: &str, type_name: &str) -> u32 {
        self.conns.push((topic.to_string(), type_name.to_string()));
        (self.conns.len() - 1) as u32
    }

    fn connection_record(&self, out: &mut Vec<u8>, id: u32) {
        let (topic, type_name) = &self.conns[id as usize];
        let data = fields(&[
            ("topic", topic.as_bytes()),
            ("type", type_name.as_bytes()),
            ("md5sum", b"0123456789abcdef0123456789abcdef"),
            ("message_definition", b"# test\n"),
            ("callerid", b"/recorder_test"),
            ("latching", if topic == "/tf_static" { b"1" } else { b"0" }),
        ]);
        record(out, &[("op", &[0x07]), ("conn", &id.to_le_bytes()), ("topic", topic.as_bytes())], &data);
    }

    /// Writes one message of connection `conn` received at `time_ns`.
    pub fn write(&mut self, conn: u32, time_ns: u64, message: &[u8]) {
        if self.connections_in_chunks && self.written.insert(conn) {
            let mut c = std::mem::take(&mut self.chunk);
            self.connection_record(&mut c, conn);
            self.chunk = c;
        }
        let offset = self.chunk.len() as u32;
        record(
            &mut self.chunk,
            &[("op", &[0x02]), ("conn", &conn.to_le_bytes()), ("time", &time_bytes(time_ns))],
            message,
        );
        self.chunk_index.entry(conn).or_default().push((time_ns, offset));
        let (s, e) = self.chunk_times.unwrap_or((time_ns, time_ns));
        self.chunk_times = Some((s.min(time_ns), e.max(time_ns)));
        if self.chunk.len() >= self.chunk_threshold {
            self.close_chunk();
        }
    }

    fn close_chunk(&mut self) {
        if self.chunk.is_empty() {
            return;
        }
        let data = std::mem::take(&mut self.chunk);
        let compressed = match self.compression {
            Compression::None => data.clone(),
            Compression::Bz2 => {
                let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
                e.write_all(&data).unwrap();
                e.finish().unwrap()
            }
            Compression::Lz4 => roslz4_frame(&data, self.lz4_block_size_id),
        };
        let pos = self.out.len() as u64;
        let header: [(&str, &[u8]); 3] = [
            ("op", &[0x05]),
            ("compression", self.compression.name().as_bytes()),
            ("size", &(data.len() as u32).to_le_bytes()),
        ];
        record(&mut self.out, &header, &compressed);
        self.last_chunk_end = self.out.len() as u64;
        let mut counts = BTreeMap::new();
        for (conn, entries) in std::mem::take(&mut self.chunk_index) {
            let mut d = Vec::new();
            for (t, off) in &entries {
                d.extend(time_bytes(*t));
                d.extend(off.to_le_bytes());
            }
            let n = entries.len() as u32;
            let h: [(&str, &[u8]); 4] = [
                ("op", &[0x04]),
                ("ver", &1u32.to_le_bytes()),
                ("conn", &conn.to_le_bytes()),
                ("count", &n.to_le_bytes()),
            ];
            record(&mut self.out, &h, &d);
            counts.insert(conn, n);
        }
        let (start_ns, end_ns) = self.chunk_times.take().unwrap_or((0, 0));
        self.infos.push(ChunkInfo { pos, start_ns, end_ns, counts });
    }

    pub fn finish(mut self) -> Bag {
        self.close_chunk();
        // The chunk section starts after the magic line and the 4096-byte bag header record.
        let shift = 13 + 4096u64;
        let index_pos = shift + self.out.len() as u64;
        let mut index = Vec::new();
        for id in 0..self.conns.len() as u32 {
            self.connection_record(&mut index, id);
        }
        for info in &self.infos {
            let mut d = Vec::new();
            for (c, n) in &info.counts {
                d.extend(c.to_le_bytes());
                d.extend(n.to_le_bytes());
            }
            let h: [(&str, &[u8]); 6] = [
                ("op", &[0x06]),
                ("ver", &1u32.to_le_bytes()),
                ("chunk_pos", &(info.pos + shift).to_le_bytes()),
                ("start_time", &time_bytes(info.start_ns)),
                ("end_time", &time_bytes(info.end_ns)),
                ("count", &(info.counts.len() as u32).to_le_bytes()),
            ];
            record(&mut index, &h, &d);
        }
        let mut bytes = b"#ROSBAG V2.0\n".to_vec();
        let h = fields(&[
            ("op", &[0x03]),
            ("index_pos", &index_pos.to_le_bytes()),
            ("conn_count", &(self.conns.len() as u32).to_le_bytes()),
            ("chunk_count", &(self.infos.len() as u32).to_le_bytes()),
        ]);
        let padding = vec![b' '; 4096 - 8 - h.len()];
        bytes.extend((h.len() as u32).to_le_bytes());
        bytes.extend(&h);
        bytes.extend((padding.len() as u32).to_le_bytes());
        bytes.extend(&padding);
        assert_eq!(bytes.len() as u64, shift);
        bytes.extend(&self.out);
        bytes.extend(index);
        let index_pos_at = 13 + 4 + 4 + "op=".len() + 1 + 4 + "index_pos=".len();
        assert_eq!(u64::from_le_bytes(bytes[index_pos_at..index_pos_at + 8].try_into().unwrap()), index_pos);
        let chunk_pos = self.infos.iter().map(|i| i.pos + shift).collect();
        Bag { bytes, index_pos, index_pos_at, chunk_pos, last_chunk_end: self.last_chunk_end + shift }
    }
}

/// xxHash32 (seed 0), as the LZ4 frame format's checksums use it.
pub fn xxh32(data: &[u8]) -> u32 {
    const P1: u32 = 2_654_435_761;
    const P2: u32 = 2_246_822_519;
    const P3: u32 = 3_266_489_917;
    const P4: u32 = 668_265_263;
    const P5: u32 = 374_761_393;
    let word = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let round = |acc: u32, x: u32| acc.wrapping_add(x.wrapping_mul(P2)).rotate_left(13).wrapping_mul(P1);
    let mut rest = data;
    let mut h = if data.len() >= 16 {
        let mut v = [P1.wrapping_add(P2), P2, 0, 0u32.wrapping_sub(P1)];
        while rest.len() >= 16 {
            for (i, acc) in v.iter_mut().enumerate() {
                *acc = round(*acc, word(&rest[4 * i..]));
            }
            rest = &rest[16..];
        }
        v[0].rotate_left(1)
            .wrapping_add(v[1].rotate_left(7))
            .wrapping_add(v[2].rotate_left(12))
            .wrapping_add(v[3].rotate_left(18))
    } else {
        P5
    };
    h = h.wrapping_add(data.len() as u32);
    while rest.len() >= 4 {
        h = h.wrapping_add(word(rest).wrapping_mul(P3)).rotate_left(17).wrapping_mul(P4);
        rest = &rest[4..];
    }
    for &b in rest {
        h = h.wrapping_add(u32::from(b).wrapping_mul(P5)).rotate_left(11).wrapping_mul(P1);
    }
    h ^= h >> 15;
    h = h.wrapping_mul(P2);
    h ^= h >> 13;
    h = h.wrapping_mul(P3);
    h ^ (h >> 16)
}

/// An LZ4 frame as `roslz4` writes one: magic `0x184D2204`; FLG = version 01, independent
/// blocks, content checksum; BD = the block size id (4 to 7: 64 KiB × 4^(id − 4)); HC = second
/// byte of xxh32(FLG, BD); blocks of at most the block size, each stored uncompressed (high bit
/// of its size set) when compressing would not shrink it; an end mark; the xxh32 of the
/// content.
pub fn roslz4_frame(data: &[u8], block_size_id: u8) -> Vec<u8> {
    let mut out = 0x184D_2204u32.to_le_bytes().to_vec();
    let descriptor = [0b0110_0100u8, block_size_id << 4];
    out.extend(descriptor);
    out.push((xxh32(&descriptor) >> 8) as u8);
    for block in data.chunks(1 << (16 + 2 * (block_size_id - 4))) {
        let c = lz4_flex::block::compress(block);
        if c.len() < block.len() {
            out.extend((c.len() as u32).to_le_bytes());
            out.extend(c);
        } else {
            out.extend((block.len() as u32 | 0x8000_0000).to_le_bytes());
            out.extend(block);
        }
    }
    out.extend(0u32.to_le_bytes());
    out.extend(xxh32(data).to_le_bytes());
    out
}

/// A ROS 1 serialiser.
#[derive(Default)]
pub struct Ser(pub Vec<u8>);

impl Ser {
    pub fn u32(mut self, v: u32) -> Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn f32(mut self, v: f32) -> Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    pub fn f64s(mut self, v: &[f64]) -> Self {
        for x in v {
            self.0.extend(x.to_le_bytes());
        }
        self
    }
    pub fn string(mut self, s: &str) -> Self {
        self = self.u32(s.len() as u32);
        self.0.extend(s.as_bytes());
        self
    }
    pub fn time(self, ns: u64) -> Self {
        self.u32((ns / 1_000_000_000) as u32).u32((ns % 1_000_000_000) as u32)
    }
    pub fn header(self, seq: u32, stamp_ns: u64, frame: &str) -> Self {
        self.u32(seq).time(stamp_ns).string(frame)
    }
}

/// The quaternion `[x, y, z, w]` of roll, pitch, yaw (radians; `Rz·Ry·Rx`).
pub fn quat(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy]
}

/// A LaserScan: `(angle_min, angle_max, angle_increment)`, `(range_min, range_max)`, ranges.
pub fn laser_scan(
    seq: u32,
    stamp_ns: u64,
    frame: &str,
    angles: (f32, f32, f32),
    limits: (f32, f32),
    ranges: &[f32],
) -> Vec<u8> {
    let mut s = Ser::default().header(seq, stamp_ns, frame).f32(angles.0).f32(angles.1).f32(angles.2);
    s = s.f32(0.0).f32(0.1).f32(limits.0).f32(limits.1).u32(ranges.len() as u32);
    for r in ranges {
        s = s.f32(*r);
    }
    s = s.u32(ranges.len() as u32);
    for _ in ranges {
        s = s.f32(1000.0);
    }
    s.0
}

/// A nav_msgs/Odometry at planar pose `(x, y, yaw)`.
pub fn odometry(seq: u32, stamp_ns: u64, frame: &str, child: &str, pose: (f64, f64, f64)) -> Vec<u8> {
    let q = quat(0.0, 0.0, pose.2);
    let s = Ser::default().header(seq, stamp_ns, frame).string(child).f64s(&[pose.0, pose.1, 0.0]).f64s(&q);
    s.f64s(&[0.01; 36]).f64s(&[0.5, 0.0, 0.0, 0.0, 0.0, 0.1]).f64s(&[0.02; 36]).0
}

/// One transform of a TFMessage: stamp, parent, child, translation, roll-pitch-yaw.
pub type Tf<'a> = (u64, &'a str, &'a str, [f64; 3], [f64; 3]);

/// A tf2_msgs/TFMessage.
pub fn tf_message(transforms: &[Tf<'_>]) -> Vec<u8> {
    let mut s = Ser::default().u32(transforms.len() as u32);
    for (stamp, parent, child, t, rpy) in transforms {
        s = s.header(0, *stamp, parent).string(child).f64s(t).f64s(&quat(rpy[0], rpy[1], rpy[2]));
    }
    s.0
}

/// A geometry_msgs/PoseStamped at `(x, y, yaw)`.
pub fn pose_stamped(stamp_ns: u64, pose: (f64, f64, f64)) -> Vec<u8> {
    Ser::default().header(0, stamp_ns, "map").f64s(&[pose.0, pose.1, 0.0]).f64s(&quat(0.0, 0.0, pose.2)).0
}

/// A geometry_msgs/PoseWithCovarianceStamped at `(x, y, yaw)`.
pub fn pose_with_covariance_stamped(stamp_ns: u64, pose: (f64, f64, f64)) -> Vec<u8> {
    let mut v = pose_stamped(stamp_ns, pose);
    v.extend(Ser::default().f64s(&[0.0; 36]).0);
    v
}
