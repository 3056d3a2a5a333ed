#!/usr/bin/env python3
"""Play a recorded ROS 2 MCAP bag onto the DDS wire with Eclipse Cyclone DDS, as a ROS 2
robot would, and record what the mapkeeper node publishes back.

This is the *independent peer* of ``mapkeeper node``: a different DDS implementation
(Cyclone DDS, from the PyPI package ``cyclonedds``, which ships its own C library) than the
node's RustDDS, no ROS installation, no mock.  ROS 2 conventions are followed on the wire:
topic ``/x/y`` is the DDS topic ``rt/x/y``; type ``pkg/msg/T`` is the DDS type
``pkg::msg::dds_::T_`` (see ``ros_types.py``); payloads are plain CDR (XCDR1), little endian.

Network confinement: before ``cyclonedds`` is imported, ``CYCLONEDDS_URI`` is set to an
inline configuration that binds Cyclone to 127.0.0.1, forbids multicast and discovers peers
by unicast SPDP to 127.0.0.1 only (participant indices 0..30, i.e. the well-known ports
7410+250*domain+2*i).  Any ``CYCLONEDDS_URI`` inherited from the environment is overridden.

Usage (from the venv that ``requirements.txt`` describes)::

    python drive.py --bag drive.mcap --out result.json [--domain 0] [--rate 1.0]
        [--pose-topic /amcl_pose | --no-pose] [--clock] [--initialpose X,Y,YAW]
        [--inject drop:TOPIC:K] [--inject reorder:TOPIC:N] [--inject stale-scan:N]
        [--inject wrong-size:N] [--inject clock-back:N] [--inject no-tf-static]
        [--inject stop-at:SECONDS] [--call-save-map NODE_NAME]
        [--wait-node-s 20] [--wait-match-s 5] [--settle-s 3] [--timeout-s 60]

    python drive.py --selftest --bag drive.mcap [--rate 1.0] [--domain 0]

What it does, in order:

1. Subscribes to ``/map`` (nav_msgs/OccupancyGrid; reliable, transient local, keep last 1),
   ``/map_updates`` (map_msgs/OccupancyGridUpdate; reliable, volatile, keep last 1000) and
   ``/initialpose`` (geometry_msgs/PoseWithCovarianceStamped; reliable, volatile, keep last
   10; its own samples ignored).
2. Waits up to ``--wait-node-s`` for the node: a matched ``/map`` publisher or a first
   ``/map``.  Then waits up to ``--wait-match-s`` for the node's readers to match this
   script's writers (stopping early once no new match came for 1 s); topics nobody reads
   are named on stderr.
3. With ``--initialpose``: publishes it on ``/initialpose`` (frame map, RViz's covariance).
4. Plays the bag in file order at real rate (``--rate`` is a speed factor): each message is
   sent when ``(log_time - first log_time) / rate`` has elapsed since the start.
   Scans, ``/odom``, ``/tf`` on their own names; ``/tf_static`` as ONE message holding
   every static transform seen so far (reliable, transient local, keep last 1, as ROS 2's
   static broadcaster); ``/truth`` (PoseStamped) as PoseWithCovarianceStamped on
   ``--pose-topic`` with the very same floats and zero covariance.  With ``--clock`` a
   ``rosgraph_msgs/Clock`` with the message's header stamp is sent before each message whose
   stamp is later than the last clock sent.
5. Waits until the node is quiet: at least one full ``/map`` arrived after the last message
   was published, then neither ``/map`` nor ``/map_updates`` for ``--settle-s``; at most
   ``--timeout-s`` after the end of the bag.
   With ``--call-save-map NODE_NAME``: then calls the node's service ``/NODE_NAME/save_map``
   (std_srvs/srv/Trigger) the way an rmw_cyclonedds client does (see "Services" below):
   waits up to 5 s for the node's request reader and reply writer to match (the client's
   endpoints exist from the start, so normally they have long matched), sends one request
   and waits up to 10 s for the reply that carries this client's guid and sequence number.
6. Writes ``--out`` (JSON)::

       {"published": {topic: count}, "maps_received": n, "updates_received": n,
        "initialposes_received": [[x, y, yaw], ...],
        "final_map": GRID, "composed_map": GRID, "errors": [...],
        "bag_seconds": s, "play_seconds": s, "injections_applied": {spec: count},
        "save_map": {"success": bool, "message": str}}

   ``save_map`` is there only with ``--call-save-map``: the reply's fields, or null when no
   reply came (the reason is then in ``errors``).  A reply with ``success`` false is
   recorded as it is, not as an error.

   GRID = ``{"width", "height", "resolution", "origin": [x, y, yaw], "data": [...]}`` with
   data row-major as on the wire.  ``final_map`` is the last full ``/map``;
   ``composed_map`` is the first full ``/map`` with every ``/map_updates`` applied in
   arrival order (Nav2's static layer with subscribe_to_updates).  An update outside that
   grid, or one that arrives before any ``/map``, is an error and is not applied.

Exit code 0 on success; 2 on any failure (node not found, not quiet in time, an error in
``errors``, an injection that never applied) with a one-line reason on stderr.  The JSON is
written in both cases when it can be.

Fault injection (``--inject``, repeatable; each application is printed to stderr).  Counts
are 1-based.  TOPIC may be a bag topic or the published one (``/truth`` means the pose
topic; ``/clock`` works too); "message N of TOPIC" counts the messages this script was about
to publish on it; "the N-th scan" counts the bag's scans over every scan topic, in bag order;
"the N-th message" counts every bag message.

* ``drop:TOPIC:K``      drop every K-th message of TOPIC.
* ``reorder:TOPIC:N``   send message N+1 of TOPIC before message N (N right after N+1).
* ``stale-scan:N``      after the N-th scan, send again the scan sent 10 scans earlier on
                        the same topic, with its old stamp.
* ``wrong-size:N``      the N-th scan's ranges are cut to half their length (angle fields
                        unchanged).
* ``clock-back:N``      (needs ``--clock``) after the N-th message, a clock 5 s before the
                        latest clock (not below 0); the next message's clock is sent anyway.
* ``no-tf-static``      never publish ``/tf_static``.
* ``stop-at:SECONDS``   once the bag time (log_time since the first message) passes
                        SECONDS: write the JSON (no settling) and ``os._exit`` at once,
                        deleting no DDS entity, so no goodbye reaches the node (it must
                        notice through the lease expiring).  Exit code 0 unless errors.

Services (``--call-save-map``): rmw_cyclonedds's layout, which the node speaks with its
parameter ``service_layout: cyclone``.  Service ``/N/save_map`` is the request topic
``rq/N/save_mapRequest`` (type ``std_srvs::srv::dds_::Trigger_Request_``) and the reply topic
``rr/N/save_mapReply`` (``std_srvs::srv::dds_::Trigger_Response_``), both reliable, volatile,
keep last 10.  Every sample starts with rmw_cyclonedds's 16-byte request header, then the
``.srv`` fields, in plain CDR little endian after the encapsulation ``00 01 00 00``::

    request   guid:u64 seq:i64 structure_needs_at_least_one_member:u8
    reply     guid:u64 seq:i64 success:bool pad:3 len:u32 message bytes NUL

``guid`` is this client's request writer's instance handle (as rmw_cyclonedds has it),
``seq`` counts from 1; the server echoes both, and only a reply carrying both is taken (others
are logged and ignored).

``--selftest`` checks this script without the node: it starts a fake node (this script with
a hidden option, a Cyclone participant in another process) that serves ``/map``,
``/map_updates`` and ``/mapkeeper/save_map``, reads everything the driver sends and compares
it with the bag, then runs the driver against it in several scenarios (clean at ``--rate``
with a save_map call, faults at rate 10, an update outside the grid and a save_map server
that answers only other clients, a vanishing driver, no node) and prints ``selftest: N
passed, M failed``.  Exit code 0 when all passed.
"""

from __future__ import annotations

import os
import sys

_MAX_AUTO_PARTICIPANT_INDEX = 30


