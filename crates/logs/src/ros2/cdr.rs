//! OMG CDR (version 1, "plain CDR"), the serialisation of ROS 2 messages on the wire and in a
//! bag, as far as the messages this crate reads and writes need it.
//!
//! A message starts with a 4-byte encapsulation header: `0x00 0x01` little endian, `0x00 0x00`
//! big endian, then two option bytes (ignored). Every primitive is aligned to its own size
//! (1, 2, 4 or 8 bytes), counted from the first byte after the header. A string is a `u32`
//! length that counts its NUL terminator, the bytes, then the NUL; a sequence is a `u32` element
//! count, then the elements; a fixed-size array is its elements alone.
//!
//! The reader never trusts a length: a sequence or string longer than the bytes left is an
//! error before anything is allocated, and every error names the byte offset in the message.

use std::fmt;

/// The encapsulation header's length, bytes.
const HEADER_LEN: usize = 4;

/// A message that cannot be decoded, or a value that cannot be encoded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CdrError {
    /// Byte offset in the message (counting the encapsulation header) where decoding failed.
    pub offset: usize,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for CdrError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "byte {}: {}", self.offset, self.message)
    }
}

impl std::error::Error for CdrError {}

/// Reads one CDR-encoded message.
#[derive(Debug)]
pub struct CdrReader<'a> {
    /// The whole message, header included.
    buf: &'a [u8],
    /// The next byte to read, an index into `buf`.
    pos: usize,
    big_endian: bool,
}

impl<'a> CdrReader<'a> {
    /// A reader past the encapsulation header of `buf`.
    pub fn new(buf: &'a [u8]) -> Result<Self, CdrError> {
        let err = |message: String| CdrError { offset: 0, message };
        if buf.len() < HEADER_LEN {
            return Err(err(format!("{} bytes: shorter than the 4-byte CDR encapsulation header", buf.len())));
        }
        let big_endian = match [buf[0], buf[1]] {
            [0x00, 0x00] => true,
            [0x00, 0x01] => false,
            [a, b] => {
                return Err(err(format!(
                    "encapsulation kind 0x{a:02x}{b:02x}: only plain CDR (0x0000 big endian, 0x0001 little endian) is read"
                )));
            }
        };
        Ok(Self { buf, pos: HEADER_LEN, big_endian })
    }

    /// The offset of the next byte in the message.
    pub fn offset(&self) -> usize {
        self.pos
    }

    /// Bytes left after the current position.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    /// An error at the current position.
    pub fn error(&self, message: impl Into<String>) -> CdrError {
        CdrError { offset: self.pos, message: message.into() }
    }

    /// Skips the padding before a value aligned to `n` bytes.
    fn align(&mut self, n: usize, what: &str) -> Result<(), CdrError> {
        let pad = (n - (self.pos - HEADER_LEN) % n) % n;
        if pad > self.remaining() {
            return Err(self.error(format!("{what}: the message ends in the padding before it")));
        }
        self.pos += pad;
        Ok(())
    }

    /// The next `N` bytes as a primitive of size `N` (aligned to `N`), in the message's byte
    /// order turned into little endian.
    fn take<const N: usize>(&mut self, what: &str) -> Result<[u8; N], CdrError> {
        self.align(N, what)?;
        let Some(bytes) = self.buf.get(self.pos..self.pos + N) else {
            return Err(self.error(format!("{what}: the message ends ({} bytes left, {N} needed)", self.remaining())));
        };
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        if self.big_endian {
            out.reverse();
        }
        self.pos += N;
        Ok(out)
    }

    /// A `uint8` (also `byte`, `char`).
    #[cfg(test)]
    pub fn u8(&mut self, what: &str) -> Result<u8, CdrError> {
        Ok(self.take::<1>(what)?[0])
    }

    /// An `int8`.
    #[cfg(test)]
    pub fn i8(&mut self, what: &str) -> Result<i8, CdrError> {
        Ok(i8::from_le_bytes(self.take(what)?))
    }

    /// A `uint16`.
    #[cfg(test)]
    pub fn u16(&mut self, what: &str) -> Result<u16, CdrError> {
        Ok(u16::from_le_bytes(self.take(what)?))
    }

