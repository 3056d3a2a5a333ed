//! The record layer of a ROS bag 2.0: record framing, header fields, the file read front to
//! back, and chunk decompression.
//!
//! A record is `header_len: u32`, `header` (`header_len` bytes), `data_len: u32`, `data`
//! (`data_len` bytes), little-endian. The header is a run of fields, each `field_len: u32` then
//! `name=value` (`field_len` bytes, the name up to the first `=`, the value binary). Every header
//! has `op`, one byte: the record's kind ([`Op`]).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// The record kinds (`op` values) of format 2.0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    /// 0x02: one message (`conn`, `time`; data = the serialised message).
    MessageData,
    /// 0x03: the bag header (`index_pos`, `conn_count`, `chunk_count`; data = padding).
    BagHeader,
    /// 0x04: the index of one connection in the chunk before it (`ver`, `conn`, `count`).
    IndexData,
    /// 0x05: a chunk of records (`compression`, `size`; data = the records, compressed).
    Chunk,
    /// 0x06: where a chunk is and what it holds (`ver`, `chunk_pos`, `start_time`, `end_time`,
    /// `count`).
    ChunkInfo,
    /// 0x07: a connection (`conn`, `topic`; data = a header-like run of fields: `topic`,
    /// `type`, `md5sum`, `message_definition`, optionally `callerid`, `latching`).
    Connection,
}

impl Op {
    fn from_byte(b: u8) -> Option<Op> {
        Some(match b {
            0x02 => Op::MessageData,
            0x03 => Op::BagHeader,
            0x04 => Op::IndexData,
            0x05 => Op::Chunk,
            0x06 => Op::ChunkInfo,
            0x07 => Op::Connection,
            _ => return None,
        })
    }

    /// Its name in errors and notes.
    pub fn name(self) -> &'static str {
        match self {
            Op::MessageData => "message data",
            Op::BagHeader => "bag header",
            Op::IndexData => "index data",
            Op::Chunk => "chunk",
            Op::ChunkInfo => "chunk info",
            Op::Connection => "connection",
        }
    }
}

/// The `name=value` fields of a record header (or of a connection record's data).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fields(BTreeMap<String, Vec<u8>>);

impl Fields {
    /// Parses a run of fields; a field whose length runs past the end, or without `=`, is an
    /// error. A name given twice keeps its last value.
    pub fn parse(bytes: &[u8]) -> Result<Fields, String> {
        let mut map = BTreeMap::new();
        let mut pos = 0usize;
        while pos < bytes.len() {
            let left = bytes.len() - pos;
            if left < 4 {
                return Err(format!("header field length at byte {pos} of the header cut short ({left} bytes left)"));
            }
            let n = u32::from_le_bytes([bytes[pos], bytes[pos + 1], bytes[pos + 2], bytes[pos + 3]]) as usize;
            pos += 4;
            if n > bytes.len() - pos {
                return Err(format!(
                    "header field of {n} bytes at byte {} runs past the end of the header ({} bytes)",
                    pos - 4,
                    bytes.len()
                ));
            }
            let field = &bytes[pos..pos + n];
            let eq = field
                .iter()
                .position(|&b| b == b'=')
                .ok_or_else(|| format!("header field at byte {} has no '=' (not a name=value field)", pos - 4))?;
            map.insert(String::from_utf8_lossy(&field[..eq]).into_owned(), field[eq + 1..].to_vec());
            pos += n;
        }
        Ok(Fields(map))
    }

    /// The raw value of a field.
    pub fn get(&self, name: &str) -> Option<&[u8]> {
        self.0.get(name).map(Vec::as_slice)
    }

    fn fixed<const N: usize>(&self, name: &str) -> Result<[u8; N], String> {
        let v = self.get(name).ok_or_else(|| format!("no '{name}' field"))?;
        v.try_into().map_err(|_| format!("field '{name}' has {} bytes, not {N}", v.len()))
    }

    /// The record kind: the raw byte and the [`Op`] it names, if known.
    pub fn op(&self) -> Result<(u8, Option<Op>), String> {
        let [b] = self.fixed::<1>("op")?;
        Ok((b, Op::from_byte(b)))
    }

    /// A `u32` field.
    pub fn u32(&self, name: &str) -> Result<u32, String> {
        self.fixed(name).map(u32::from_le_bytes)
    }

    /// A `u64` field.
    pub fn u64(&self, name: &str) -> Result<u64, String> {
        self.fixed(name).map(u64::from_le_bytes)
    }

