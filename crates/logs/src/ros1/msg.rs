//! ROS 1 message deserialisation for the few types the reader uses.
//!
//! ROS 1 serialises a message as its fields in definition order, little-endian, with no padding
//! and no type tags: fixed-size numbers as they are; `string` as a `u32` byte count then the
//! bytes (UTF-8, no terminator); a variable-length array `T[]` as a `u32` element count then the
//! elements; a fixed-length array `T[n]` as its `n` elements with no count; `time` as `secs: u32`
//! then `nsecs: u32`; a nested message as its own fields.
//!
//! `std_msgs/Header` is `seq: u32, stamp: time, frame_id: string`.
//!
//! Every length read from a message is checked against the bytes left before anything is
//! allocated, so a corrupt length gives an error, never a huge allocation. A message must be used
//! up exactly: bytes left over mean the message is not of the type its connection names.

/// Reads a ROS 1 serialised message front to back.
#[derive(Debug)]
pub struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// The type being read, for errors (`sensor_msgs/LaserScan`).
    what: &'static str,
}

impl<'a> Cursor<'a> {
    /// A cursor at the start of `bytes`, a message of type `what`.
    pub fn new(bytes: &'a [u8], what: &'static str) -> Self {
        Self { bytes, pos: 0, what }
    }

    fn take(&mut self, n: usize, field: &str) -> Result<&'a [u8], String> {
        let left = self.bytes.len() - self.pos;
        if n > left {
            return Err(format!(
                "message too short for a {}: '{field}' needs {n} bytes at byte {} but only {left} are left \
(the message has {} bytes)",
                self.what,
                self.pos,
                self.bytes.len()
            ));
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self, field: &str) -> Result<[u8; N], String> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N, field)?);
        Ok(a)
    }

    /// A `uint32`.
    pub fn u32(&mut self, field: &str) -> Result<u32, String> {
        self.array(field).map(u32::from_le_bytes)
    }

    /// A `float32`.
    pub fn f32(&mut self, field: &str) -> Result<f32, String> {
        self.array(field).map(f32::from_le_bytes)
    }

    /// A `float64`.
    pub fn f64(&mut self, field: &str) -> Result<f64, String> {
        self.array(field).map(f64::from_le_bytes)
    }

    /// A `time` (`secs: u32`, `nsecs: u32`), as nanoseconds.
    pub fn time_ns(&mut self, field: &str) -> Result<u64, String> {
        let secs = self.u32(field)?;
        let nsecs = self.u32(field)?;
        Ok(u64::from(secs) * 1_000_000_000 + u64::from(nsecs))
    }

    /// A `string`: its `u32` length (at most the bytes left), then UTF-8 bytes.
    pub fn string(&mut self, field: &str) -> Result<String, String> {
        let n = self.u32(field)? as usize;
        let at = self.pos;
        let bytes = self.take(n, field)?;
        String::from_utf8(bytes.to_vec())
            .map_err(|_| format!("'{field}' of the {} at byte {at} is not UTF-8 text", self.what))
    }

    /// A `float32[]`: its `u32` count (at most the bytes left / 4), then the values.
    pub fn f32_vec(&mut self, field: &str) -> Result<Vec<f32>, String> {
        let n = self.u32(field)? as usize;
        let bytes = self.take(n.saturating_mul(4), field)?;
        Ok(bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    }

    /// Skips `n` `float64` values (a fixed-size array such as a covariance).
    pub fn skip_f64(&mut self, n: usize, field: &str) -> Result<(), String> {
        self.take(n * 8, field).map(|_| ())
    }

    /// `n` `float64` values.
    pub fn f64s<const N: usize>(&mut self, field: &str) -> Result<[f64; N], String> {
        let mut a = [0.0; N];
        for v in &mut a {
            *v = self.f64(field)?;
        }
        Ok(a)
    }

    /// A `std_msgs/Header`.
    pub fn header(&mut self) -> Result<Header, String> {
        Ok(Header {
            seq: self.u32("header.seq")?,
            stamp_ns: self.time_ns("header.stamp")?,
            frame_id: self.string("header.frame_id")?,
        })
    }

    /// The element count of a variable-length array whose elements take at least `min_size`
    /// bytes each: refused if that many could not fit in the bytes left.
    pub fn count(&mut self, min_size: usize, field: &str) -> Result<usize, String> {
        let n = self.u32(field)? as usize;
        let left = self.bytes.len() - self.pos;
        if n.saturating_mul(min_size) > left {
            return Err(format!(
                "'{field}' of the {} says {n} elements, but only {left} bytes are left (each takes at least {min_size})",
                self.what
            ));
        }
        Ok(n)
    }

    /// Checks that the message is used up.
    pub fn end(&self) -> Result<(), String> {
        let left = self.bytes.len() - self.pos;
        if left != 0 {
            return Err(format!(
                "{left} bytes left over after a {} of {} bytes: the message is not of the type its connection names",
                self.what, self.pos
            ));
        }
        Ok(())
    }
}