    /// A `uint32`.
    pub fn u32(&mut self, what: &str) -> Result<u32, CdrError> {
        Ok(u32::from_le_bytes(self.take(what)?))
    }

    /// An `int32`.
    pub fn i32(&mut self, what: &str) -> Result<i32, CdrError> {
        Ok(i32::from_le_bytes(self.take(what)?))
    }

    /// A `uint64`.
    #[cfg(test)]
    pub fn u64(&mut self, what: &str) -> Result<u64, CdrError> {
        Ok(u64::from_le_bytes(self.take(what)?))
    }

    /// A `float32`.
    pub fn f32(&mut self, what: &str) -> Result<f32, CdrError> {
        Ok(f32::from_le_bytes(self.take(what)?))
    }

    /// A `float64`.
    pub fn f64(&mut self, what: &str) -> Result<f64, CdrError> {
        Ok(f64::from_le_bytes(self.take(what)?))
    }

    /// A fixed-size array of `float64` (`float64[36] covariance`).
    pub fn f64_array<const N: usize>(&mut self, what: &str) -> Result<[f64; N], CdrError> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(what)?;
        }
        Ok(out)
    }

    /// A sequence's element count, checked against the bytes left: each element takes at least
    /// `min_element_bytes` (≥ 1) bytes on the wire, and an element's first primitive is aligned
    /// to `align` bytes.
    pub fn sequence_len(&mut self, min_element_bytes: usize, align: usize, what: &str) -> Result<usize, CdrError> {
        let at = self.pos;
        let n = self.u32(what)? as usize;
        if n == 0 {
            return Ok(0);
        }
        let pad = (align - (self.pos - HEADER_LEN) % align) % align;
        let needed = n.saturating_mul(min_element_bytes.max(1)).saturating_add(pad);
        if needed > self.remaining() {
            return Err(CdrError {
                offset: at,
                message: format!(
                    "{what}: a sequence of {n} elements needs at least {needed} bytes, the message has {} left",
                    self.remaining()
                ),
            });
        }
        Ok(n)
    }

    /// A `float32[]`.
    pub fn f32_seq(&mut self, what: &str) -> Result<Vec<f32>, CdrError> {
        let n = self.sequence_len(4, 4, what)?;
        (0..n).map(|_| self.f32(what)).collect()
    }

    /// A `string`: UTF-8, the NUL terminator removed.
    pub fn string(&mut self, what: &str) -> Result<String, CdrError> {
        let at = self.pos;
        let n = self.sequence_len(1, 1, what)?;
        let bytes = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        // The length counts the terminator; a writer that leaves it out is tolerated.
        let text = bytes.strip_suffix(&[0]).unwrap_or(bytes);
        match std::str::from_utf8(text) {
            Ok(s) => Ok(s.to_string()),
            Err(e) => Err(CdrError { offset: at, message: format!("{what}: the string is not UTF-8 ({e})") }),
        }
    }
}

/// Writes one CDR-encoded message.
#[derive(Debug)]
pub struct CdrWriter {
    buf: Vec<u8>,
    big_endian: bool,
    /// The first length that did not fit a `u32`, if any (reported by [`CdrWriter::finish`]).
    overflow: Option<String>,
}

impl CdrWriter {
    /// A little-endian message (what ROS 2 writes on the usual platforms).
    pub fn little_endian() -> Self {
        Self { buf: vec![0x00, 0x01, 0x00, 0x00], big_endian: false, overflow: None }
    }

    /// A big-endian message.
    #[cfg(test)]
    pub fn big_endian() -> Self {
        Self { buf: vec![0x00, 0x00, 0x00, 0x00], big_endian: true, overflow: None }
    }

    fn put<const N: usize>(&mut self, mut le_bytes: [u8; N]) {
        let pad = (N - (self.buf.len() - HEADER_LEN) % N) % N;
        self.buf.extend(std::iter::repeat_n(0u8, pad));
        if self.big_endian {
            le_bytes.reverse();
        }
        self.buf.extend_from_slice(&le_bytes);
    }

    /// A `uint8` (or a `bool`: 0 or 1).
    pub fn u8(&mut self, v: u8) {
        self.put([v]);
    }

