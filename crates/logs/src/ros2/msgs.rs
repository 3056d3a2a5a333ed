//! Decoding the ROS 2 messages the reader uses from their CDR bytes. Each decoder reads the
//! whole message, so one shorter than its type is an error even if the fields used come first.

use super::cdr::{CdrError, CdrReader};

/// `std_msgs/Header`, the stamp in nanoseconds since 1970.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// `stamp`, nanoseconds.
    pub stamp_ns: u64,
    /// `frame_id`.
    pub frame_id: String,
}

/// `geometry_msgs/Pose`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// `position` (x, y, z).
    pub position: [f64; 3],
    /// `orientation` (x, y, z, w).
    pub orientation: [f64; 4],
}

/// The fields of `sensor_msgs/LaserScan` the reader uses.
#[derive(Clone, Debug, PartialEq)]
pub struct LaserScan {
    /// `header`.
    pub header: Header,
    /// `angle_min`, radians.
    pub angle_min: f32,
    /// `angle_increment`, radians.
    pub angle_increment: f32,
    /// `time_increment`, seconds (0: unknown).
    pub time_increment: f32,
    /// `range_min`, metres.
    pub range_min: f32,
    /// `range_max`, metres (inclusive).
    pub range_max: f32,
    /// `ranges`, metres.
    pub ranges: Vec<f32>,
}

/// A stamped pose: `geometry_msgs/PoseStamped`, `PoseWithCovarianceStamped`, the pose of
/// `nav_msgs/Odometry` (whose `child_frame_id` is dropped), or one transform of
/// `tf2_msgs/TFMessage` (translation and rotation as a pose).
#[derive(Clone, Debug, PartialEq)]
pub struct StampedPose {
    /// `header`.
    pub header: Header,
    /// The child frame (`child_frame_id`; empty for the pose messages).
    pub child_frame_id: String,
    /// The pose.
    pub pose: Pose,
}

fn time(r: &mut CdrReader<'_>, what: &str) -> Result<u64, CdrError> {
    let at = r.offset();
    let sec = r.i32(what)?;
    let nanosec = r.u32(what)?;
    let ns = i64::from(sec) * 1_000_000_000 + i64::from(nanosec);
    u64::try_from(ns).map_err(|_| CdrError {
        offset: at,
        message: format!("{what}: {sec} s {nanosec} ns is before 1970: a stamp cannot be negative"),
    })
}

fn header(r: &mut CdrReader<'_>) -> Result<Header, CdrError> {
    Ok(Header { stamp_ns: time(r, "header.stamp")?, frame_id: r.string("header.frame_id")? })
}

fn vector3(r: &mut CdrReader<'_>, what: &str) -> Result<[f64; 3], CdrError> {
    r.f64_array(what)
}

fn pose(r: &mut CdrReader<'_>, what: &str) -> Result<Pose, CdrError> {
    Ok(Pose { position: vector3(r, what)?, orientation: r.f64_array(what)? })
}

/// `sensor_msgs/msg/LaserScan`.
pub fn laser_scan(buf: &[u8]) -> Result<LaserScan, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let header = header(&mut r)?;
    let angle_min = r.f32("angle_min")?;
    let _angle_max = r.f32("angle_max")?;
    let angle_increment = r.f32("angle_increment")?;
    let time_increment = r.f32("time_increment")?;
    let _scan_time = r.f32("scan_time")?;
    let range_min = r.f32("range_min")?;
    let range_max = r.f32("range_max")?;
    let ranges = r.f32_seq("ranges")?;
    let n = r.sequence_len(4, 4, "intensities")?;
    for _ in 0..n {
        r.f32("intensities")?;
    }
    Ok(LaserScan { header, angle_min, angle_increment, time_increment, range_min, range_max, ranges })
}

/// `nav_msgs/msg/Odometry` (the twist is read and dropped).
pub fn odometry(buf: &[u8]) -> Result<StampedPose, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let header = header(&mut r)?;
    let child_frame_id = r.string("child_frame_id")?;
    let pose = pose(&mut r, "pose.pose")?;
    r.f64_array::<36>("pose.covariance")?;
    vector3(&mut r, "twist.twist.linear")?;
    vector3(&mut r, "twist.twist.angular")?;
    r.f64_array::<36>("twist.covariance")?;
    Ok(StampedPose { header, child_frame_id, pose })
}