/// A `std_msgs/Header`.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Sequence number.
    pub seq: u32,
    /// Stamp, nanoseconds (ROS time: since the Unix epoch, or since the simulator's start).
    pub stamp_ns: u64,
    /// The frame, as written (a leading '/' is kept here).
    pub frame_id: String,
}

/// A `sensor_msgs/LaserScan` (its timing fields and intensities read and dropped).
#[derive(Clone, Debug, PartialEq)]
pub struct Scan {
    /// The header.
    pub header: Header,
    /// First beam's angle, radians.
    pub angle_min: f32,
    /// Last beam's angle, radians.
    pub angle_max: f32,
    /// Angle between beams, radians.
    pub angle_increment: f32,
    /// Time between beams, seconds (0: unknown).
    pub time_increment: f32,
    /// Smallest valid range, metres.
    pub range_min: f32,
    /// Largest valid range, metres (inclusive in ROS).
    pub range_max: f32,
    /// One reading per beam, metres.
    pub ranges: Vec<f32>,
}

/// A position and orientation (`geometry_msgs/Pose`, `geometry_msgs/Transform`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Position (translation), metres.
    pub position: [f64; 3],
    /// Orientation (rotation) quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

/// A stamped pose: `nav_msgs/Odometry` (`pose.pose`), `geometry_msgs/PoseStamped` or
/// `geometry_msgs/PoseWithCovarianceStamped` (`pose.pose`).
#[derive(Clone, Debug, PartialEq)]
pub struct StampedPose {
    /// The header.
    pub header: Header,
    /// The pose.
    pub pose: Placement,
}

/// One `geometry_msgs/TransformStamped`.
#[derive(Clone, Debug, PartialEq)]
pub struct Transform {
    /// The header (its frame is the parent).
    pub header: Header,
    /// The child frame, as written.
    pub child_frame_id: String,
    /// The child frame in the parent frame.
    pub transform: Placement,
}

/// `sensor_msgs/LaserScan`: header, `angle_min`, `angle_max`, `angle_increment`,
/// `time_increment`, `scan_time`, `range_min`, `range_max` (all `float32`), `ranges: float32[]`,
/// `intensities: float32[]`.
pub fn laser_scan(bytes: &[u8]) -> Result<Scan, String> {
    let mut c = Cursor::new(bytes, "sensor_msgs/LaserScan");
    let header = c.header()?;
    let angle_min = c.f32("angle_min")?;
    let angle_max = c.f32("angle_max")?;
    let angle_increment = c.f32("angle_increment")?;
    let time_increment = c.f32("time_increment")?;
    c.f32("scan_time")?;
    let range_min = c.f32("range_min")?;
    let range_max = c.f32("range_max")?;
    let ranges = c.f32_vec("ranges")?;
    c.f32_vec("intensities")?;
    c.end()?;
    Ok(Scan { header, angle_min, angle_max, angle_increment, time_increment, range_min, range_max, ranges })
}

fn placement(c: &mut Cursor<'_>, prefix: &str) -> Result<Placement, String> {
    let position = c.f64s::<3>(&format!("{prefix}.position"))?;
    let orientation = c.f64s::<4>(&format!("{prefix}.orientation"))?;
    Ok(Placement { position, orientation })
}