    /// An `int8`.
    #[cfg(test)]
    pub fn i8(&mut self, v: i8) {
        self.put(v.to_le_bytes());
    }

    /// A `uint16`.
    #[cfg(test)]
    pub fn u16(&mut self, v: u16) {
        self.put(v.to_le_bytes());
    }

    /// A `uint32`.
    pub fn u32(&mut self, v: u32) {
        self.put(v.to_le_bytes());
    }

    /// An `int32`.
    pub fn i32(&mut self, v: i32) {
        self.put(v.to_le_bytes());
    }

    /// A `uint64`.
    #[cfg(test)]
    pub fn u64(&mut self, v: u64) {
        self.put(v.to_le_bytes());
    }

    /// A `float32`.
    pub fn f32(&mut self, v: f32) {
        self.put(v.to_le_bytes());
    }

    /// A `float64`.
    pub fn f64(&mut self, v: f64) {
        self.put(v.to_le_bytes());
    }

    /// A sequence's element count (or a string's length).
    pub fn length(&mut self, n: usize, what: &str) {
        match u32::try_from(n) {
            Ok(n) => self.u32(n),
            Err(_) => {
                self.overflow.get_or_insert_with(|| format!("{what}: {n} elements do not fit a CDR length"));
                self.u32(0);
            }
        }
    }

    /// A `float32[]`.
    pub fn f32_seq(&mut self, v: &[f32]) {
        self.length(v.len(), "float32[]");
        for &x in v {
            self.f32(x);
        }
    }

    /// An `int8[]` (or `uint8[]`) given as bytes.
    pub fn byte_seq(&mut self, v: &[u8]) {
        self.length(v.len(), "int8[]");
        self.buf.extend_from_slice(v);
    }

