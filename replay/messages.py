"""ROS 2 message types in memory: the rosbags type store, navlog's own types, and small builders.

Messages are the type store's dataclasses; they become CDR bytes only at the log boundary.
Time is integer nanoseconds everywhere; ``stamp(ns)`` and ``to_ns(stamp)`` convert.
"""

from __future__ import annotations

import sys
from functools import cache, lru_cache
from types import SimpleNamespace
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

# re-exported for the message builders' callers; the implementations live in navlog.replay.geometry
from navlog.replay.geometry import make_transform as make_transform
from navlog.replay.geometry import matrix_to_quat as matrix_to_quat
from navlog.replay.geometry import quat_from_rpy as quat_from_rpy
from navlog.replay.geometry import quat_from_yaw as quat_from_yaw
from navlog.replay.geometry import quat_to_matrix as quat_to_matrix
from navlog.replay.geometry import yaw_from_quat as yaw_from_quat

# navlog's own message types. Their definitions travel in the MCAP schema of every log that uses them.
EVENT_TYPE = "navlog_msgs/msg/Event"
EVENT_MSG = """\
# A navigation event: goal accepted, reached, failed, recovery, collision-monitor action, ...
std_msgs/Header header
string kind
string source
string detail
float64 value
"""

NAVLOG_TYPES = {EVENT_TYPE: EVENT_MSG}

# Topic names and types that Nav2 / ROS 2 users expect.
CLOCK = "rosgraph_msgs/msg/Clock"
LASER_SCAN = "sensor_msgs/msg/LaserScan"
POINT_CLOUD2 = "sensor_msgs/msg/PointCloud2"
POINT_FIELD = "sensor_msgs/msg/PointField"
IMU = "sensor_msgs/msg/Imu"
ODOMETRY = "nav_msgs/msg/Odometry"
PATH = "nav_msgs/msg/Path"
OCCUPANCY_GRID = "nav_msgs/msg/OccupancyGrid"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
TWIST = "geometry_msgs/msg/Twist"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TRANSFORM_STAMPED = "geometry_msgs/msg/TransformStamped"

# QoS profiles as rosbag2 stores them in `offered_qos_profiles` (version 8 YAML form).
_QOS = """- history: 3
  depth: 0
  reliability: 1
  durability: {durability}
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: 1
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false
"""
QOS_VOLATILE = _QOS.format(durability=2)
QOS_TRANSIENT_LOCAL = _QOS.format(durability=1)
LATCHED_TOPICS = ("/tf_static", "/map")


def qos_for(topic: str) -> str:
    """Offered QoS YAML for a topic: transient-local for latched topics, volatile otherwise."""
    return QOS_TRANSIENT_LOCAL if topic in LATCHED_TOPICS else QOS_VOLATILE


def new_typestore():
    """A new type store of the ROS 2 types (Humble = Jazzy for the common types) and navlog's own.

    A log reader that meets types the shared store lacks registers them into one of these.
    """
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in NAVLOG_TYPES.items():
        store.register(get_types_from_msg(text, name))
    return store


@lru_cache(maxsize=1)
def typestore():
    """The shared base type store (``new_typestore()``, made once): never register anything into it.

    Builders, writers and ``serialize``/``deserialize`` use it; a log's own types go into a reader's
    own store (``navlog.replay.io.typestore``), so one log's definitions never reach another.
    """
    return new_typestore()


def msgdef(typename: str) -> str:
    """The `ros2msg` schema text of a type: root definition plus one section per dependency."""
    return typestore().generate_msgdef(typename, ros_version=2)[0]


_LITTLE = sys.byteorder == "little"


@cache
def _cdr_functions(typename: str):
    """The type store's generated (size, serialize) functions of a type, looked up once."""
    md = typestore().get_msgdef(typename)
    return md.getsize_cdr, (md.serialize_cdr_le if _LITTLE else md.serialize_cdr_be)


def serialize(msg: Any, typename: str) -> bytes:
    """CDR bytes (4-byte encapsulation header, native byte order), as ``Typestore.serialize_cdr`` makes them."""
    return bytes(serialize_buffer(msg, typename))


def serialize_buffer(msg: Any, typename: str) -> bytearray:
    """``serialize`` into a new bytearray, without the copy into immutable bytes (for writers).

    The type store's generated functions are called directly, which saves the per-call lookups of
    ``serialize_cdr`` on the recording hot path; the bytes are the same.
    """
    getsize, write = _cdr_functions(typename)
    store = typestore()
    size = 4 + getsize(0, msg, store)
    raw = bytearray(size)
    raw[1] = _LITTLE
    if write(memoryview(raw)[4:], 0, msg, store) + 4 != size:
        raise ValueError(f"CDR size mismatch serializing {typename}")
    return raw


def deserialize(data: bytes, typename: str) -> Any:
    return typestore().deserialize_cdr(data, typename)


@cache
def msg_class(typename: str):
    return typestore().types[typename]