def loopback_config(max_auto_index: int = _MAX_AUTO_PARTICIPANT_INDEX) -> str:
    """Cyclone DDS configuration that keeps every packet on 127.0.0.1."""
    return (
        "<CycloneDDS><Domain Id=\"any\">"
        "<General>"
        "<Interfaces><NetworkInterface address=\"127.0.0.1\" multicast=\"false\"/></Interfaces>"
        "<AllowMulticast>false</AllowMulticast>"
        "<DontRoute>true</DontRoute>"
        "</General>"
        "<Discovery>"
        "<ParticipantIndex>auto</ParticipantIndex>"
        f"<MaxAutoParticipantIndex>{max_auto_index}</MaxAutoParticipantIndex>"
        "<Peers><Peer address=\"127.0.0.1\"/></Peers>"
        "</Discovery>"
        "<Tracing><Verbosity>warning</Verbosity><OutputFile>stderr</OutputFile></Tracing>"
        "</Domain></CycloneDDS>"
    )


# ruff: noqa: E402 (the imports below must come after CYCLONEDDS_URI is set)
# Mandatory network confinement: set before cyclonedds is imported (and so before any
# DomainParticipant exists), overriding whatever the environment says.
os.environ["CYCLONEDDS_URI"] = loopback_config()

import argparse
import itertools
import json
import math
import random
import subprocess
import tempfile
import threading
import time
from collections import Counter, defaultdict, deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cyclonedds.core import (
    InstanceState,
    Policy,
    Qos,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

import ros_types as rt

# ----------------------------------------------------------------------------------------
# Constants: QoS, names
# ----------------------------------------------------------------------------------------

_XCDR1 = Policy.DataRepresentation(use_cdrv0_representation=True)
_RELIABLE = Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1))

#: Sensor-like topics (scans, /odom, /tf, pose, /clock): reliable, volatile, keep last 50.
QOS_SENSOR = Qos(_RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(50), _XCDR1)
#: /tf_static, /map: reliable, transient local, keep last 1 (ROS 2 static broadcaster, map_server).
QOS_LATCHED = Qos(_RELIABLE, Policy.Durability.TransientLocal, Policy.History.KeepLast(1), _XCDR1)
#: /map_updates reader: reliable, volatile, keep last 1000.
QOS_UPDATES = Qos(_RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(1000), _XCDR1)
#: /initialpose writer (RViz/Nav2-like): reliable, volatile, keep last 10.
QOS_INITIALPOSE_W = Qos(_RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(10), _XCDR1)
#: /initialpose reader: as amcl's, and ignoring this participant's own samples.
QOS_INITIALPOSE_R = Qos(
    _RELIABLE,
    Policy.Durability.Volatile,
    Policy.History.KeepLast(10),
    Policy.IgnoreLocal.Participant,
    _XCDR1,
)

#: Service request and reply topics (rmw_qos_profile_services_default): reliable, volatile, keep last 10.
QOS_SERVICE = Qos(_RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(10), _XCDR1)

SCAN_T = "sensor_msgs/msg/LaserScan"
ODOM_T = "nav_msgs/msg/Odometry"
TF_T = "tf2_msgs/msg/TFMessage"
POSE_STAMPED_T = "geometry_msgs/msg/PoseStamped"

#: RViz's "2D Pose Estimate" covariance: x, y variance 0.25 m^2, yaw variance (pi/12)^2.
INITIALPOSE_COVARIANCE_DIAG = {0: 0.25, 7: 0.25, 35: 0.06853891945200942}

EXIT_OK = 0
EXIT_FAIL = 2


def dds_topic_name(ros_name: str) -> str:
    """ROS 2 topic name -> DDS topic name (``/lidar_0/scan`` -> ``rt/lidar_0/scan``)."""
    return "rt/" + ros_name.lstrip("/")


_TOPICS: dict[tuple[int, str], Topic] = {}


def get_topic(dp: DomainParticipant, ros_name: str, data_type: type) -> Topic:
    """One Topic entity per participant and name (readers and writers share it)."""
    key = (id(dp), ros_name)
    if key not in _TOPICS:
        _TOPICS[key] = Topic(dp, dds_topic_name(ros_name), data_type)
    return _TOPICS[key]


def log(msg: str) -> None:
    print(f"drive.py: {msg}", file=sys.stderr, flush=True)


class Failure(Exception):
    """A failure that ends the run with exit code 2 and a one-line reason."""


# ----------------------------------------------------------------------------------------
# Conversions between mcap_ros2 decoded messages and Cyclone structs
# ----------------------------------------------------------------------------------------


def ns_to_time(ns: int) -> rt.Time:
    return rt.Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def time_to_ns(t: Any) -> int:
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


def c_time(t: Any) -> rt.Time:
    return rt.Time(sec=int(t.sec), nanosec=int(t.nanosec))


def c_header(h: Any) -> rt.Header:
    return rt.Header(stamp=c_time(h.stamp), frame_id=str(h.frame_id))


def c_vec3(v: Any) -> rt.Vector3:
    return rt.Vector3(x=float(v.x), y=float(v.y), z=float(v.z))


def c_point(p: Any) -> rt.Point:
    return rt.Point(x=float(p.x), y=float(p.y), z=float(p.z))


def c_quat(q: Any) -> rt.Quaternion:
    return rt.Quaternion(x=float(q.x), y=float(q.y), z=float(q.z), w=float(q.w))


def c_pose(p: Any) -> rt.Pose:
    return rt.Pose(position=c_point(p.position), orientation=c_quat(p.orientation))


def c_scan(m: Any) -> rt.LaserScan:
    return rt.LaserScan(
        header=c_header(m.header),
        angle_min=float(m.angle_min),
        angle_max=float(m.angle_max),
        angle_increment=float(m.angle_increment),
        time_increment=float(m.time_increment),
        scan_time=float(m.scan_time),
        range_min=float(m.range_min),
        range_max=float(m.range_max),
        ranges=[float(r) for r in m.ranges],
        intensities=[float(i) for i in m.intensities],
    )


def c_odom(m: Any) -> rt.Odometry:
    return rt.Odometry(
        header=c_header(m.header),
        child_frame_id=str(m.child_frame_id),
        pose=rt.PoseWithCovariance(
            pose=c_pose(m.pose.pose), covariance=[float(c) for c in m.pose.covariance]
        ),
        twist=rt.TwistWithCovariance(
            twist=rt.Twist(linear=c_vec3(m.twist.twist.linear), angular=c_vec3(m.twist.twist.angular)),
            covariance=[float(c) for c in m.twist.covariance],
        ),
    )


def c_transform_stamped(t: Any) -> rt.TransformStamped:
    return rt.TransformStamped(
        header=c_header(t.header),
        child_frame_id=str(t.child_frame_id),
        transform=rt.Transform(
            translation=c_vec3(t.transform.translation), rotation=c_quat(t.transform.rotation)
        ),
    )


def c_tf(m: Any) -> rt.TFMessage:
    return rt.TFMessage(transforms=[c_transform_stamped(t) for t in m.transforms])


def c_truth_as_pose(m: Any) -> rt.PoseWithCovarianceStamped:
    return rt.PoseWithCovarianceStamped(
        header=c_header(m.header),
        pose=rt.PoseWithCovariance(pose=c_pose(m.pose), covariance=[0.0] * 36),
    )


