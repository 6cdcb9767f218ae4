"""ROS 2 message types in memory: the rosbags type store, navlog's own types, and small builders.

Messages are the type store's dataclasses; they become CDR bytes only at the log boundary.
Time is integer nanoseconds everywhere; ``stamp(ns)`` and ``to_ns(stamp)`` convert.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Iterator, MutableMapping
from functools import cache, lru_cache
from types import SimpleNamespace
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

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
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
POSE_WITH_COVARIANCE_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
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
# Nav2's costmap publishers (Costmap2DPublisher: ``costmap``, ``costmap_raw``, ``costmap_updates``) offer
# QoS(1).transient_local().reliable(), as map_server does for /map: RViz's Nav2 view subscribes so
LATCHED_SUFFIXES = ("/costmap", "/costmap_raw", "/costmap_updates")


def is_latched(topic: str) -> bool:
    """True for a topic its ROS 2 publisher offers transient-local: /tf_static, /map, Nav2's costmaps."""
    return topic in LATCHED_TOPICS or topic.endswith(LATCHED_SUFFIXES)


def qos_for(topic: str) -> str:
    """Offered QoS YAML for a topic: transient-local for latched topics (``is_latched``), volatile otherwise."""
    return QOS_TRANSIENT_LOCAL if is_latched(topic) else QOS_VOLATILE


# The ROS 2 (Humble) definitions of the types navlog writes and reads and of the types they use, as
# rosbags' Humble store defines them (tested equal, schema text included). A type store starts with
# these and navlog's own: making them takes ~20 ms, where rosbags' Humble store takes ~110 ms of
# imports (its module chain defines every type of five ROS 2 releases). Any other type loads the
# Humble store the first time it is asked for.
BASE_TYPES = {
    "builtin_interfaces/msg/Time": """\
int32 sec
uint32 nanosec
""",
    "rosgraph_msgs/msg/Clock": """\
builtin_interfaces/Time clock
""",
    "std_msgs/msg/Header": """\
builtin_interfaces/Time stamp
string frame_id
""",
    "sensor_msgs/msg/LaserScan": """\
std_msgs/Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities
""",
    "sensor_msgs/msg/PointField": """\
uint8 INT8=1
uint8 UINT8=2
uint8 INT16=3
uint8 UINT16=4
uint8 INT32=5
uint8 UINT32=6
uint8 FLOAT32=7
uint8 FLOAT64=8
string name
uint32 offset
uint8 datatype
uint32 count
""",
    "sensor_msgs/msg/PointCloud2": """\
std_msgs/Header header
uint32 height
uint32 width
sensor_msgs/PointField[] fields
bool is_bigendian
uint32 point_step
uint32 row_step
uint8[] data
bool is_dense
""",
    "geometry_msgs/msg/Quaternion": """\
float64 x
float64 y
float64 z
float64 w
""",
    "geometry_msgs/msg/Vector3": """\
float64 x
float64 y
float64 z
""",
    "sensor_msgs/msg/Imu": """\
std_msgs/Header header
geometry_msgs/Quaternion orientation
float64[9] orientation_covariance
geometry_msgs/Vector3 angular_velocity
float64[9] angular_velocity_covariance
geometry_msgs/Vector3 linear_acceleration
float64[9] linear_acceleration_covariance
""",
    "geometry_msgs/msg/Point": """\
float64 x
float64 y
float64 z
""",
    "geometry_msgs/msg/Pose": """\
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
""",
    "geometry_msgs/msg/PoseWithCovariance": """\
geometry_msgs/Pose pose
float64[36] covariance
""",
    "geometry_msgs/msg/Twist": """\
geometry_msgs/Vector3 linear
geometry_msgs/Vector3 angular
""",
    "geometry_msgs/msg/TwistWithCovariance": """\
geometry_msgs/Twist twist
float64[36] covariance
""",
    "nav_msgs/msg/Odometry": """\
std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
""",
    "geometry_msgs/msg/PoseStamped": """\
std_msgs/Header header
geometry_msgs/Pose pose
""",
    "nav_msgs/msg/Path": """\
std_msgs/Header header
geometry_msgs/PoseStamped[] poses
""",
    "nav_msgs/msg/MapMetaData": """\
builtin_interfaces/Time map_load_time
float32 resolution
uint32 width
uint32 height
geometry_msgs/Pose origin
""",
    "nav_msgs/msg/OccupancyGrid": """\
std_msgs/Header header
nav_msgs/MapMetaData info
int8[] data
""",
    "geometry_msgs/msg/Transform": """\
geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation
""",
    "geometry_msgs/msg/TransformStamped": """\
std_msgs/Header header
string child_frame_id
geometry_msgs/Transform transform
""",
    "tf2_msgs/msg/TFMessage": """\
geometry_msgs/TransformStamped[] transforms
""",
    "geometry_msgs/msg/TwistStamped": """\
std_msgs/Header header
geometry_msgs/Twist twist
""",
    "geometry_msgs/msg/PoseWithCovarianceStamped": """\
std_msgs/Header header
geometry_msgs/PoseWithCovariance pose
""",
    "geometry_msgs/msg/PoseArray": """\
std_msgs/Header header
geometry_msgs/Pose[] poses
""",
    "geometry_msgs/msg/Point32": """\
float32 x
float32 y
float32 z
""",
    "geometry_msgs/msg/Polygon": """\
geometry_msgs/Point32[] points
""",
    "geometry_msgs/msg/PolygonStamped": """\
std_msgs/Header header
geometry_msgs/Polygon polygon
""",
    "sensor_msgs/msg/Range": """\
uint8 ULTRASOUND=0
uint8 INFRARED=1
std_msgs/Header header
uint8 radiation_type
float32 field_of_view
float32 min_range
float32 max_range
float32 range
""",
}