@lru_cache(maxsize=1)
def _types() -> SimpleNamespace:
    """The message classes the builders use, looked up once."""
    c = msg_class
    return SimpleNamespace(
        Time=c("builtin_interfaces/msg/Time"),
        Header=c("std_msgs/msg/Header"),
        Vector3=c("geometry_msgs/msg/Vector3"),
        Quaternion=c("geometry_msgs/msg/Quaternion"),
        Point=c("geometry_msgs/msg/Point"),
        Pose=c("geometry_msgs/msg/Pose"),
        Transform=c("geometry_msgs/msg/Transform"),
        TransformStamped=c(TRANSFORM_STAMPED),
        TFMessage=c(TF_MESSAGE),
        Twist=c(TWIST),
        Clock=c(CLOCK),
        PoseWithCovariance=c("geometry_msgs/msg/PoseWithCovariance"),
        TwistWithCovariance=c("geometry_msgs/msg/TwistWithCovariance"),
        Odometry=c(ODOMETRY),
        Event=c(EVENT_TYPE),
    )


# ---------------------------------------------------------------- builders


def f32(x: float) -> float:
    """A value as a float32 field holds it: live messages must equal what a log gives back."""
    return float(np.float32(x))


def stamp(ns: int):
    """builtin_interfaces/Time from integer nanoseconds."""
    return _types().Time(int(ns // 1_000_000_000), int(ns % 1_000_000_000))


def to_ns(t: Any) -> int:
    """Integer nanoseconds from a builtin_interfaces/Time."""
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


def header(ns: int, frame_id: str):
    T = _types()
    return T.Header(T.Time(int(ns // 1_000_000_000), int(ns % 1_000_000_000)), frame_id)


def vector3(x: float, y: float, z: float):
    return _types().Vector3(float(x), float(y), float(z))


def quaternion(q_xyzw) -> Any:
    x, y, z, w = q_xyzw
    return _types().Quaternion(float(x), float(y), float(z), float(w))


def pose(xyz, q_xyzw):
    T = _types()
    x, y, z, w = q_xyzw
    return T.Pose(
        T.Point(float(xyz[0]), float(xyz[1]), float(xyz[2])), T.Quaternion(float(x), float(y), float(z), float(w))
    )


def transform_stamped(ns: int, parent: str, child: str, xyz, q_xyzw):
    T = _types()
    tx, ty, tz = xyz
    x, y, z, w = q_xyzw
    return T.TransformStamped(
        header(ns, parent),
        child,
        T.Transform(T.Vector3(float(tx), float(ty), float(tz)), T.Quaternion(float(x), float(y), float(z), float(w))),
    )


class TFTransforms:
    """A tf2_msgs/TFMessage in its light form: ``entries``, one tuple per transform, ``(parent, child,
    stamp_ns, tx, ty, tz, qx, qy, qz, qw)`` with the frame ids as sent. A log reader gives it, instead of
    message objects, to the subscribers that accept it (``Node.subscribe(..., light=True)``): a TF
    buffer needs the numbers, not six objects per transform."""

    __slots__ = ("entries",)

    def __init__(self, entries: list[tuple]) -> None:
        self.entries = entries


def tf_entries(msg: Any) -> list[tuple]:
    """The transforms of a TFMessage, light (``TFTransforms``) or message object, as ``TFTransforms`` tuples."""
    if type(msg) is TFTransforms:
        return msg.entries
    out = []
    for ts in msg.transforms:
        tr, rot, st = ts.transform.translation, ts.transform.rotation, ts.header.stamp
        out.append(
            (
                ts.header.frame_id,
                ts.child_frame_id,
                int(st.sec) * 1_000_000_000 + int(st.nanosec),
                tr.x,
                tr.y,
                tr.z,
                rot.x,
                rot.y,
                rot.z,
                rot.w,
            )
        )
    return out


def tf_message(transforms: list) -> Any:
    return _types().TFMessage(list(transforms))


def twist(vx: float, vy: float, wz: float):
    T = _types()
    return T.Twist(T.Vector3(float(vx), float(vy), 0.0), T.Vector3(0.0, 0.0, float(wz)))


def twist_values(msg: Any) -> tuple[float, float, float]:
    """(vx, vy, wz) from a Twist or a TwistStamped."""
    tw = msg.twist if hasattr(msg, "twist") else msg
    return float(tw.linear.x), float(tw.linear.y), float(tw.angular.z)


def clock(ns: int):
    T = _types()
    return T.Clock(T.Time(int(ns // 1_000_000_000), int(ns % 1_000_000_000)))


def odometry(ns: int, frame: str, child: str, xyz, q_xyzw, lin, ang, pose_cov=None, twist_cov=None):
    T = _types()
    pc = np.zeros(36) if pose_cov is None else np.asarray(pose_cov, dtype=np.float64)
    tc = np.zeros(36) if twist_cov is None else np.asarray(twist_cov, dtype=np.float64)
    lx, ly, lz = lin
    ax, ay, az = ang
    return T.Odometry(
        header(ns, frame),
        child,
        T.PoseWithCovariance(pose(xyz, q_xyzw), pc),
        T.TwistWithCovariance(
            T.Twist(T.Vector3(float(lx), float(ly), float(lz)), T.Vector3(float(ax), float(ay), float(az))), tc
        ),
    )


def event(ns: int, kind: str, source: str, detail: str = "", value: float = 0.0):
    return _types().Event(header(ns, ""), kind, source, detail, float(value))
