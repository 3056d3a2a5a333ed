"""Cyclone DDS (Python) definitions of the ROS 2 Jazzy messages the mapkeeper node exchanges.

Each class is an ``IdlStruct`` whose DDS type name follows the ROS 2 convention
(``<package>::msg::dds_::<Name>_``), so a Cyclone endpoint matches a ROS 2 endpoint
of the same message on the wire.  Field order and field types are exactly those of the
``.msg`` definitions (ROS 2 Jazzy), hence the serialized CDR is byte-for-byte what a
ROS 2 node sends:

* ``float64[36]``  -> ``array[float64, 36]`` (fixed array, no length prefix)
* ``float32[]`` / ``int8[]`` -> ``sequence[...]`` (uint32 length prefix)
* ``string`` -> ``str`` (uint32 length including the NUL, bytes, NUL)

All structs are ``final`` (the default here and in ROS 2), serialized as XCDR1 / plain CDR
(encapsulation ``CDR_LE``) when the writer's DataRepresentation QoS asks for XCDR1 only,
which ``drive.py`` does.

Services (``std_srvs/srv/Trigger``) are laid out as rmw_cyclonedds lays them out (the only
layout this peer speaks): request type ``<package>::srv::dds_::<Name>_Request_`` on the DDS
topic ``rq/<service>Request``, reply type ``<package>::srv::dds_::<Name>_Response_`` on
``rr/<service>Reply``, and every sample starts with rmw_cyclonedds's request header
(``cdds_request_header_t``: ``uint64 guid``, ``int64 seq``, native order, i.e. little endian
here) before the ``.srv`` fields.  The header is modelled as two ordinary leading members, so
the CDR is::

    Trigger_Request_   guid:8 seq:8 structure_needs_at_least_one_member:1            (17 bytes)
    Trigger_Response_  guid:8 seq:8 success:1 pad:3 message_length:4 message... NUL

(after the 4-byte encapsulation header ``00 01 00 00``).  The server echoes the header
unchanged in its reply; the client keeps the replies whose header is its own.

Importing this module does not start DDS; it only needs ``cyclonedds.idl``.
"""

from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float32, float64, int8, int32, int64, sequence, uint8, uint32, uint64


def _zeros36() -> list[float]:
    return [0.0] * 36


# --- builtin_interfaces -------------------------------------------------------------


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    """builtin_interfaces/msg/Time: int32 sec, uint32 nanosec."""

    sec: int32 = 0
    nanosec: uint32 = 0


# --- std_msgs -----------------------------------------------------------------------


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    """std_msgs/msg/Header: builtin_interfaces/Time stamp, string frame_id."""

    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


# --- geometry_msgs ------------------------------------------------------------------


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64 = 0.0
    y: float64 = 0.0
    z: float64 = 0.0
    w: float64 = 1.0


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose = field(default_factory=Pose)
    covariance: array[float64, 36] = field(default_factory=_zeros36)


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass
class PoseWithCovarianceStamped(
    IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovarianceStamped_"
):
    header: Header = field(default_factory=Header)
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)


@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3 = field(default_factory=Vector3)
    angular: Vector3 = field(default_factory=Vector3)


@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist = field(default_factory=Twist)
    covariance: array[float64, 36] = field(default_factory=_zeros36)


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


# --- tf2_msgs -----------------------------------------------------------------------


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: sequence[TransformStamped] = field(default_factory=list)


# --- sensor_msgs --------------------------------------------------------------------


@dataclass
class LaserScan(IdlStruct, typename="sensor_msgs::msg::dds_::LaserScan_"):
    header: Header = field(default_factory=Header)
    angle_min: float32 = 0.0
    angle_max: float32 = 0.0
    angle_increment: float32 = 0.0
    time_increment: float32 = 0.0
    scan_time: float32 = 0.0
    range_min: float32 = 0.0
    range_max: float32 = 0.0
    ranges: sequence[float32] = field(default_factory=list)
    intensities: sequence[float32] = field(default_factory=list)


# --- nav_msgs -----------------------------------------------------------------------


@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    pose: PoseWithCovariance = field(default_factory=PoseWithCovariance)
    twist: TwistWithCovariance = field(default_factory=TwistWithCovariance)


@dataclass
class MapMetaData(IdlStruct, typename="nav_msgs::msg::dds_::MapMetaData_"):
    map_load_time: Time = field(default_factory=Time)
    resolution: float32 = 0.0
    width: uint32 = 0
    height: uint32 = 0
    origin: Pose = field(default_factory=Pose)


@dataclass
class OccupancyGrid(IdlStruct, typename="nav_msgs::msg::dds_::OccupancyGrid_"):
    header: Header = field(default_factory=Header)
    info: MapMetaData = field(default_factory=MapMetaData)
    data: sequence[int8] = field(default_factory=list)


# --- map_msgs -----------------------------------------------------------------------


@dataclass
class OccupancyGridUpdate(IdlStruct, typename="map_msgs::msg::dds_::OccupancyGridUpdate_"):
    header: Header = field(default_factory=Header)
    x: int32 = 0
    y: int32 = 0
    width: uint32 = 0
    height: uint32 = 0
    data: sequence[int8] = field(default_factory=list)


# --- rosgraph_msgs ------------------------------------------------------------------


@dataclass
class Clock(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time = field(default_factory=Time)


# --- std_srvs (rmw_cyclonedds service layout: request header first) -------------------


@dataclass
class TriggerRequest(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    """std_srvs/srv/Trigger request as rmw_cyclonedds sends it.

    ``client_guid`` and ``sequence_number`` are rmw_cyclonedds's ``cdds_request_header_t``
    (``guid``: the client's request writer's instance handle; ``seq``: 1, 2, ...); then the
    placeholder byte ROS 2 gives the empty request.
    """

    client_guid: uint64 = 0
    sequence_number: int64 = 0
    structure_needs_at_least_one_member: uint8 = 0


@dataclass
class TriggerResponse(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    """std_srvs/srv/Trigger response as rmw_cyclonedds sends it: the request's header echoed,
    then ``bool success``, ``string message``."""

    client_guid: uint64 = 0
    sequence_number: int64 = 0
    success: bool = False
    message: str = ""


__all__ = [
    "Clock",
    "Header",
    "LaserScan",
    "MapMetaData",
    "OccupancyGrid",
    "OccupancyGridUpdate",
    "Odometry",
    "Point",
    "Pose",
    "PoseStamped",
    "PoseWithCovariance",
    "PoseWithCovarianceStamped",
    "Quaternion",
    "TFMessage",
    "Time",
    "Transform",
    "TransformStamped",
    "TriggerRequest",
    "TriggerResponse",
    "Twist",
    "TwistWithCovariance",
    "Vector3",
]