def yaw_of(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def quat_of_yaw(yaw: float) -> rt.Quaternion:
    return rt.Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def stamp_ns_of(msg: Any) -> int | None:
    """Header stamp of a Cyclone message (latest transform stamp for a TFMessage)."""
    if isinstance(msg, rt.TFMessage):
        stamps = [time_to_ns(t.header.stamp) for t in msg.transforms]
        return max(stamps) if stamps else None
    header = getattr(msg, "header", None)
    return time_to_ns(header.stamp) if header is not None else None


def make_initialpose(x: float, y: float, yaw: float, stamp_ns: int) -> rt.PoseWithCovarianceStamped:
    cov = [0.0] * 36
    for i, v in INITIALPOSE_COVARIANCE_DIAG.items():
        cov[i] = v
    return rt.PoseWithCovarianceStamped(
        header=rt.Header(stamp=ns_to_time(stamp_ns), frame_id="map"),
        pose=rt.PoseWithCovariance(
            pose=rt.Pose(position=rt.Point(x=x, y=y, z=0.0), orientation=quat_of_yaw(yaw)),
            covariance=cov,
        ),
    )


def grid_json(m: rt.OccupancyGrid) -> dict[str, Any]:
    o = m.info.origin
    return {
        "width": int(m.info.width),
        "height": int(m.info.height),
        "resolution": float(m.info.resolution),
        "origin": [float(o.position.x), float(o.position.y), yaw_of(o.orientation)],
        "frame_id": m.header.frame_id,
        "data": [int(v) for v in m.data],
    }


# ----------------------------------------------------------------------------------------
# Bag reading
# ----------------------------------------------------------------------------------------


@dataclass
class BagInfo:
    topics: dict[str, str]  # bag topic -> schema name
    counts: Counter[str]
    first_ns: int
    last_ns: int

    @property
    def seconds(self) -> float:
        return (self.last_ns - self.first_ns) / 1e9

    @property
    def scan_topics(self) -> list[str]:
        return sorted(t for t, s in self.topics.items() if s == SCAN_T)


def bag_info(path: Path) -> BagInfo:
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        if summary is not None and summary.statistics is not None:
            topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
            counts: Counter[str] = Counter()
            for cid, n in summary.statistics.channel_message_counts.items():
                counts[summary.channels[cid].topic] += n
            return BagInfo(topics, counts, summary.statistics.message_start_time,
                           summary.statistics.message_end_time)
    topics = {}
    counts = Counter()
    first = last = None
    with path.open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
            topics[channel.topic] = schema.name if schema else ""
            counts[channel.topic] += 1
            first = message.log_time if first is None else min(first, message.log_time)
            last = message.log_time if last is None else max(last, message.log_time)
    if first is None:
        raise Failure(f"bag {path} holds no message")
    return BagInfo(topics, counts, first, last)


def iter_bag(path: Path) -> Iterator[tuple[str, str, int, Any]]:
    """(topic, schema name, log_time ns, decoded message), in file (bag) order."""
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            yield channel.topic, schema.name if schema else "", message.log_time, decoded


# ----------------------------------------------------------------------------------------
# Fault injection
# ----------------------------------------------------------------------------------------


@dataclass
class Injections:
    specs: list[str] = field(default_factory=list)
    drop: dict[str, tuple[int, str]] = field(default_factory=dict)  # out topic -> (K, spec)
    reorder: dict[str, tuple[int, str]] = field(default_factory=dict)  # out topic -> (N, spec)
    stale_scan: dict[int, str] = field(default_factory=dict)
    wrong_size: dict[int, str] = field(default_factory=dict)
    clock_back: dict[int, str] = field(default_factory=dict)
    no_tf_static: str | None = None
    stop_at: tuple[float, str] | None = None
    applied: Counter[str] = field(default_factory=Counter)

    def apply(self, spec: str, what: str) -> None:
        self.applied[spec] += 1
        log(f"inject {spec}: {what}")


def parse_injections(specs: list[str], pose_topic: str | None, clock: bool) -> Injections:
    inj = Injections(specs=list(specs))

    def out_topic(t: str) -> str:
        if not t.startswith("/"):
            t = "/" + t
        if t == "/truth":
            if pose_topic is None:
                raise ValueError("/truth is not published (--no-pose)")
            return pose_topic
        return t

    def positive(s: str, spec: str) -> int:
        n = int(s)
        if n < 1:
            raise ValueError(f"{spec}: the count must be >= 1")
        return n

    for spec in specs:
        parts = spec.split(":")
        kind = parts[0]
        try:
            if kind in ("drop", "reorder") and len(parts) == 3:
                table = inj.drop if kind == "drop" else inj.reorder
                table[out_topic(parts[1])] = (positive(parts[2], spec), spec)
            elif kind == "stale-scan" and len(parts) == 2:
                n = positive(parts[1], spec)
                if n <= 10:
                    raise ValueError(f"{spec}: N must be > 10 (it resends the scan 10 scans older)")
                inj.stale_scan[n] = spec
            elif kind == "wrong-size" and len(parts) == 2:
                inj.wrong_size[positive(parts[1], spec)] = spec
            elif kind == "clock-back" and len(parts) == 2:
                if not clock:
                    raise ValueError(f"{spec} needs --clock")
                inj.clock_back[positive(parts[1], spec)] = spec
            elif kind == "no-tf-static" and len(parts) == 1:
                inj.no_tf_static = spec
            elif kind == "stop-at" and len(parts) == 2:
                s = float(parts[1])
                if not s >= 0.0:
                    raise ValueError(f"{spec}: SECONDS must be >= 0")
                inj.stop_at = (s, spec)
            else:
                raise ValueError(f"unknown or malformed injection {spec!r}")
        except ValueError as e:
            raise argparse.ArgumentTypeError(str(e)) from e
    return inj


# ----------------------------------------------------------------------------------------
# Receiving side: /map, /map_updates, /initialpose
# ----------------------------------------------------------------------------------------


class Recorder:
    """Takes what the node publishes, on a thread of its own, and composes the map."""

    def __init__(self, dp: DomainParticipant) -> None:
        self.lock = threading.Lock()
        self.map_reader = DataReader(dp, get_topic(dp, "/map", rt.OccupancyGrid), qos=QOS_LATCHED)
        self.upd_reader = DataReader(
            dp, get_topic(dp, "/map_updates", rt.OccupancyGridUpdate), qos=QOS_UPDATES
        )
        self.pose_topic = get_topic(dp, "/initialpose", rt.PoseWithCovarianceStamped)
        self.pose_reader = DataReader(dp, self.pose_topic, qos=QOS_INITIALPOSE_R)
        self.maps_received = 0
        self.updates_received = 0
        self.initialposes: list[list[float]] = []
        self.errors: list[str] = []
        self.first_map: dict[str, Any] | None = None  # composed map (first + updates)
        self.final_map: dict[str, Any] | None = None
        self.last_map_at = -math.inf  # time.monotonic() of arrival
        self.last_activity_at = -math.inf
        self._stop = threading.Event()
        self._ws = WaitSet(dp)
        mask = SampleState.Any | ViewState.Any | InstanceState.Any
        self._conds = []
        for r in (self.map_reader, self.upd_reader, self.pose_reader):
            c = ReadCondition(r, mask)
            self._ws.attach(c)
            self._conds.append(c)
        self._thread = threading.Thread(target=self._run, name="recorder", daemon=True)
        self._thread.start()

    def map_publisher_matched(self) -> bool:
        return self.map_reader.get_subscription_matched_status().current_count > 0

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)

    def _run(self) -> None:
        while not self._stop.is_set():
            self._ws.wait(duration(milliseconds=50))
            self.poll()

    def _take(self, reader: DataReader, what: str) -> list[Any]:
        try:
            return [s for s in reader.take(N=256) if hasattr(s, "sample_info") and s.sample_info.valid_data]
        except Exception as e:  # noqa: BLE001 - a sample this peer cannot decode is the node's fault
            with self.lock:
                self.errors.append(f"{what}: cannot take/decode a sample: {e}")
            return []

    def poll(self) -> None:
        while True:
            maps = self._take(self.map_reader, "/map")
            upds = self._take(self.upd_reader, "/map_updates")
            poses = self._take(self.pose_reader, "/initialpose")
            if not (maps or upds or poses):
                return
            now = time.monotonic()
            with self.lock:
                for m in maps:
                    self._on_map(m, now)
                for u in upds:
                    self._on_update(u, now)
                for p in poses:
                    pp = p.pose.pose
                    self.initialposes.append([pp.position.x, pp.position.y, yaw_of(pp.orientation)])

    def _on_map(self, m: rt.OccupancyGrid, now: float) -> None:
        self.maps_received += 1
        self.last_map_at = now
        self.last_activity_at = now
        g = grid_json(m)
        if len(g["data"]) != g["width"] * g["height"]:
            self.errors.append(
                f"/map #{self.maps_received}: {len(g['data'])} cells for {g['width']}x{g['height']}"
            )
        self.final_map = g
        if self.first_map is None:
            self.first_map = dict(g, data=list(g["data"]))

    def _on_update(self, u: rt.OccupancyGridUpdate, now: float) -> None:
        self.updates_received += 1
        self.last_activity_at = now
        n = self.updates_received
        x, y, w, h = int(u.x), int(u.y), int(u.width), int(u.height)
        if self.first_map is None:
            self.errors.append(f"/map_updates #{n} arrived before any /map (not applied)")
            return
        W, H = self.first_map["width"], self.first_map["height"]
        if len(u.data) != w * h:
            self.errors.append(f"/map_updates #{n}: {len(u.data)} cells for {w}x{h} (not applied)")
            return
        if x < 0 or y < 0 or x + w > W or y + h > H:
            self.errors.append(
                f"/map_updates #{n}: x={x} y={y} {w}x{h} is outside the {W}x{H} grid (not applied)"
            )
            return
        data = self.first_map["data"]
        for row in range(h):
            start = (y + row) * W + x
            data[start:start + w] = [int(v) for v in u.data[row * w:(row + 1) * w]]