    /// A time field (`secs: u32`, `nsecs: u32`), nanoseconds.
    pub fn time_ns(&self, name: &str) -> Result<u64, String> {
        let b = self.fixed::<8>(name)?;
        let secs = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let nsecs = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
        Ok(u64::from(secs) * 1_000_000_000 + u64::from(nsecs))
    }

    /// A text field.
    pub fn string(&self, name: &str) -> Result<String, String> {
        let v = self.get(name).ok_or_else(|| format!("no '{name}' field"))?;
        String::from_utf8(v.to_vec()).map_err(|_| format!("field '{name}' is not UTF-8 text"))
    }
}

/// One record of a buffer (a chunk's uncompressed data): its fields, data, and where the next
/// record starts.
pub fn record_in(buf: &[u8], pos: usize) -> Result<(Fields, &[u8], usize), String> {
    let len_at = |at: usize, what: &str| -> Result<usize, String> {
        let b = buf
            .get(at..at + 4)
            .ok_or_else(|| format!("{what} length cut short: {} bytes left", buf.len().saturating_sub(at)))?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let header_len = len_at(pos, "record header")?;
    let header = buf.get(pos + 4..).and_then(|rest| rest.get(..header_len)).ok_or_else(|| {
        format!("record header of {header_len} bytes runs past the end ({} bytes left)", buf.len() - pos - 4)
    })?;
    let fields = Fields::parse(header)?;
    let data_at = pos + 4 + header_len;
    let data_len = len_at(data_at, "record data")?;
    let data = buf.get(data_at + 4..).and_then(|rest| rest.get(..data_len)).ok_or_else(|| {
        format!("record data of {data_len} bytes runs past the end ({} bytes left)", buf.len() - data_at - 4)
    })?;
    Ok((fields, data, data_at + 4 + data_len))
}

/// A record of the file read by [`BagFile::next`]: its offset, fields, kind and data (empty if
/// skipped).
#[derive(Debug)]
pub struct TopRecord {
    /// Byte offset of the record in the file.
    pub offset: u64,
    /// Header fields.
    pub fields: Fields,
    /// The raw `op` byte.
    pub op_byte: u8,
    /// The kind, if known.
    pub op: Option<Op>,
    /// The data (empty for the records whose data is skipped: index data).
    pub data: Vec<u8>,
}

/// The bag file, read front to back with every length checked against the bytes left.
#[derive(Debug)]
pub struct BagFile {
    reader: BufReader<File>,
    /// Current byte offset.
    pub pos: u64,
    /// File length, bytes.
    pub len: u64,
}

impl BagFile {
    /// Opens the file.
    pub fn open(path: &Path) -> std::io::Result<BagFile> {
        let file = File::open(path)?;
        let len = file.metadata()?.len();
        Ok(BagFile { reader: BufReader::with_capacity(1 << 16, file), pos: 0, len })
    }

    /// Moves to byte `pos` (at most the file's length).
    pub fn seek(&mut self, pos: u64) -> Result<(), String> {
        let pos = pos.min(self.len);
        self.reader.seek(SeekFrom::Start(pos)).map_err(|e| format!("cannot seek: {e}"))?;
        self.pos = pos;
        Ok(())
    }

    /// Reads `n` bytes; an error if fewer are left.
    pub fn bytes(&mut self, n: u64, what: &str) -> Result<Vec<u8>, String> {
        let left = self.len - self.pos;
        if n > left {
            return Err(format!("{what} of {n} bytes runs past the end of the file ({left} bytes left)"));
        }
        let mut v = vec![0u8; n as usize];
        self.reader.read_exact(&mut v).map_err(|e| format!("cannot read {what}: {e}"))?;
        self.pos += n;
        Ok(v)
    }

    fn skip(&mut self, n: u64, what: &str) -> Result<(), String> {
        let left = self.len - self.pos;
        if n > left {
            return Err(format!("{what} of {n} bytes runs past the end of the file ({left} bytes left)"));
        }
        self.reader.seek_relative(n as i64).map_err(|e| format!("cannot skip {what}: {e}"))?;
        self.pos += n;
        Ok(())
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        let b = self.bytes(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// The offset of the first record at or after `from` that reads as a chunk record (its header
    /// parses, `op` 0x05 with a `compression` and a `size`, and its data ends within the file),
    /// if any: where a damaged bag can be read on. Searches for the `op=\x05` field and tries the
    /// record starts up to 4 KiB before it. Leaves the file at an unspecified offset.
    pub fn next_chunk(&mut self, from: u64) -> Result<Option<u64>, String> {
        const WINDOW: u64 = 1 << 20;
        const BACK: u64 = 4096;
        let mut start = from;
        while start < self.len {
            // The window holds `BACK` bytes before `start` for the headers found near its start.
            let lo = start.saturating_sub(BACK).max(from);
            let hi = (start + WINDOW).min(self.len);
            self.seek(lo)?;
            let buf = self.bytes(hi - lo, "bytes searched for a chunk")?;
            let first = (start - lo) as usize;
            let hits =
                buf.windows(8).enumerate().skip(first.saturating_sub(4)).filter(|(_, w)| w == b"\x04\0\0\0op=\x05");
            let mut found = None;
            for (at, _) in hits {
                found = (at.saturating_sub(BACK as usize)..=at.saturating_sub(4))
                    .filter(|&s| lo + s as u64 >= from)
                    .find(|&s| self.chunk_header_at(&buf, s, at, lo));
                if found.is_some() {
                    break;
                }
            }
            if let Some(s) = found {
                return Ok(Some(lo + s as u64));
            }
            if hi == self.len {
                break;
            }
            start = hi - 8;
        }
        Ok(None)
    }

    /// Whether `buf[s..]` (at file offset `lo + s`) starts a chunk record whose header holds the
    /// field at `field`.
    fn chunk_header_at(&self, buf: &[u8], s: usize, field: usize, lo: u64) -> bool {
        let le = |i: usize| buf.get(i..i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
        let Some(header_len) = le(s).filter(|&n| n <= 4096 && s + 4 + n >= field + 8) else { return false };
        let Some(header) = buf.get(s + 4..s + 4 + header_len) else { return false };
        let Ok(fields) = Fields::parse(header) else { return false };
        let is_chunk = matches!(fields.op(), Ok((_, Some(Op::Chunk))));
        let Some(data_len) = le(s + 4 + header_len) else { return false };
        is_chunk
            && fields.string("compression").is_ok()
            && fields.u32("size").is_ok()
            && lo + (s + 8 + header_len + data_len) as u64 <= self.len
    }

    /// Reads the record at the current offset; the data of index data records is skipped.
    pub fn next(&mut self) -> Result<TopRecord, String> {
        let offset = self.pos;
        let header_len = self.u32("record header length")?;
        let header = self.bytes(u64::from(header_len), "record header")?;
        let fields = Fields::parse(&header)?;
        let (op_byte, op) = fields.op()?;
        let data_len = u64::from(self.u32("record data length")?);
        let data = if op == Some(Op::IndexData) {
            self.skip(data_len, "index data")?;
            Vec::new()
        } else {
            self.bytes(data_len, "record data")?
        };
        Ok(TopRecord { offset, fields, op_byte, op, data })
    }
}

/// The largest uncompressed chunk read, bytes (256 MiB, the MCAP reader's record limit).
pub const CHUNK_LIMIT: u32 = 1 << 28;

/// The uncompressed data of a chunk compressed with `compression` (`none`, `bz2`, `lz4`)
/// whose header says it holds `size` bytes. ROS's `lz4` chunks are LZ4 frames (magic
/// `0x184D2204`, independent blocks, a content checksum; written by `roslz4`), `bz2` chunks one
/// bzip2 stream. Never allocates or decompresses more than `size + 1` bytes, and refuses a
/// `size` over [`CHUNK_LIMIT`] before decompressing anything (a kilobyte of bzip2 can claim,
/// and hold, 4 GiB of zeros).
pub fn decompress(compression: &str, data: &[u8], size: u32) -> Result<Vec<u8>, String> {
    if size > CHUNK_LIMIT {
        return Err(format!(
            "the {compression} chunk's header says {size} bytes, more than the {} MiB a chunk may hold here \
             (rosbag writes chunks of 768 KiB)",
            CHUNK_LIMIT >> 20
        ));
    }
    let limit = u64::from(size) + 1;
    let capacity = (size as usize).min(data.len().saturating_mul(4));
    let mut out = Vec::with_capacity(capacity);
    let result = match compression {
        "none" => {
            out.extend_from_slice(data);
            Ok(out.len())
        }
        "bz2" => bzip2::read::BzDecoder::new(data).take(limit).read_to_end(&mut out),
        "lz4" => lz4_flex::frame::FrameDecoder::new(data).take(limit).read_to_end(&mut out),
        other => return Err(format!("compression '{other}' is not one of none, bz2, lz4")),
    };
    result.map_err(|e| format!("the {compression} chunk does not decompress: {e}"))?;
    if out.len() > size as usize {
        return Err(format!("the {compression} chunk decompresses to more than the {size} bytes its header says"));
    }
    if out.len() < size as usize {
        return Err(format!("the {compression} chunk decompresses to {} bytes, but its header says {size}", out.len()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn field(name: &str, value: &[u8]) -> Vec<u8> {
        let mut f = ((name.len() + 1 + value.len()) as u32).to_le_bytes().to_vec();
        f.extend_from_slice(name.as_bytes());
        f.push(b'=');
        f.extend_from_slice(value);
        f
    }

    #[test]
    fn fields_parse_and_type_check() {
        let mut h = field("op", &[0x02]);
        h.extend(field("conn", &7u32.to_le_bytes()));
        h.extend(field("time", &[1, 0, 0, 0, 5, 0, 0, 0]));
        h.extend(field("topic", b"/scan=x"));
        let f = Fields::parse(&h).unwrap();
        assert_eq!(f.op().unwrap(), (2, Some(Op::MessageData)));
        assert_eq!(f.u32("conn").unwrap(), 7);
        assert_eq!(f.time_ns("time").unwrap(), 1_000_000_005);
        assert_eq!(f.string("topic").unwrap(), "/scan=x", "the value may hold '='");
        assert_eq!(f.u64("conn").unwrap_err(), "field 'conn' has 4 bytes, not 8");
        assert_eq!(f.u32("size").unwrap_err(), "no 'size' field");
        assert!(Fields::parse(&h[..h.len() - 1]).unwrap_err().contains("runs past the end of the header"));
        assert!(Fields::parse(&h[..2]).unwrap_err().contains("cut short"));
        assert!(Fields::parse(&[1, 0, 0, 0, b'x']).unwrap_err().contains("no '='"));
        let mut rec = (h.len() as u32).to_le_bytes().to_vec();
        rec.extend(&h);
        rec.extend(3u32.to_le_bytes());
        rec.extend(b"abc");
        let (f2, data, next) = record_in(&rec, 0).unwrap();
        assert_eq!((f2, data, next), (f, &b"abc"[..], rec.len()));
        for cut in 0..rec.len() {
            assert!(record_in(&rec[..cut], 0).is_err(), "cut at {cut}");
        }
    }

    #[test]
    fn chunks_decompress_with_their_sizes_checked() {
        let text: Vec<u8> = (0..5000u32).flat_map(|i| (i % 251).to_le_bytes()).collect();
        let size = text.len() as u32;
        assert_eq!(decompress("none", &text, size).unwrap(), text);
        let mut bz = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
        bz.write_all(&text).unwrap();
        let bz = bz.finish().unwrap();
        assert_eq!(decompress("bz2", &bz, size).unwrap(), text);
        let mut lz = lz4_flex::frame::FrameEncoder::new(Vec::new());
        lz.write_all(&text).unwrap();
        let lz = lz.finish().unwrap();
        assert_eq!(&lz[..4], &[0x04, 0x22, 0x4d, 0x18], "an LZ4 frame");
        assert_eq!(decompress("lz4", &lz, size).unwrap(), text);
        let e = decompress("lz4", &lz, size - 1).unwrap_err();
        assert!(e.contains(&format!("more than the {} bytes", size - 1)), "{e}");
        let e = decompress("bz2", &bz, size + 1).unwrap_err();
        assert!(e.contains(&format!("decompresses to {size} bytes")), "{e}");
        assert!(decompress("bz2", &bz[..bz.len() / 2], size).is_err());
        assert!(decompress("lz4", &bz, size).unwrap_err().contains("does not decompress"));
        assert!(decompress("zstd", &bz, size).unwrap_err().contains("'zstd' is not one of"));
        // A size of 4 GB on a small chunk: refused without allocating it.
        assert!(decompress("lz4", &lz, u32::MAX).unwrap_err().contains("header says 4294967295"));
        // A chunk whose header claims 300 MiB (a kilobyte of bzip2 can hold that many zeros):
        // refused by the size alone, before anything is decompressed.
        let e = decompress("bz2", &bz, 300 << 20).unwrap_err();
        assert!(e.contains("header says 314572800 bytes, more than the 256 MiB"), "{e}");
        assert!(decompress("none", &[], CHUNK_LIMIT + 1).unwrap_err().contains("more than the 256 MiB"));
        // At the limit the size is read, and checked against what the chunk holds.
        assert!(decompress("none", &[], CHUNK_LIMIT).unwrap_err().contains("decompresses to 0 bytes"));
    }
}
