//! The ROS 2 messages the node speaks, as serde types laid out field for field as their Jazzy
//! definitions (CDR on the wire through RustDDS), with their ROS type names.

use ros2_client::{Message, MessageTypeName};
use serde::{Deserialize, Serialize};

/// `builtin_interfaces/msg/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// The time as nanoseconds since the epoch; `None` before it or with `nanosec` ≥ 10⁹.
    pub fn to_ns(self) -> Option<u64> {
        if self.nanosec >= 1_000_000_000 {
            return None;
        }
        let ns = i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec);
        u64::try_from(ns).ok()
    }

    /// Nanoseconds since the epoch as a time (saturating at `i32::MAX` seconds).
    pub fn from_ns(ns: u64) -> Time {
        let sec = i32::try_from(ns / 1_000_000_000).unwrap_or(i32::MAX);
        Time { sec, nanosec: (ns % 1_000_000_000) as u32 }
    }
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Stamp.
    pub stamp: Time,
    /// Frame.
    pub frame_id: String,
}

/// `geometry_msgs/msg/Point` and `Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }
    }
}

impl Quaternion {
    /// A rotation by `yaw` about z.
    pub fn from_yaw(yaw: f64) -> Quaternion {
        let (s, c) = (yaw / 2.0).sin_cos();
        Quaternion { x: 0.0, y: 0.0, z: s, w: c }
    }
}

/// `geometry_msgs/msg/Pose` (and `Transform`: translation, rotation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (translation).
    pub position: Vector3,
    /// Orientation (rotation).
    pub orientation: Quaternion,
}

/// A 6 × 6 covariance, row-major: a fixed array of 36 `float64` on the wire (no length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cov36(pub [f64; 36]);

impl Default for Cov36 {
    fn default() -> Self {
        Cov36([0.0; 36])
    }
}

impl Serialize for Cov36 {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeTuple;
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Cov36 {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Cov36;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut a: A) -> Result<Cov36, A::Error> {
                let mut c = [0.0; 36];
                for (k, v) in c.iter_mut().enumerate() {
                    *v = a.next_element()?.ok_or_else(|| serde::de::Error::invalid_length(k, &self))?;
                }
                Ok(Cov36(c))
            }
        }
        d.deserialize_tuple(36, V)
    }
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6 × 6 covariance (x, y, z, roll, pitch, yaw).
    pub covariance: Cov36,
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped` (`/amcl_pose`, `/initialpose`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    /// Header (frame `map`).
    pub header: Header,
    /// The pose.
    pub pose: PoseWithCovariance,
}

/// `geometry_msgs/msg/Twist`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear.
    pub linear: Vector3,
    /// Angular.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Its covariance.
    pub covariance: Cov36,
}

/// `nav_msgs/msg/Odometry`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Header (frame `odom`).
    pub header: Header,
    /// `base_link`.
    pub child_frame_id: String,
    /// The pose.
    pub pose: PoseWithCovariance,
    /// The twist.
    pub twist: TwistWithCovariance,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Header: the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child frame in the parent (`geometry_msgs/Transform`: translation, rotation).
    pub transform: Pose,
}

/// `tf2_msgs/msg/TFMessage` (`/tf`, `/tf_static`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `sensor_msgs/msg/LaserScan`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Header: the lidar's frame.
    pub header: Header,
    /// First beam's angle, radians.
    pub angle_min: f32,
    /// Last beam's angle, radians.
    pub angle_max: f32,
    /// Angle between beams, radians.
    pub angle_increment: f32,
    /// Time between beams, seconds.
    pub time_increment: f32,
    /// Time between scans, seconds.
    pub scan_time: f32,
    /// Smallest valid range, metres.
    pub range_min: f32,
    /// Largest valid range, metres (inclusive).
    pub range_max: f32,
    /// Ranges, metres.
    pub ranges: Vec<f32>,
    /// Intensities (unused).
    pub intensities: Vec<f32>,
}

/// `nav_msgs/msg/MapMetaData`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    /// When the map was loaded.
    pub map_load_time: Time,
    /// Metres per cell.
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// The pose of cell (0, 0)'s corner in the map frame.
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid` (`/map`, `/updater/changes`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Header (frame `map`).
    pub header: Header,
    /// Geometry.
    pub info: MapMetaData,
    /// Row-major from the bottom row: 0 free, 100 occupied, −1 unknown.
    pub data: Vec<i8>,
}