/// `nav_msgs/Odometry`: header, `child_frame_id: string`, `pose: PoseWithCovariance` (`Pose`,
/// `float64[36]`), `twist: TwistWithCovariance` (two `Vector3`, `float64[36]`).
pub fn odometry(bytes: &[u8]) -> Result<StampedPose, String> {
    let mut c = Cursor::new(bytes, "nav_msgs/Odometry");
    let header = c.header()?;
    c.string("child_frame_id")?;
    let pose = placement(&mut c, "pose.pose")?;
    c.skip_f64(36, "pose.covariance")?;
    c.skip_f64(6, "twist.twist")?;
    c.skip_f64(36, "twist.covariance")?;
    c.end()?;
    Ok(StampedPose { header, pose })
}

/// `geometry_msgs/PoseStamped`: header, `pose: Pose`.
pub fn pose_stamped(bytes: &[u8]) -> Result<StampedPose, String> {
    let mut c = Cursor::new(bytes, "geometry_msgs/PoseStamped");
    let header = c.header()?;
    let pose = placement(&mut c, "pose")?;
    c.end()?;
    Ok(StampedPose { header, pose })
}

/// `geometry_msgs/PoseWithCovarianceStamped`: header, `pose: PoseWithCovariance`.
pub fn pose_with_covariance_stamped(bytes: &[u8]) -> Result<StampedPose, String> {
    let mut c = Cursor::new(bytes, "geometry_msgs/PoseWithCovarianceStamped");
    let header = c.header()?;
    let pose = placement(&mut c, "pose.pose")?;
    c.skip_f64(36, "pose.covariance")?;
    c.end()?;
    Ok(StampedPose { header, pose })
}

/// Smallest serialised `geometry_msgs/TransformStamped`: a header with an empty frame (16
/// bytes), an empty child frame (4), seven `float64` (56).
const MIN_TRANSFORM_STAMPED: usize = 16 + 4 + 56;

/// `tf2_msgs/TFMessage` (and the older `tf/tfMessage`, laid out the same):
/// `transforms: geometry_msgs/TransformStamped[]`, each a header, `child_frame_id: string`,
/// `transform: Transform` (`translation: Vector3`, `rotation: Quaternion`).
pub fn tf_message(bytes: &[u8]) -> Result<Vec<Transform>, String> {
    let mut c = Cursor::new(bytes, "tf2_msgs/TFMessage");
    let n = c.count(MIN_TRANSFORM_STAMPED, "transforms")?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let header = c.header()?;
        let child_frame_id = c.string("child_frame_id")?;
        let transform = placement(&mut c, "transform")?;
        out.push(Transform { header, child_frame_id, transform });
    }
    c.end()?;
    Ok(out)
}