/// `geometry_msgs/msg/PoseStamped`.
pub fn pose_stamped(buf: &[u8]) -> Result<StampedPose, CdrError> {
    let mut r = CdrReader::new(buf)?;
    Ok(StampedPose { header: header(&mut r)?, child_frame_id: String::new(), pose: pose(&mut r, "pose")? })
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped` (the covariance is read and dropped).
pub fn pose_with_covariance_stamped(buf: &[u8]) -> Result<StampedPose, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let header = header(&mut r)?;
    let pose = pose(&mut r, "pose.pose")?;
    r.f64_array::<36>("pose.covariance")?;
    Ok(StampedPose { header, child_frame_id: String::new(), pose })
}

/// The smallest `geometry_msgs/TransformStamped` on the wire: a stamp, two empty strings
/// (length words) and seven `float64`.
const MIN_TRANSFORM_BYTES: usize = 8 + 4 + 4 + 7 * 8;

/// `tf2_msgs/msg/TFMessage`: each transform's child frame in its parent (`header.frame_id`).
pub fn tf_message(buf: &[u8]) -> Result<Vec<StampedPose>, CdrError> {
    let mut r = CdrReader::new(buf)?;
    let n = r.sequence_len(MIN_TRANSFORM_BYTES, 4, "transforms")?;
    let mut out = Vec::new();
    for _ in 0..n {
        let header = header(&mut r)?;
        let child_frame_id = r.string("child_frame_id")?;
        let pose = pose(&mut r, "transform")?;
        out.push(StampedPose { header, child_frame_id, pose });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros2::cdr::CdrWriter;

    fn header(w: &mut CdrWriter, sec: i32, nanosec: u32, frame: &str) {
        w.i32(sec);
        w.u32(nanosec);
        w.string(frame);
    }

    #[test]
    fn a_tf_message_and_a_negative_stamp() {
        let mut w = CdrWriter::little_endian();
        w.u32(2);
        for (child, x) in [("plate", 1.0), ("laser", 2.0)] {
            header(&mut w, 3, 5, "base_link");
            w.string(child);
            for v in [x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
                w.f64(v);
            }
        }
        let tfs = tf_message(&w.finish().unwrap()).unwrap();
        assert_eq!(tfs.len(), 2);
        assert_eq!(tfs[1].child_frame_id, "laser");
        assert_eq!(tfs[1].header, Header { stamp_ns: 3_000_000_005, frame_id: "base_link".into() });
        assert_eq!(tfs[1].pose.position, [2.0, 0.0, 0.0]);
        let mut w = CdrWriter::little_endian();
        header(&mut w, -1, 0, "map");
        let e = pose_stamped(&w.finish().unwrap()).unwrap_err();
        assert!(e.to_string().starts_with("byte 4: header.stamp: -1 s 0 ns is before 1970"), "{e}");
    }

    #[test]
    fn a_message_shorter_than_its_type_is_refused() {
        let mut w = CdrWriter::little_endian();
        header(&mut w, 1, 0, "laser");
        for v in [-1.0, 1.0, 0.5, 0.0, 0.1, 0.1, 10.0] {
            w.f32(v);
        }
        w.f32_seq(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        let full = {
            let mut w2 = CdrWriter::little_endian();
            header(&mut w2, 1, 0, "laser");
            for v in [-1.0, 1.0, 0.5, 0.0, 0.1, 0.1, 10.0] {
                w2.f32(v);
            }
            w2.f32_seq(&[1.0, 2.0, 3.0, 4.0, 5.0]);
            w2.f32_seq(&[]);
            w2.finish().unwrap()
        };
        let scan = laser_scan(&full).unwrap();
        assert_eq!((scan.angle_min, scan.angle_increment, scan.range_max), (-1.0, 0.5, 10.0));
        assert_eq!(scan.ranges.len(), 5);
        // Without the intensities' length.
        let e = laser_scan(&w.finish().unwrap()).unwrap_err();
        assert!(e.message.starts_with("intensities:"), "{e}");
        for cut in 0..full.len() {
            assert!(laser_scan(&full[..cut]).is_err(), "cut at {cut}");
        }
    }
}
