"""Writes tests/data/rosbags_bag: a small ROS 2 bag in MCAP storage written by the `rosbags` Python
library (pip install rosbags numpy; python3 make_rosbags_bag.py rosbags_bag), a recorder other
than this crate. An upside-down lidar two frames from the base (/tf_static base_link -> plate ->
laser, roll pi on the laser), odometry on /odom, and a topic the reader skips."""
import math, sys, shutil
from pathlib import Path
import numpy as np
from rosbags.rosbag2 import Writer, StoragePlugin
from rosbags.typesys import Stores, get_typestore

ts = get_typestore(Stores.ROS2_HUMBLE)
Time = ts.types['builtin_interfaces/msg/Time']
Header = ts.types['std_msgs/msg/Header']
LaserScan = ts.types['sensor_msgs/msg/LaserScan']
Odometry = ts.types['nav_msgs/msg/Odometry']
TFMessage = ts.types['tf2_msgs/msg/TFMessage']
TransformStamped = ts.types['geometry_msgs/msg/TransformStamped']
Transform = ts.types['geometry_msgs/msg/Transform']
Vector3 = ts.types['geometry_msgs/msg/Vector3']
Quaternion = ts.types['geometry_msgs/msg/Quaternion']
Pose = ts.types['geometry_msgs/msg/Pose']
Point = ts.types['geometry_msgs/msg/Point']
PoseWithCovariance = ts.types['geometry_msgs/msg/PoseWithCovariance']
Twist = ts.types['geometry_msgs/msg/Twist']
TwistWithCovariance = ts.types['geometry_msgs/msg/TwistWithCovariance']
String = ts.types['std_msgs/msg/String']

T0 = 1_700_000_000 * 10**9
def stamp(ns): return Time(sec=ns // 10**9, nanosec=ns % 10**9)
def quat(roll, yaw):
    # Rz(yaw) * Rx(roll)
    cr, sr = math.cos(roll/2), math.sin(roll/2)
    cy, sy = math.cos(yaw/2), math.sin(yaw/2)
    return Quaternion(x=cy*sr, y=sy*sr, z=sy*cr, w=cy*cr)

out = Path(sys.argv[1])
shutil.rmtree(out, ignore_errors=True)
with Writer(out, version=8, storage_plugin=StoragePlugin.MCAP) as w:
    tf_static = w.add_connection('/tf_static', TFMessage.__msgtype__, typestore=ts)
    scan = w.add_connection('/scan', LaserScan.__msgtype__, typestore=ts)
    odom = w.add_connection('/odom', Odometry.__msgtype__, typestore=ts)
    chatter = w.add_connection('/chatter', String.__msgtype__, typestore=ts)
    tfs = TFMessage(transforms=[
        TransformStamped(header=Header(stamp=stamp(T0), frame_id='base_link'), child_frame_id='plate',
            transform=Transform(translation=Vector3(x=0.2, y=0.0, z=0.3), rotation=quat(0.0, 0.0))),
        TransformStamped(header=Header(stamp=stamp(T0), frame_id='plate'), child_frame_id='laser',
            transform=Transform(translation=Vector3(x=0.1, y=-0.2, z=0.0), rotation=quat(math.pi, 0.5))),
    ])
    w.write(tf_static, T0, ts.serialize_cdr(tfs, TFMessage.__msgtype__))
    for k in range(5):
        t = T0 + k * 100_000_000
        o = Odometry(header=Header(stamp=stamp(t), frame_id='odom'), child_frame_id='base_link',
            pose=PoseWithCovariance(pose=Pose(position=Point(x=0.1*k, y=0.0, z=0.0), orientation=quat(0.0, 0.02*k)), covariance=np.zeros(36)),
            twist=TwistWithCovariance(twist=Twist(linear=Vector3(x=0.0,y=0.0,z=0.0), angular=Vector3(x=0.0,y=0.0,z=0.0)), covariance=np.zeros(36)))
        w.write(odom, t, ts.serialize_cdr(o, Odometry.__msgtype__))
        ranges = np.array([1.0, 2.0, math.inf, 3.0, 10.0], dtype=np.float32)
        s = LaserScan(header=Header(stamp=stamp(t + 10_000_000), frame_id='laser'), angle_min=-0.5, angle_max=0.5,
            angle_increment=0.25, time_increment=0.0, scan_time=0.1, range_min=0.05, range_max=10.0,
            ranges=ranges, intensities=np.array([], dtype=np.float32))
        w.write(scan, t + 12_000_000, ts.serialize_cdr(s, LaserScan.__msgtype__))
        w.write(chatter, t + 1, ts.serialize_cdr(String(data='hi'), String.__msgtype__))