# ----------------------------------------------------------------------------------------
# Publishing side
# ----------------------------------------------------------------------------------------


class Publisher:
    """Writers per ROS topic, with the drop/reorder faults and the published counts."""

    def __init__(self, dp: DomainParticipant, inj: Injections) -> None:
        self.dp = dp
        self.inj = inj
        self.writers: dict[str, DataWriter] = {}
        self.published: Counter[str] = Counter()
        self.offered: Counter[str] = Counter()  # messages that reached the fault layer
        self.held: dict[str, Any] = {}  # reorder: message N waiting for N+1
        self.last_publish_at = time.monotonic()

    def add(self, ros_topic: str, data_type: type, qos: Qos) -> None:
        if ros_topic not in self.writers:
            topic = get_topic(self.dp, ros_topic, data_type)
            self.writers[ros_topic] = DataWriter(self.dp, topic, qos=qos)

    def _write(self, ros_topic: str, msg: Any) -> None:
        self.writers[ros_topic].write(msg)
        self.published[ros_topic] += 1
        self.last_publish_at = time.monotonic()

    def emit(self, ros_topic: str, msg: Any, faults: bool = True) -> None:
        if not faults:
            self._write(ros_topic, msg)
            return
        self.offered[ros_topic] += 1
        k = self.offered[ros_topic]
        drop = self.inj.drop.get(ros_topic)
        if drop is not None and k % drop[0] == 0:
            self.inj.apply(drop[1], f"dropped message {k} of {ros_topic}")
            return
        reorder = self.inj.reorder.get(ros_topic)
        if reorder is not None:
            if k == reorder[0]:
                self.held[ros_topic] = msg
                return
            if k == reorder[0] + 1 and ros_topic in self.held:
                self._write(ros_topic, msg)
                self._write(ros_topic, self.held.pop(ros_topic))
                self.inj.apply(reorder[1], f"sent message {k} of {ros_topic} before message {k - 1}")
                return
        self._write(ros_topic, msg)

    def flush_held(self) -> None:
        for ros_topic, msg in list(self.held.items()):
            log(f"{ros_topic}: message {self.inj.reorder[ros_topic][0]} held for a reorder had no successor; sent last")
            self._write(ros_topic, msg)
        self.held.clear()

    def matched(self) -> dict[str, int]:
        return {t: w.get_publication_matched_status().current_count for t, w in self.writers.items()}


# ----------------------------------------------------------------------------------------
# Service client: std_srvs/srv/Trigger in rmw_cyclonedds's layout
# ----------------------------------------------------------------------------------------


def service_topics(service: str) -> tuple[str, str]:
    """ROS 2 service name -> (request, reply) DDS topic names, as rmw_cyclonedds names them
    (``/mapkeeper/save_map`` -> ``rq/mapkeeper/save_mapRequest``, ``rr/mapkeeper/save_mapReply``)."""
    base = service.strip("/")
    return f"rq/{base}Request", f"rr/{base}Reply"


class TriggerClient:
    """A std_srvs/srv/Trigger client laid out as rmw_cyclonedds's: the request header (this
    client's guid, a sequence number) leads every request and comes back in the reply."""

    def __init__(self, dp: DomainParticipant, service: str) -> None:
        self.service = service
        self.request_topic, self.reply_topic = service_topics(service)
        self.writer = DataWriter(dp, Topic(dp, self.request_topic, rt.TriggerRequest), qos=QOS_SERVICE)
        self.reader = DataReader(dp, Topic(dp, self.reply_topic, rt.TriggerResponse), qos=QOS_SERVICE)
        # rmw_cyclonedds's cdds_request_header_t.guid is the request writer's instance handle
        # (a uint64; the Python binding hands it out as a signed int64).
        self.guid = int(self.writer.get_instance_handle()) & 0xFFFF_FFFF_FFFF_FFFF
        self.seq = 0
        self._ws = WaitSet(dp)
        self._cond = ReadCondition(self.reader, SampleState.Any | ViewState.Any | InstanceState.Any)
        self._ws.attach(self._cond)

    def matched(self) -> tuple[bool, bool]:
        """(the server's request reader matched, the server's reply writer matched)."""
        return (self.writer.get_publication_matched_status().current_count > 0,
                self.reader.get_subscription_matched_status().current_count > 0)

    def call(self, match_s: float = 5.0, reply_s: float = 10.0) -> tuple[rt.TriggerResponse | None, str | None]:
        """One call: (the reply, None) or (None, why there is none)."""
        t0 = time.monotonic()
        waited = False
        while not all(self.matched()):
            if time.monotonic() - t0 > match_s:
                req_ok, rep_ok = self.matched()
                missing = ([] if req_ok else [f"no reader of {self.request_topic}"]) + (
                    [] if rep_ok else [f"no writer of {self.reply_topic}"])
                return None, (f"{self.service}: {' and '.join(missing)} matched within {match_s:g} s "
                              f"(is the node's service_layout cyclone?)")
            waited = True
            time.sleep(0.05)
        if waited:
            # Matched only just now on this side: give the server a moment to match us too, or
            # a volatile endpoint there may not take the request, or send the reply, to us.
            time.sleep(1.0)
        self.seq += 1
        req = rt.TriggerRequest(client_guid=self.guid, sequence_number=self.seq)
        try:
            self.writer.write(req)
        except Exception as e:  # noqa: BLE001 - reported as the call's failure
            return None, f"{self.service}: cannot send the request on {self.request_topic}: {e}"
        log(f"{self.service}: request sent on {self.request_topic} (header guid 0x{self.guid:016x} "
            f"seq {self.seq}; CDR {req.serialize(use_version_2=False).hex()})")
        t_sent = time.monotonic()
        ignored = 0
        while time.monotonic() - t_sent < reply_s:
            self._ws.wait(duration(milliseconds=100))
            try:
                samples = self.reader.take(N=64)
            except Exception as e:  # noqa: BLE001 - a reply this peer cannot decode is the node's fault
                return None, f"{self.service}: cannot take/decode a reply on {self.reply_topic}: {e}"
            for s in samples:
                if not (hasattr(s, "sample_info") and s.sample_info.valid_data):
                    continue
                if s.client_guid == self.guid and s.sequence_number == self.seq:
                    log(f"{self.service}: reply after {time.monotonic() - t_sent:.3f} s: success={s.success} "
                        f"message={s.message!r}")
                    return s, None
                ignored += 1
                log(f"{self.service}: ignored a reply for guid 0x{s.client_guid:016x} "
                    f"seq {s.sequence_number} (not ours)")
        return None, (f"{self.service}: no reply with our guid 0x{self.guid:016x} and sequence number "
                      f"{self.seq} on {self.reply_topic} within {reply_s:g} s ({ignored} other replies ignored)")


# ----------------------------------------------------------------------------------------
# The driver
# ----------------------------------------------------------------------------------------


def parse_initialpose(s: str) -> tuple[float, float, float]:
    try:
        x, y, yaw = (float(v) for v in s.split(","))
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"--initialpose wants X,Y,YAW, got {s!r}") from e
    return x, y, yaw


def write_result(path: Path | None, result: dict[str, Any]) -> None:
    if path is None:
        return
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(result))
    tmp.replace(path)


def build_result(pub: Publisher, rec: Recorder, inj: Injections, info: BagInfo,
                 play_seconds: float | None, extra_errors: list[str],
                 save_map: dict[str, Any] | None | bool = False) -> dict[str, Any]:
    """``save_map``: False leaves the key out (no call asked for); None or the reply's fields."""
    with rec.lock:
        result = {
            "published": dict(sorted(pub.published.items())),
            "maps_received": rec.maps_received,
            "updates_received": rec.updates_received,
            "initialposes_received": [list(p) for p in rec.initialposes],
            "final_map": rec.final_map,
            "composed_map": rec.first_map,
            "errors": list(rec.errors) + list(extra_errors),
            "bag_seconds": info.seconds,
            "play_seconds": play_seconds,
            "injections_applied": {s: inj.applied.get(s, 0) for s in inj.specs},
        }
    if save_map is not False:
        result["save_map"] = save_map
    return result