/// `map_msgs/msg/OccupancyGridUpdate` (`/map_updates`): a window of the grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGridUpdate {
    /// Header (frame `map`).
    pub header: Header,
    /// The window's first column.
    pub x: i32,
    /// The window's first row.
    pub y: i32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// The window's cells, row-major from its bottom row.
    pub data: Vec<i8>,
}

/// `rosgraph_msgs/msg/Clock` (`/clock`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// The simulated time.
    pub clock: Time,
}

/// `mapkeeper_msgs/msg/UpdaterStep` (`/updater/step`), laid out as in the MCAP files
/// (`docs/real-data.md`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UpdaterStep {
    /// Header (the step's stamp).
    pub header: Header,
    /// The verdict acted on.
    pub verdict: String,
    /// The paper's check alone.
    pub check_verdict: String,
    /// What happened to the step.
    pub outcome: String,
    /// Valid beams.
    pub valid_beams: u32,
    /// Detected-change beams.
    pub detected_change_beams: u32,
    /// Their share of the valid beams.
    pub detected_share: f64,
    /// Cells that became occupied.
    pub cells_added: u32,
    /// Cells that stopped being occupied.
    pub cells_removed: u32,
    /// Cells between free and unknown.
    pub cells_other: u32,
    /// Registration ran.
    pub registration_ran: bool,
    /// Registration's correction was accepted.
    pub registration_accepted: bool,
    /// Its shift, metres.
    pub registration_shift_m: f64,
    /// Its turn, degrees.
    pub registration_turn_deg: f64,
    /// Pose updating's outcome.
    pub pose_recovery: String,
}

/// `std_srvs/srv/Trigger` request (empty: one byte on the wire, as ROS 2 sends it).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TriggerRequest {
    /// The placeholder byte ROS 2 gives an empty structure.
    pub structure_needs_at_least_one_member: u8,
}

/// `std_srvs/srv/Trigger` response.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TriggerResponse {
    /// Whether the map was saved.
    pub success: bool,
    /// Where, or why not.
    pub message: String,
}

macro_rules! messages {
    ($($t:ty => ($pkg:literal, $name:literal)),* $(,)?) => {
        $(impl Message for $t {})*
        /// The ROS type name of each message the node speaks.
        pub trait RosType {
            /// `pkg/msg/Name` as ROS 2 types it.
            fn type_name() -> MessageTypeName;
        }
        $(impl RosType for $t {
            fn type_name() -> MessageTypeName {
                MessageTypeName::new($pkg, $name)
            }
        })*
    };
}

messages! {
    Header => ("std_msgs", "Header"),
    PoseWithCovarianceStamped => ("geometry_msgs", "PoseWithCovarianceStamped"),
    Odometry => ("nav_msgs", "Odometry"),
    TfMessage => ("tf2_msgs", "TFMessage"),
    LaserScan => ("sensor_msgs", "LaserScan"),
    OccupancyGrid => ("nav_msgs", "OccupancyGrid"),
    OccupancyGridUpdate => ("map_msgs", "OccupancyGridUpdate"),
    Clock => ("rosgraph_msgs", "Clock"),
    UpdaterStep => ("mapkeeper_msgs", "UpdaterStep"),
}

impl Message for TriggerRequest {}
impl Message for TriggerResponse {}

/// A message from its CDR bytes with their 4-byte encapsulation header (a bag's message data):
/// little- or big-endian plain CDR.
pub fn from_cdr<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    let (head, body) = bytes.split_at_checked(4).ok_or("shorter than the 4-byte encapsulation header")?;
    let r = match head[..2] {
        [0, 1] => ros2_client::dds::rustdds::cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(body),
        [0, 0] => ros2_client::dds::rustdds::cdr_encoding::from_bytes::<T, byteorder::BigEndian>(body),
        _ => return Err(format!("encapsulation {:02x}{:02x} is not plain CDR", head[0], head[1])),
    };
    r.map(|(m, _)| m).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_round_trips_and_refuses_what_is_not_a_time() {
        let t = Time::from_ns(1_700_000_000_123_456_789);
        assert_eq!(t, Time { sec: 1_700_000_000, nanosec: 123_456_789 });
        assert_eq!(t.to_ns(), Some(1_700_000_000_123_456_789));
        assert_eq!(Time { sec: -1, nanosec: 0 }.to_ns(), None);
        assert_eq!(Time { sec: 1, nanosec: 1_000_000_000 }.to_ns(), None);
        assert_eq!(LaserScan::type_name().dds_msg_type(), "sensor_msgs::msg::dds_::LaserScan_");
    }
}