/// A frame id without one leading '/' (ROS 1 frames are often written `/base_link`; tf2 and
/// the project write `base_link`).
pub fn frame(id: &str) -> String {
    id.strip_prefix('/').unwrap_or(id).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A little ROS 1 serialiser for the tests.
    #[derive(Default)]
    struct Ser(Vec<u8>);

    impl Ser {
        fn u32(mut self, v: u32) -> Self {
            self.0.extend_from_slice(&v.to_le_bytes());
            self
        }
        fn f32(mut self, v: f32) -> Self {
            self.0.extend_from_slice(&v.to_le_bytes());
            self
        }
        fn f64s(mut self, v: &[f64]) -> Self {
            for x in v {
                self.0.extend_from_slice(&x.to_le_bytes());
            }
            self
        }
        fn string(self, s: &str) -> Self {
            let mut me = self.u32(s.len() as u32);
            me.0.extend_from_slice(s.as_bytes());
            me
        }
        fn header(self, seq: u32, secs: u32, nsecs: u32, frame: &str) -> Self {
            self.u32(seq).u32(secs).u32(nsecs).string(frame)
        }
    }

    fn scan_bytes(ranges: &[f32]) -> Vec<u8> {
        let mut s = Ser::default().header(7, 10, 500, "/laser").f32(-1.0).f32(1.0).f32(0.5).f32(0.0).f32(0.1);
        s = s.f32(0.05).f32(30.0).u32(ranges.len() as u32);
        for r in ranges {
            s = s.f32(*r);
        }
        s.u32(1).f32(100.0).0
    }

    #[test]
    fn a_laser_scan_decodes_field_by_field() {
        let s = laser_scan(&scan_bytes(&[1.0, 2.0, 3.0, 4.0, 30.0])).unwrap();
        assert_eq!(s.header, Header { seq: 7, stamp_ns: 10_000_000_500, frame_id: "/laser".into() });
        assert_eq!((s.angle_min, s.angle_max, s.angle_increment), (-1.0, 1.0, 0.5));
        assert_eq!((s.range_min, s.range_max), (0.05, 30.0));
        assert_eq!(s.ranges, vec![1.0, 2.0, 3.0, 4.0, 30.0]);
        assert_eq!(frame(&s.header.frame_id), "laser");
        assert_eq!(frame("//x"), "/x", "one slash only");
        assert_eq!(frame("x"), "x");
    }

    #[test]
    fn short_long_and_absurd_messages_are_refused() {
        let b = scan_bytes(&[1.0, 2.0]);
        for cut in 0..b.len() {
            let e = laser_scan(&b[..cut]).unwrap_err();
            assert!(e.contains("too short") || e.contains("bytes are left"), "cut {cut}: {e}");
        }
        let mut long = b.clone();
        long.push(0);
        assert!(laser_scan(&long).unwrap_err().contains("1 bytes left over"));
        // A frame_id length of 4 GB: refused before allocating.
        let absurd = Ser::default().u32(0).u32(0).u32(0).u32(u32::MAX - 3).0;
        let e = laser_scan(&absurd).unwrap_err();
        assert!(e.contains("'header.frame_id' needs 4294967292 bytes"), "{e}");
        // A ranges count of 1 G.
        let mut r = Ser::default().header(0, 0, 0, "l");
        for _ in 0..7 {
            r = r.f32(0.0);
        }
        let e = laser_scan(&r.u32(1 << 30).0).unwrap_err();
        assert!(e.contains("'ranges' needs 4294967296 bytes"), "{e}");
        let e = tf_message(&Ser::default().u32(1 << 31).0).unwrap_err();
        assert!(e.contains("says 2147483648 elements"), "{e}");
        let bad_utf8 = Ser::default().u32(0).u32(0).u32(0).u32(1).0.into_iter().chain([0xff]).collect::<Vec<u8>>();
        assert!(Cursor::new(&bad_utf8, "x").header().unwrap_err().contains("not UTF-8"));
    }

    #[test]
    fn odometry_poses_and_transforms_decode() {
        let pose = [1.0, 2.0, 0.5, 0.0, 0.0, 0.6, 0.8];
        let odom = Ser::default().header(1, 3, 0, "odom").string("base_link").f64s(&pose).f64s(&[0.0; 36]);
        let odom = odom.f64s(&[0.0; 6]).f64s(&[0.0; 36]).0;
        let o = odometry(&odom).unwrap();
        assert_eq!(o.header.stamp_ns, 3_000_000_000);
        assert_eq!(o.pose, Placement { position: [1.0, 2.0, 0.5], orientation: [0.0, 0.0, 0.6, 0.8] });
        assert!(odometry(&odom[..odom.len() - 8]).unwrap_err().contains("'twist.covariance'"));
        let ps = Ser::default().header(1, 4, 0, "map").f64s(&pose).0;
        assert_eq!(pose_stamped(&ps).unwrap().pose, o.pose);
        let pc = Ser::default().header(1, 4, 0, "map").f64s(&pose).f64s(&[0.0; 36]).0;
        assert_eq!(pose_with_covariance_stamped(&pc).unwrap().pose, o.pose);
        assert!(pose_stamped(&pc).unwrap_err().contains("left over"));
        let tf = Ser::default().u32(2).header(0, 5, 1, "/odom").string("/base_link").f64s(&pose);
        let tf = tf.header(0, 5, 2, "base_link").string("laser").f64s(&pose).0;
        let t = tf_message(&tf).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!((t[0].header.frame_id.as_str(), t[0].child_frame_id.as_str()), ("/odom", "/base_link"));
        assert_eq!(t[1].header.stamp_ns, 5_000_000_002);
        assert_eq!(t[1].transform.position, [1.0, 2.0, 0.5]);
    }
}