def run_driver(args: argparse.Namespace) -> int:
    bag = Path(args.bag)
    if not bag.is_file():
        raise Failure(f"--bag {bag}: no such file")
    out = Path(args.out) if args.out else None
    pose_topic = None if args.no_pose else args.pose_topic
    inj = parse_injections(args.inject, pose_topic, args.clock)
    info = bag_info(bag)
    log(f"bag {bag}: {sum(info.counts.values())} messages, {info.seconds:.2f} s, topics "
        + ", ".join(f"{t}({info.counts[t]})" for t in sorted(info.topics)))

    dp = DomainParticipant(args.domain)
    rec = Recorder(dp)  # readers before any writer, before playing
    pub = Publisher(dp, inj)
    for topic, schema in sorted(info.topics.items()):
        if schema == SCAN_T:
            pub.add(topic, rt.LaserScan, QOS_SENSOR)
        elif schema == ODOM_T:
            pub.add(topic, rt.Odometry, QOS_SENSOR)
        elif schema == TF_T and topic == "/tf_static":
            if inj.no_tf_static is None:
                pub.add(topic, rt.TFMessage, QOS_LATCHED)
        elif schema == TF_T:
            pub.add(topic, rt.TFMessage, QOS_SENSOR)
        elif schema == POSE_STAMPED_T and topic == "/truth":
            if pose_topic is not None:
                pub.add(pose_topic, rt.PoseWithCovarianceStamped, QOS_SENSOR)
        else:
            log(f"bag topic {topic} ({schema}) is not played")
    if args.clock:
        pub.add("/clock", rt.Clock, QOS_SENSOR)
    if args.initialpose is not None:
        pub.add("/initialpose", rt.PoseWithCovarianceStamped, QOS_INITIALPOSE_W)
    # The service client's endpoints exist from the start, so discovery is long over at the call.
    client = None
    if args.call_save_map is not None:
        client = TriggerClient(dp, f"/{args.call_save_map.strip('/')}/save_map")

    def fail(reason: str, play_seconds: float | None = None) -> int:
        write_result(out, build_result(pub, rec, inj, info, play_seconds, [reason]))
        log(f"FAILED: {reason}")
        return EXIT_FAIL

    # 1. The node appears.
    t_start = time.monotonic()
    while not (rec.map_publisher_matched() or rec.maps_received > 0):
        if time.monotonic() - t_start > args.wait_node_s:
            return fail(f"no /map publisher (the node) appeared on domain {args.domain} within "
                        f"{args.wait_node_s:g} s")
        time.sleep(0.05)
    log(f"node found after {time.monotonic() - t_start:.2f} s")

    # 2. Its readers match our writers (SEDP comes in a burst; stop once it is over).
    t_match = time.monotonic()
    last_change = t_match
    prev = pub.matched()
    while True:
        now = time.monotonic()
        m = pub.matched()
        if m != prev:
            prev, last_change = m, now
        if all(v > 0 for v in m.values()) or now - t_match > args.wait_match_s or now - last_change > 1.0:
            break
        time.sleep(0.05)
    unmatched = sorted(t for t, v in prev.items() if v == 0)
    if unmatched:
        log("nobody reads " + ", ".join(unmatched) + " (published anyway)")

    # 3. The initial pose, as RViz's 2D Pose Estimate.
    first_stamp_ns = None
    for _topic, _schema, _lt, decoded in iter_bag(bag):
        h = getattr(decoded, "header", None)
        if h is not None:
            first_stamp_ns = time_to_ns(h.stamp)
            break
    if first_stamp_ns is None:
        first_stamp_ns = 0
    last_clock_ns = -1
    if args.initialpose is not None:
        x, y, yaw = args.initialpose
        if args.clock:
            pub.emit("/clock", rt.Clock(clock=ns_to_time(first_stamp_ns)))
            last_clock_ns = first_stamp_ns
        pub.emit("/initialpose", make_initialpose(x, y, yaw, first_stamp_ns))
        log(f"published /initialpose {x:g},{y:g},{yaw:g}")

    # 4. Play.
    static_tf: dict[str, rt.TransformStamped] = {}
    scan_history: dict[str, deque[rt.LaserScan]] = defaultdict(lambda: deque(maxlen=11))
    scan_index = 0
    bag_index = 0
    force_clock = False
    wall0 = time.monotonic()
    t0 = None
    no_tf_static_reported = False
    for topic, schema, log_time, decoded in iter_bag(bag):
        if t0 is None:
            t0 = log_time
        bag_index += 1
        rel = max(0.0, (log_time - t0) / 1e9)
        if inj.stop_at is not None and rel > inj.stop_at[0]:
            inj.apply(inj.stop_at[1], f"bag time {rel:.3f} s > {inj.stop_at[0]:g} s: vanishing without goodbye")
            result = build_result(pub, rec, inj, info, time.monotonic() - wall0, [])
            write_result(out, result)
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(EXIT_FAIL if result["errors"] else EXIT_OK)
        delay = wall0 + rel / args.rate - time.monotonic()
        if delay > 0:
            time.sleep(delay)

        msg: Any
        out_topic = topic
        if schema == SCAN_T:
            scan_index += 1
            msg = c_scan(decoded)
            if scan_index in inj.wrong_size:
                n = len(msg.ranges)
                msg.ranges = msg.ranges[: n // 2]
                inj.apply(inj.wrong_size[scan_index], f"scan {scan_index} ({topic}): ranges cut from {n} to {n // 2}")
        elif schema == ODOM_T:
            msg = c_odom(decoded)
        elif schema == TF_T and topic == "/tf_static":
            if inj.no_tf_static is not None:
                if not no_tf_static_reported:
                    inj.apply(inj.no_tf_static, "not publishing /tf_static")
                    no_tf_static_reported = True
                continue
            for t in c_tf(decoded).transforms:
                static_tf[t.child_frame_id] = t
            msg = rt.TFMessage(transforms=list(static_tf.values()))
        elif schema == TF_T:
            msg = c_tf(decoded)
        elif schema == POSE_STAMPED_T and topic == "/truth":
            if pose_topic is None:
                continue
            msg = c_truth_as_pose(decoded)
            out_topic = pose_topic
        else:
            continue

        if args.clock:
            stamp = stamp_ns_of(msg)
            if stamp is not None and (force_clock or stamp > last_clock_ns):
                pub.emit("/clock", rt.Clock(clock=ns_to_time(stamp)))
                last_clock_ns = max(last_clock_ns, stamp)
                force_clock = False

        pub.emit(out_topic, msg)

        if schema == SCAN_T:
            scan_history[topic].append(msg)
            if scan_index in inj.stale_scan:
                hist = scan_history[topic]
                if len(hist) == 11:
                    old = hist[0]
                    pub.emit(topic, old, faults=False)
                    inj.apply(inj.stale_scan[scan_index],
                              f"after scan {scan_index} ({topic}) resent the one 10 scans older, "
                              f"stamp {stamp_ns_of(old) / 1e9:.3f} s")
                else:
                    log(f"stale-scan:{scan_index}: {topic} has fewer than 11 scans so far; not applied")
        if bag_index in inj.clock_back:
            back = max(0, last_clock_ns - 5_000_000_000)
            pub.emit("/clock", rt.Clock(clock=ns_to_time(back)))
            force_clock = True
            inj.apply(inj.clock_back[bag_index],
                      f"after message {bag_index} clock {back / 1e9:.3f} s (was {last_clock_ns / 1e9:.3f} s)")
    pub.flush_held()
    play_seconds = time.monotonic() - wall0
    t_end = pub.last_publish_at
    log(f"bag played in {play_seconds:.2f} s (bag {info.seconds:.2f} s, rate {args.rate:g}); published "
        + ", ".join(f"{t}={n}" for t, n in sorted(pub.published.items())))

    # 5. The node goes quiet.
    while True:
        now = time.monotonic()
        with rec.lock:
            map_after = rec.last_map_at > t_end
            quiet_for = now - rec.last_activity_at
        if map_after and quiet_for >= args.settle_s:
            break
        if now - t_end > args.timeout_s:
            if not map_after:
                return fail(f"no full /map arrived within {args.timeout_s:g} s after the last message "
                            f"published", play_seconds)
            return fail(f"the node did not go quiet ({args.settle_s:g} s without /map or /map_updates) "
                        f"within {args.timeout_s:g} s after the bag", play_seconds)
        time.sleep(0.05)
    rec.stop()
    rec.poll()

    never = [s for s in inj.specs if inj.applied.get(s, 0) == 0]
    extra = [f"injection {s} was never applied" for s in never]
    save_map: dict[str, Any] | None | bool = False
    if client is not None:
        reply, why = client.call(match_s=5.0, reply_s=10.0)
        if reply is None:
            save_map = None
            extra.append(str(why))
            log(f"save_map: {why}")
        else:
            save_map = {"success": bool(reply.success), "message": str(reply.message)}
    result = build_result(pub, rec, inj, info, play_seconds, extra, save_map)
    write_result(out, result)
    log(f"received {result['maps_received']} /map, {result['updates_received']} /map_updates, "
        f"{len(result['initialposes_received'])} /initialpose")
    if result["errors"]:
        log(f"FAILED: {len(result['errors'])} error(s), first: {result['errors'][0]}")
        return EXIT_FAIL
    return EXIT_OK


# ----------------------------------------------------------------------------------------
# Self-test: a fake node in another process
# ----------------------------------------------------------------------------------------

FAKE_W, FAKE_H, FAKE_RES = 120, 80, 0.05
FAKE_ORIGIN = (-3.0, -2.0, 0.1)
FAKE_POSE = (1.25, -0.5, 0.3)
FAKE_NODE_NAME = "mapkeeper"
FAKE_SAVED = "/fake/saved/map.yaml"


def run_fake_node(args: argparse.Namespace) -> int:
    """Stand-in for the mapkeeper node: serves /map and /map_updates, records what it reads."""
    bag = Path(args.bag)
    info = bag_info(bag)
    pose_topic = args.pose_topic
    mode = args.fake_node
    dp = DomainParticipant(args.domain)
    rng = random.Random(6)

    map_w = DataWriter(dp, get_topic(dp, "/map", rt.OccupancyGrid), qos=QOS_LATCHED)
    upd_w = DataWriter(dp, get_topic(dp, "/map_updates", rt.OccupancyGridUpdate), qos=QOS_UPDATES)
    ip_topic = get_topic(dp, "/initialpose", rt.PoseWithCovarianceStamped)
    ip_w = DataWriter(dp, ip_topic, qos=QOS_INITIALPOSE_W)
    reader_qos = Qos(_RELIABLE, Policy.Durability.Volatile, Policy.History.KeepLast(1000), _XCDR1)
    readers: dict[str, DataReader] = {}
    for t in info.scan_topics:
        readers[t] = DataReader(dp, get_topic(dp, t, rt.LaserScan), qos=reader_qos)
    readers["/odom"] = DataReader(dp, get_topic(dp, "/odom", rt.Odometry), qos=reader_qos)
    readers["/tf"] = DataReader(dp, get_topic(dp, "/tf", rt.TFMessage), qos=reader_qos)
    readers["/tf_static"] = DataReader(dp, get_topic(dp, "/tf_static", rt.TFMessage),
                                       qos=QOS_LATCHED)
    readers[pose_topic] = DataReader(dp, get_topic(dp, pose_topic, rt.PoseWithCovarianceStamped),
                                     qos=reader_qos)
    readers["/clock"] = DataReader(dp, get_topic(dp, "/clock", rt.Clock), qos=reader_qos)
    readers["/initialpose"] = DataReader(dp, ip_topic, qos=QOS_INITIALPOSE_R)
    # /mapkeeper/save_map, rmw_cyclonedds layout: replies first to other clients (a wrong
    # sequence number, a wrong guid), then (mode clean only) to the caller.
    rq_name, rr_name = service_topics(f"/{FAKE_NODE_NAME}/save_map")
    save_r = DataReader(dp, Topic(dp, rq_name, rt.TriggerRequest), qos=QOS_SERVICE)
    save_w = DataWriter(dp, Topic(dp, rr_name, rt.TriggerResponse), qos=QOS_SERVICE)
    save_requests: list[list[int]] = []
    ws = WaitSet(dp)
    conds = [ReadCondition(r, SampleState.Any | ViewState.Any | InstanceState.Any)
             for r in [*readers.values(), save_r]]
    for c in conds:
        ws.attach(c)

    grid = [-1] * (FAKE_W * FAKE_H)

    def full_map() -> rt.OccupancyGrid:
        ox, oy, oyaw = FAKE_ORIGIN
        return rt.OccupancyGrid(
            header=rt.Header(stamp=rt.Time(), frame_id="map"),
            info=rt.MapMetaData(resolution=FAKE_RES, width=FAKE_W, height=FAKE_H,
                                origin=rt.Pose(position=rt.Point(x=ox, y=oy), orientation=quat_of_yaw(oyaw))),
            data=list(grid),
        )

    map_w.write(full_map())
    maps_sent = 1
    updates_sent = 0

    # What it saw.
    stamps: dict[str, list[int]] = defaultdict(list)
    scan_lengths: dict[str, list[int]] = defaultdict(list)
    clocks: list[int] = []
    tf_static_frames: list[list[str]] = []
    poses: list[list[float]] = []
    initialposes: list[list[float]] = []
    scans_seen = 0
    # Exactness: compare with the bag.
    truth: dict[int, tuple[float, ...]] = {}
    first_scans: dict[str, tuple[int, list[float]]] = {}
    for topic, schema, _lt, d in iter_bag(bag):
        if topic == "/truth":
            p = d.pose
            truth[time_to_ns(d.header.stamp)] = (p.position.x, p.position.y, p.position.z, p.orientation.x,
                                                 p.orientation.y, p.orientation.z, p.orientation.w)
        elif schema == SCAN_T and topic not in first_scans:
            first_scans[topic] = (time_to_ns(d.header.stamp), list(d.ranges))
    pose_mismatches = 0
    scan_exact: dict[str, bool] = {}

    t_begin = time.monotonic()
    last_data = None
    final_sent_at = None
    gone_at = None
    while True:
        ws.wait(duration(milliseconds=50))
        now = time.monotonic()
        for q in save_r.take(N=16):
            if not (hasattr(q, "sample_info") and q.sample_info.valid_data):
                continue
            g, n = int(q.client_guid), int(q.sequence_number)
            save_requests.append([g, n, int(q.structure_needs_at_least_one_member)])
            save_w.write(rt.TriggerResponse(client_guid=g, sequence_number=n + 1, success=True, message="decoy seq"))
            save_w.write(rt.TriggerResponse(client_guid=g ^ 1, sequence_number=n, success=True, message="decoy guid"))
            if mode == "clean":
                save_w.write(rt.TriggerResponse(client_guid=g, sequence_number=n, success=True, message=FAKE_SAVED))
        got = False
        for t, r in readers.items():
            for s in r.take(N=500):
                if not (hasattr(s, "sample_info") and s.sample_info.valid_data):
                    continue
                got = True
                if t == "/clock":
                    clocks.append(time_to_ns(s.clock))
                    continue
                if t == "/initialpose":
                    pp = s.pose.pose
                    initialposes.append([pp.position.x, pp.position.y, yaw_of(pp.orientation)])
                    continue
                stamps[t].append(stamp_ns_of(s) or 0)
                if t == "/tf_static":
                    tf_static_frames.append(sorted(x.child_frame_id for x in s.transforms))
                elif t == pose_topic:
                    p = s.pose.pose
                    vals = (p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
                            p.orientation.z, p.orientation.w)
                    poses.append(list(vals))
                    if truth.get(time_to_ns(s.header.stamp)) != vals or any(s.pose.covariance):
                        pose_mismatches += 1
                elif t in info.scan_topics:
                    scans_seen += 1
                    scan_lengths[t].append(len(s.ranges))
                    st = time_to_ns(s.header.stamp)
                    if first_scans.get(t, (None,))[0] == st and t not in scan_exact:
                        scan_exact[t] = list(s.ranges) == first_scans[t][1]
                    if scans_seen == 10:
                        x, y, yaw = FAKE_POSE
                        ip_w.write(make_initialpose(x, y, yaw, st))
                    if scans_seen % 20 == 0:
                        updates_sent += 1
                        w, h = rng.randint(1, 30), rng.randint(1, 20)
                        ux, uy = rng.randint(0, FAKE_W - w), rng.randint(0, FAKE_H - h)
                        if mode == "oob" and updates_sent == 3:
                            ux, w = FAKE_W - 2, 5  # sticks out of the grid on the right
                        data = [rng.choice((-1, 0, 100)) for _ in range(w * h)]
                        upd_w.write(rt.OccupancyGridUpdate(header=rt.Header(frame_id="map"), x=ux, y=uy,
                                                           width=w, height=h, data=data))
                        if ux + w <= FAKE_W:
                            for row in range(h):
                                at = (uy + row) * FAKE_W + ux
                                grid[at:at + w] = data[row * w:(row + 1) * w]
        if got:
            last_data = now
        if final_sent_at is None and last_data is not None and now - last_data > 1.0:
            map_w.write(full_map())
            maps_sent += 1
            final_sent_at = now
        if final_sent_at is not None:
            # The driver is gone once its writers no longer match (goodbye, or lease expiry).
            matched = sum(r.get_subscription_matched_status().current_count for r in readers.values())
            if matched == 0:
                gone_at = time.time()
                break
            if now - final_sent_at > 20.0:
                break
        if now - t_begin > args.timeout_s + info.seconds + 60:
            break
    report = {
        "stamps": stamps,
        "scan_lengths": scan_lengths,
        "clocks": clocks,
        "tf_static_frames": tf_static_frames,
        "pose_count": len(poses),
        "pose_mismatches": pose_mismatches,
        "scan_exact": scan_exact,
        "initialposes": initialposes,
        "maps_sent": maps_sent,
        "updates_sent": updates_sent,
        "grid": grid,
        "driver_gone_at": gone_at,
        "save_requests": save_requests,
    }
    write_result(Path(args.out), report)
    return EXIT_OK


@dataclass
class Check:
    name: str
    ok: bool
    detail: str = ""


def _run_pair(script: Path, bag: Path, domain: int, tmp: Path, name: str, driver_args: list[str],
              fake_mode: str | None, pose_topic: str = "/amcl_pose",
              timeout: float = 300.0) -> tuple[int, dict[str, Any], dict[str, Any], str, float]:
    """Runs the fake node (unless fake_mode is None) and the driver; returns
    (driver exit code, driver JSON, fake node JSON, driver stderr, driver wall seconds)."""
    d_out, f_out = tmp / f"{name}.driver.json", tmp / f"{name}.fake.json"
    fake = None
    if fake_mode is not None:
        fake = subprocess.Popen(
            [sys.executable, str(script), "--fake-node", fake_mode, "--bag", str(bag), "--domain", str(domain),
             "--out", str(f_out), "--pose-topic", pose_topic, "--timeout-s", "30"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        time.sleep(0.5)
    t0 = time.monotonic()
    drv = subprocess.run([sys.executable, str(script), "--bag", str(bag), "--domain", str(domain),
                          "--out", str(d_out), *driver_args],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, timeout=timeout,
                         check=False)
    wall = time.monotonic() - t0
    driver_exit_at = time.time()
    fake_json: dict[str, Any] = {}
    if fake is not None:
        try:
            _, ferr = fake.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            fake.kill()
            _, ferr = fake.communicate()
        if fake.returncode != 0:
            print(f"[{name}] fake node exit {fake.returncode}: {ferr.strip()[-2000:]}", file=sys.stderr)
        if f_out.exists():
            fake_json = json.loads(f_out.read_text())
            gone = fake_json.get("driver_gone_at")
            fake_json["driver_gone_after_s"] = None if gone is None else gone - driver_exit_at
    drv_json = json.loads(d_out.read_text()) if d_out.exists() else {}
    with (tmp / f"{name}.driver.stderr").open("w") as f:
        f.write(drv.stderr)
    return drv.returncode, drv_json, fake_json, drv.stderr, wall


def run_selftest(args: argparse.Namespace) -> int:
    script = Path(__file__).resolve()
    bag = Path(args.bag)
    info = bag_info(bag)
    checks: list[Check] = []

    def check(name: str, ok: bool, detail: str = "") -> None:
        checks.append(Check(name, bool(ok), detail))
        print(f"{'PASS' if ok else 'FAIL'} {name}{': ' + detail if detail else ''}", flush=True)

    expected_pub = {("/amcl_pose" if t == "/truth" else t): n for t, n in info.counts.items()}
    tmp = Path(tempfile.mkdtemp(prefix="drive-selftest-"))
    print(f"selftest: bag {bag} ({info.seconds:.2f} s), work dir {tmp}", flush=True)
    base = args.domain

    # 0. The service layout, byte for byte (rmw_cyclonedds: uint64 guid, int64 seq, then the fields).
    req = rt.TriggerRequest(client_guid=0xF1E2D3C4B5A69788, sequence_number=1).serialize(use_version_2=False)
    check("layout: Trigger request CDR", req.hex() == "00010000" "8897a6b5c4d3e2f1" "0100000000000000" "00", req.hex())
    rep = rt.TriggerResponse(client_guid=0xF1E2D3C4B5A69788, sequence_number=1, success=True,
                             message="ab").serialize(use_version_2=False)
    check("layout: Trigger response CDR",
          rep.hex() == "00010000" "8897a6b5c4d3e2f1" "0100000000000000" "01000000" "03000000" "616200", rep.hex())

    # A. Clean run at --rate: counts, exact data, composition, real rate.
    rc, d, f, err, _ = _run_pair(script, bag, base, tmp, "clean",
                                 ["--rate", str(args.rate), "--call-save-map", FAKE_NODE_NAME], "clean")
    check("clean: exit 0", rc == 0, err.strip().splitlines()[-1] if err.strip() else "")
    check("clean: published counts equal the bag's", d.get("published") == expected_pub,
          f"{d.get('published')} vs {expected_pub}")
    recv = {t: len(v) for t, v in f.get("stamps", {}).items()}
    want_recv = {t: n for t, n in expected_pub.items() if t != "/tf_static"}
    check("clean: the fake node received every message", all(recv.get(t) == n for t, n in want_recv.items()),
          f"{recv}")
    check("clean: the /tf_static reader (transient local) holds all mounts",
          bool(f.get("tf_static_frames")) and f["tf_static_frames"][-1] == sorted(
              f"lidar_{t.split('_')[1].split('/')[0]}" for t in info.scan_topics),
          f"{f.get('tf_static_frames')}")
    check("clean: pose floats identical to /truth, covariance zero",
          f.get("pose_count") == info.counts["/truth"] and f.get("pose_mismatches") == 0,
          f"{f.get('pose_count')} poses, {f.get('pose_mismatches')} mismatches")
    check("clean: first scan of each lidar identical to the bag",
          f.get("scan_exact") and all(f["scan_exact"].get(t) for t in info.scan_topics), f"{f.get('scan_exact')}")
    stamps_sorted = all(v == sorted(v) for v in f.get("stamps", {}).values())
    check("clean: messages arrived in bag order", stamps_sorted)
    cm, fm = d.get("composed_map") or {}, d.get("final_map") or {}
    check("clean: composed_map == final_map == the fake node's grid",
          bool(cm) and cm.get("data") == fm.get("data") == f.get("grid") and cm.get("width") == FAKE_W
          and cm.get("height") == FAKE_H,
          f"{d.get('updates_received')} updates, {d.get('maps_received')} maps")
    check("clean: grid metadata", bool(fm) and abs(fm["resolution"] - FAKE_RES) < 1e-6
          and all(abs(a - b) < 1e-9 for a, b in zip(fm["origin"], FAKE_ORIGIN)), f"{fm.get('origin')}")
    check("clean: every update and map counted",
          d.get("updates_received") == f.get("updates_sent") and d.get("maps_received") == f.get("maps_sent"),
          f"updates {d.get('updates_received')}/{f.get('updates_sent')}, "
          f"maps {d.get('maps_received')}/{f.get('maps_sent')}")
    got_ip = d.get("initialposes_received") or []
    check("clean: the node's /initialpose recorded",
          len(got_ip) == 1 and all(abs(a - b) < 1e-9 for a, b in zip(got_ip[0], FAKE_POSE)), f"{got_ip}")
    want = info.seconds / args.rate
    ps = d.get("play_seconds") or 0.0
    check(f"clean: real rate (bag {info.seconds:.2f} s at rate {args.rate:g})",
          abs(ps - want) <= 0.05 * want + 0.3, f"played in {ps:.2f} s, want {want:.2f} s")
    check("clean: save_map reply recorded", d.get("save_map") == {"success": True, "message": FAKE_SAVED},
          f"{d.get('save_map')}")
    sreq = f.get("save_requests") or []
    check("clean: one save_map request, header guid != 0 and seq 1, placeholder byte 0",
          len(sreq) == 1 and sreq[0][0] != 0 and sreq[0][1:] == [1, 0], f"{sreq}")
    check("clean: the two replies to other clients ignored", err.count("(not ours)") == 2)
    check("clean: the driver said goodbye at exit (the fake node saw it leave within 1 s)",
          f.get("driver_gone_after_s") is not None and f["driver_gone_after_s"] < 1.0,
          f"{f.get('driver_gone_after_s')}")

    # B. Faults at rate 10, with /clock and /initialpose.
    injections = ["drop:/odom:10", "reorder:/lidar_0/scan:5", "stale-scan:40", "wrong-size:7",
                  "clock-back:1500", "no-tf-static", "drop:/truth:100"]
    dargs = ["--rate", "10", "--clock", "--initialpose", "1,2,0.5"]
    for s in injections:
        dargs += ["--inject", s]
    rc, d, f, err, _ = _run_pair(script, bag, base + 1, tmp, "faults", dargs, "clean")
    check("faults: exit 0, every injection applied",
          rc == 0 and all(v > 0 for v in d.get("injections_applied", {}).values()), f"{d.get('injections_applied')}")
    check("faults: each injection printed", all(f"inject {s}:" in err for s in injections))
    st = f.get("stamps", {})
    n_odom = info.counts["/odom"]
    check("faults: drop:/odom:10", len(st.get("/odom", [])) == n_odom - n_odom // 10,
          f"{len(st.get('/odom', []))}")
    check("faults: drop:/truth:100 (pose topic)",
          len(st.get("/amcl_pose", [])) == info.counts["/truth"] - info.counts["/truth"] // 100)
    l0 = st.get("/lidar_0/scan", [])
    check("faults: reorder:/lidar_0/scan:5", len(l0) > 6 and l0[4] > l0[5] and l0[3] < l0[5] and l0[4] < l0[6],
          f"{l0[:8]}")
    all_scans = sorted(s for t in info.scan_topics for s in st.get(t, []))
    backs = [(t, i) for t in info.scan_topics for i, (a, b) in enumerate(itertools.pairwise(st.get(t, [])))
             if b < a and not (t == "/lidar_0/scan" and i == 4)]
    check("faults: stale-scan:40 (one stamp 10 scans back)", len(backs) == 1 and len(all_scans) ==
          sum(info.counts[t] for t in info.scan_topics) + 1, f"{backs}")
    lens = [n for t in info.scan_topics for n in f.get("scan_lengths", {}).get(t, [])]
    full = max(lens) if lens else 0
    check("faults: wrong-size:7 (exactly one scan with half the ranges)", lens.count(full // 2) == 1,
          f"{Counter(lens)}")
    clocks = f.get("clocks", [])
    drops = [(a, b) for a, b in itertools.pairwise(clocks) if b < a]
    check("faults: clock-back:1500 (one 5 s step back)", len(drops) == 1 and drops[0][0] - drops[0][1] == 5_000_000_000,
          f"{drops}")
    check("faults: no-tf-static", not st.get("/tf_static") and "/tf_static" not in d.get("published", {}))
    check("faults: the fake node got our /initialpose 1,2,0.5 with RViz covariance",
          len(f.get("initialposes", [])) == 1
          and all(abs(a - b) < 1e-12 for a, b in zip(f["initialposes"][0], (1.0, 2.0, 0.5))),
          f"{f.get('initialposes')}")
    check("faults: our own /initialpose not recorded as received", len(d.get("initialposes_received", [])) == 1)
    check("faults: rate 10", abs((d.get("play_seconds") or 0) - info.seconds / 10) <= 0.05 * info.seconds / 10 + 0.3,
          f"{d.get('play_seconds')}")
    check("faults: no save_map key without --call-save-map", "save_map" not in d)

    # C. An update outside the grid: an error, exit 2.  Its save_map server answers other
    # clients only: no reply for us within 10 s, an error, save_map null.
    rc, d, f, err, _ = _run_pair(script, bag, base + 2, tmp, "oob",
                                 ["--rate", "20", "--call-save-map", FAKE_NODE_NAME], "oob")
    errs = d.get("errors", [])
    check("oob: exit 2 with the update recorded as outside the grid",
          rc == 2 and any("outside" in e for e in errs) and "outside" in err, f"rc={rc} {errs}")
    check("oob: save_map null and 'no reply' in errors when only other clients are answered",
          "save_map" in d and d["save_map"] is None
          and any("no reply with our guid" in e and "2 other replies ignored" in e for e in errs), f"{errs}")

    # D. stop-at: vanishes without goodbye.
    rc, d, f, err, wall = _run_pair(script, bag, base + 3, tmp, "stop", ["--rate", "10", "--inject", "stop-at:5"],
                                    "clean")
    n = d.get("published", {}).get("/odom", 0)
    check("stop: exit 0, only the first 5 s of the bag published",
          rc == 0 and abs(n - 5.0 / info.seconds * n_odom) <= 2,
          f"rc={rc} /odom={n}")
    check("stop: no goodbye (the fake node saw the driver leave only through its lease)",
          f.get("driver_gone_after_s") is not None and f["driver_gone_after_s"] > 3.0,
          f"{f.get('driver_gone_after_s')}")

    # E. No node.
    rc, d, f, err, wall = _run_pair(script, bag, base + 4, tmp, "nonode", ["--wait-node-s", "2"], None)
    check("nonode: exit 2 within the wait with a clear reason",
          rc == 2 and "no /map publisher" in err and wall < 10, f"rc={rc} {wall:.1f} s")

    passed = sum(c.ok for c in checks)
    failed = len(checks) - passed
    print(f"selftest: {passed} passed, {failed} failed", flush=True)
    return EXIT_OK if failed == 0 else EXIT_FAIL


# ----------------------------------------------------------------------------------------
# Command line
# ----------------------------------------------------------------------------------------


def parse_args(argv: list[str]) -> argparse.Namespace:
    # `--initialpose -1.5,2,0` would read as an option to argparse: glue the value on.
    glued: list[str] = []
    it = iter(argv)
    for a in it:
        if a == "--initialpose":
            v = next(it, None)
            glued.append(a if v is None else f"--initialpose={v}")
        else:
            glued.append(a)
    argv = glued
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bag", required=True, help="MCAP file to play")
    p.add_argument("--out", help="where to write the result JSON")
    p.add_argument("--domain", type=int, default=0, help="DDS domain id (default 0)")
    p.add_argument("--rate", type=float, default=1.0, help="speed factor (default 1.0: real time)")
    p.add_argument("--pose-topic", default="/amcl_pose", help="where /truth goes (default /amcl_pose)")
    p.add_argument("--no-pose", action="store_true", help="do not publish /truth at all")
    p.add_argument("--clock", action="store_true", help="publish /clock (sim time) before each message")
    p.add_argument("--initialpose", type=parse_initialpose, metavar="X,Y,YAW",
                   help="publish this /initialpose before playing")
    p.add_argument("--inject", action="append", default=[], metavar="SPEC", help="fault injection (repeatable)")
    p.add_argument("--call-save-map", metavar="NODE_NAME",
                   help="once the node is quiet, call /NODE_NAME/save_map (rmw_cyclonedds layout)")
    p.add_argument("--wait-node-s", type=float, default=20.0, help="how long to wait for the node (default 20)")
    p.add_argument("--wait-match-s", type=float, default=5.0,
                   help="how long to wait for the node's readers to match (default 5)")
    p.add_argument("--settle-s", type=float, default=3.0, help="quiet time that ends the run (default 3)")
    p.add_argument("--timeout-s", type=float, default=60.0, help="max wait after the bag (default 60)")
    p.add_argument("--selftest", action="store_true", help="test this script against a fake node")
    p.add_argument("--fake-node", choices=("clean", "oob"), help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if not a.rate > 0:
        p.error("--rate must be > 0")
    if not a.pose_topic.startswith("/"):
        a.pose_topic = "/" + a.pose_topic
    try:
        parse_injections(a.inject, None if a.no_pose else a.pose_topic, a.clock)
    except argparse.ArgumentTypeError as e:
        p.error(str(e))
    if not (a.selftest or a.fake_node) and not a.out:
        p.error("--out is required")
    if a.call_save_map is not None and not a.call_save_map.strip("/"):
        p.error("--call-save-map wants a node name")
    return a


def main(argv: list[str] | None = None) -> int:
    args = parse_args(sys.argv[1:] if argv is None else argv)
    try:
        if args.fake_node:
            return run_fake_node(args)
        if args.selftest:
            return run_selftest(args)
        return run_driver(args)
    except Failure as e:
        log(f"FAILED: {e}")
        return EXIT_FAIL
    except KeyboardInterrupt:
        log("FAILED: interrupted")
        return EXIT_FAIL


if __name__ == "__main__":
    sys.exit(main())