# the base classes are made once and a store is completed once, whichever thread asks first
_LOCK = threading.Lock()


def _base_types() -> tuple[dict[str, Any], dict[str, Any]]:
    """(fielddefs, classes) of ``BASE_TYPES`` and ``NAVLOG_TYPES``, made once: every store shares the classes."""
    with _LOCK:
        return _make_base_types()


@lru_cache(maxsize=1)
def _make_base_types() -> tuple[dict[str, Any], dict[str, Any]]:
    parsed: dict[str, Any] = {}
    for name, text in (BASE_TYPES | NAVLOG_TYPES).items():
        parsed.update(get_types_from_msg(text, name))
    store = Typestore()
    store.register(parsed)
    return dict(store.fielddefs), dict(store.types)


@lru_cache(maxsize=1)
def _humble() -> Any:
    """rosbags' whole ROS 2 Humble store (Humble = Jazzy for the common types)."""
    return get_typestore(Stores.ROS2_HUMBLE)


class _OnDemand(MutableMapping[str, Any]):
    """A store's ``types`` or ``fielddefs``: the base types, completed with the Humble store's (the
    entries it has keep theirs) the first time a name it lacks is looked up or the mapping is listed.

    So a store answers every question as a Humble store would, and a replay of navlog's own types never
    loads the Humble store.
    """

    def __init__(self, data: dict[str, Any], humble: Callable[[], dict[str, Any]]) -> None:
        self._data = data
        self._humble: Callable[[], dict[str, Any]] | None = humble  # None once completed

    @property
    def complete(self) -> bool:
        """True once the Humble store's entries are in."""
        return self._humble is None

    def _complete(self) -> None:
        if self._humble is None:
            return
        with _LOCK:  # a second thread waits until every entry is in
            if self._humble is not None:
                for name, value in self._humble().items():
                    self._data.setdefault(name, value)
                self._humble = None

    def __getitem__(self, name: str) -> Any:
        try:
            return self._data[name]
        except KeyError:
            if self._humble is None:
                raise
        self._complete()
        return self._data[name]

    def __setitem__(self, name: str, value: Any) -> None:
        self._data[name] = value

    def __delitem__(self, name: str) -> None:
        self._complete()
        del self._data[name]

    def __iter__(self) -> Iterator[str]:
        self._complete()
        return iter(self._data)

    def __len__(self) -> int:
        self._complete()
        return len(self._data)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._data!r}{'' if self.complete else ', Humble on demand'})"


def new_typestore():
    """A new type store of the ROS 2 types (Humble = Jazzy for the common types) and navlog's own.

    It holds ``BASE_TYPES`` and ``NAVLOG_TYPES`` at first and loads the rest of rosbags' Humble store
    on demand (``_OnDemand``); the message classes of a type are the same in every store. A log reader
    that meets types the shared store lacks registers them into one of these.
    """
    fielddefs, types = _base_types()
    store = Typestore()
    store.fielddefs = _OnDemand(dict(fielddefs), lambda: _humble().fielddefs)
    store.types = _OnDemand(dict(types), lambda: _humble().types)
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


def valid_stamp(t: Any) -> bool:
    """Whether a builtin_interfaces/Time is a time: ``nanosec`` below a second (a larger one would carry
    into ``sec``, past int32 at the end of its range)."""
    return 0 <= int(t.nanosec) < 1_000_000_000


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


def covariance_6x6(cov: np.ndarray) -> np.ndarray:
    """The 36 entries of a ROS pose covariance from a 3x3 (x, y, yaw) one (the other axes' entries 0)."""
    out = np.zeros((6, 6))
    out[:2, :2] = cov[:2, :2]
    out[5, 5] = cov[2, 2]
    return out.ravel()


def planar_pose_with_covariance(ns: int, frame_id: str, pose_xyt, cov: np.ndarray):
    """A geometry_msgs/PoseWithCovarianceStamped of a planar pose (x, y, yaw) and its 3x3 covariance."""
    x, y, yaw = (float(v) for v in pose_xyt)
    pwc = msg_class("geometry_msgs/msg/PoseWithCovariance")(pose((x, y, 0.0), quat_from_yaw(yaw)), covariance_6x6(cov))
    return msg_class(POSE_WITH_COVARIANCE_STAMPED)(header(ns, frame_id), pwc)


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