    /// A `string` (its NUL terminator added).
    pub fn string(&mut self, s: &str) {
        self.length(s.len() + 1, "string");
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// The message's bytes, or the first length that did not fit.
    pub fn finish(self) -> Result<Vec<u8>, CdrError> {
        match self.overflow {
            None => Ok(self.buf),
            Some(message) => Err(CdrError { offset: 0, message }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_are_aligned_to_their_size_after_the_header() {
        let mut w = CdrWriter::little_endian();
        w.u8(7); // offset 4
        w.u32(0x0102_0304); // padded to 8
        w.u8(1); // 12
        w.f64(1.5); // padded to 20 (16 after the header)
        w.u16(9); // 28
        let bytes = w.finish().unwrap();
        assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
        assert_eq!(bytes.len(), 30);
        assert_eq!(&bytes[4..12], &[7, 0, 0, 0, 4, 3, 2, 1]);
        assert_eq!(&bytes[12..20], &[1, 0, 0, 0, 0, 0, 0, 0]);
        let mut r = CdrReader::new(&bytes).unwrap();
        assert_eq!(r.u8("a").unwrap(), 7);
        assert_eq!(r.u32("b").unwrap(), 0x0102_0304);
        assert_eq!(r.u8("c").unwrap(), 1);
        assert_eq!(r.offset(), 13);
        assert_eq!(r.f64("d").unwrap(), 1.5);
        assert_eq!(r.u16("e").unwrap(), 9);
        assert_eq!(r.remaining(), 0);
    }

    #[test]
    fn both_byte_orders_read_the_same_values() {
        for big in [false, true] {
            let mut w = if big { CdrWriter::big_endian() } else { CdrWriter::little_endian() };
            w.i32(-5);
            w.u64(u64::MAX - 1);
            w.f32(-0.25);
            w.i8(-3);
            w.string("base_link");
            w.f32_seq(&[1.0, f32::INFINITY, 3.5]);
            w.f64(std::f64::consts::PI);
            let bytes = w.finish().unwrap();
            assert_eq!(bytes[1], u8::from(!big));
            if big {
                assert_eq!(&bytes[4..8], &(-5i32).to_be_bytes());
            } else {
                assert_eq!(&bytes[4..8], &(-5i32).to_le_bytes());
            }
            let mut r = CdrReader::new(&bytes).unwrap();
            assert_eq!(r.i32("a").unwrap(), -5);
            assert_eq!(r.u64("b").unwrap(), u64::MAX - 1);
            assert_eq!(r.f32("c").unwrap(), -0.25);
            assert_eq!(r.i8("d").unwrap(), -3);
            assert_eq!(r.string("e").unwrap(), "base_link");
            assert_eq!(r.f32_seq("f").unwrap(), vec![1.0, f32::INFINITY, 3.5]);
            assert_eq!(r.f64("g").unwrap(), std::f64::consts::PI);
            assert_eq!(r.remaining(), 0);
        }
    }

    #[test]
    fn strings_count_their_terminator_and_sequences_their_elements() {
        let mut w = CdrWriter::little_endian();
        w.string("ab");
        w.string("");
        w.byte_seq(&[0xff, 1]);
        let bytes = w.finish().unwrap();
        // "ab": length 3, 'a' 'b' NUL; "" : padded to 12, length 1, NUL; bytes: padded to 20.
        assert_eq!(&bytes[4..11], &[3, 0, 0, 0, b'a', b'b', 0]);
        assert_eq!(&bytes[12..17], &[1, 0, 0, 0, 0]);
        assert_eq!(&bytes[20..26], &[2, 0, 0, 0, 0xff, 1]);
        let mut r = CdrReader::new(&bytes).unwrap();
        assert_eq!(r.string("a").unwrap(), "ab");
        assert_eq!(r.string("b").unwrap(), "");
        assert_eq!(r.sequence_len(1, 1, "c").unwrap(), 2);
        assert_eq!(r.i8("c0").unwrap(), -1);
        assert_eq!(r.u8("c1").unwrap(), 1);
        // A string without its terminator and one of length 0 are tolerated.
        let mut r = CdrReader::new(&[0, 1, 0, 0, 2, 0, 0, 0, b'h', b'i', 0, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(r.string("x").unwrap(), "hi");
        assert_eq!(r.string("y").unwrap(), "");
    }

    #[test]
    fn errors_name_the_byte_and_never_trust_a_length() {
        assert_eq!(CdrReader::new(&[0, 1]).unwrap_err().offset, 0);
        let e = CdrReader::new(&[0, 3, 0, 0]).unwrap_err();
        assert!(e.to_string().contains("0x0003"), "{e}");
        // A sequence claiming four billion floats in a 12-byte message.
        let bytes = [0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff, 0, 0, 0, 0];
        let e = CdrReader::new(&bytes).unwrap().f32_seq("ranges").unwrap_err();
        assert_eq!(e.offset, 4);
        assert!(e.to_string().starts_with("byte 4: ranges: a sequence of 4294967295 elements"), "{e}");
        // A string longer than the message.
        let e = CdrReader::new(&[0, 1, 0, 0, 9, 0, 0, 0, b'a']).unwrap().string("frame_id").unwrap_err();
        assert!(e.to_string().contains("frame_id") && e.offset == 4, "{e}");
        // A primitive cut short, and one cut in its padding.
        let mut r = CdrReader::new(&[0, 1, 0, 0, 1, 2, 3]).unwrap();
        let e = r.u32("sec").unwrap_err();
        assert_eq!((e.offset, e.message.as_str()), (4, "sec: the message ends (3 bytes left, 4 needed)"));
        let mut r = CdrReader::new(&[0, 1, 0, 0, 1, 2]).unwrap();
        r.u8("a").unwrap();
        assert!(r.f64("x").unwrap_err().message.contains("padding"));
        // Not UTF-8.
        let e = CdrReader::new(&[0, 1, 0, 0, 2, 0, 0, 0, 0xc3, 0]).unwrap().string("s").unwrap_err();
        assert!(e.message.contains("not UTF-8"), "{e}");
    }

    #[test]
    fn fixed_arrays_have_no_length() {
        let mut w = CdrWriter::little_endian();
        w.u8(1);
        for i in 0..3 {
            w.f64(f64::from(i));
        }
        let bytes = w.finish().unwrap();
        assert_eq!(bytes.len(), 4 + 8 + 24);
        let mut r = CdrReader::new(&bytes).unwrap();
        r.u8("a").unwrap();
        assert_eq!(r.f64_array::<3>("c").unwrap(), [0.0, 1.0, 2.0]);
        assert!(r.f64_array::<1>("d").is_err());
    }
}
