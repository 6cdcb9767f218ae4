"""The type store navlog starts with: its own definitions of the types it writes and reads, equal to rosbags'
ROS 2 Humble store in schema text, fields, classes and CDR bytes; the Humble store loaded only when a type
outside them is asked for, with the same answers a Humble store gives."""

from __future__ import annotations

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from navlog.replay import messages
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.runtime.executor import Envelope

REPO = Path(__file__).resolve().parents[2]
HUMBLE_MODULE = "rosbags.typesys.stores.ros2_humble"
POSE_ARRAY = "geometry_msgs/msg/PoseArray"
POSE_WITH_COVARIANCE_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
POLYGON_STAMPED = "geometry_msgs/msg/PolygonStamped"
RANGE = "sensor_msgs/msg/Range"

# every type navlog writes (recorder, pipelines, events) or its nodes read
WRITTEN_AND_READ = [
    messages.CLOCK,
    messages.LASER_SCAN,
    messages.POINT_CLOUD2,
    messages.IMU,
    messages.ODOMETRY,
    messages.PATH,
    messages.OCCUPANCY_GRID,
    messages.TF_MESSAGE,
    messages.TWIST,
    messages.TWIST_STAMPED,
    messages.POSE_STAMPED,
    messages.TRANSFORM_STAMPED,
    POSE_ARRAY,
    POSE_WITH_COVARIANCE_STAMPED,
    POLYGON_STAMPED,
    RANGE,
    messages.EVENT_TYPE,
]


@pytest.fixture(scope="module")
def humble():
    """The store ``new_typestore`` made before: rosbags' whole Humble store with navlog's types registered."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    for name, text in messages.NAVLOG_TYPES.items():
        store.register(get_types_from_msg(text, name))
    return store


def test_the_node_modules_publish_the_types_listed_here():
    from navlog.replay.nodes import amcl, collision_monitor

    assert {amcl.POSE_ARRAY, amcl.POSE_WITH_COVARIANCE_STAMPED} <= set(WRITTEN_AND_READ)
    assert {collision_monitor.RANGE, collision_monitor.POLYGON_STAMPED} <= set(WRITTEN_AND_READ)


@pytest.mark.parametrize("typename", WRITTEN_AND_READ)
def test_every_type_navlog_writes_has_the_humble_schema_text_and_fields(typename, humble):
    assert typename in messages.BASE_TYPES or typename in messages.NAVLOG_TYPES
    assert messages.msgdef(typename) == humble.generate_msgdef(typename, ros_version=2)[0]
    assert messages.typestore().fielddefs[typename] == humble.fielddefs[typename]


def test_every_base_type_has_the_humble_definition_and_class_shape(humble):
    store = messages.typestore()
    for name in messages.BASE_TYPES:
        assert messages.msgdef(name) == humble.generate_msgdef(name, ros_version=2)[0], name
        assert store.fielddefs[name] == humble.fielddefs[name], name
        ours, theirs = store.types[name], humble.types[name]
        assert [f.name for f in dataclasses.fields(ours)] == [f.name for f in dataclasses.fields(theirs)], name
        consts = [c for c, _, _ in humble.fielddefs[name][0]]
        assert [getattr(ours, c) for c in consts] == [getattr(theirs, c) for c in consts], name
        assert ours.__msgtype__ == theirs.__msgtype__ == name
    # the schema text of a type with constants, as a log carries it
    assert messages.msgdef(messages.POINT_FIELD).startswith("uint8 INT8=1\nuint8 UINT8=2\n")
    assert store.types[messages.POINT_FIELD].FLOAT32 == 7


def _sample(store, typename: str, seed: int = 1):
    """A message of ``typename`` of ``store`` with every field set to a distinct value (sequences of 2)."""
    consts, fields = store.fielddefs[typename]
    values = []
    for k, (_, desc) in enumerate(fields, start=seed):
        values.append(_value(store, desc, k))
    return store.types[typename](*values)


_DTYPES = {"float32": np.float32, "float64": np.float64, "uint8": np.uint8, "int8": np.int8}


def _value(store, desc, k: int):
    kind, arg = desc
    if kind == Nodetype.BASE:
        base = arg[0]
        if base == "string":
            return f"field {k}"
        if base == "bool":
            return k % 2 == 1
        if base.startswith("float"):
            return float(np.float32(k * 0.25 + 0.125))
        return k % 100
    if kind == Nodetype.NAME:
        return _sample(store, arg, k)
    (sub_kind, sub_arg), count = arg
    n = count if kind == Nodetype.ARRAY else 2
    if sub_kind == Nodetype.BASE and sub_arg[0] in _DTYPES:
        return np.arange(k, k + n).astype(_DTYPES[sub_arg[0]])
    return [_value(store, (sub_kind, sub_arg), k + i) for i in range(n)]


@pytest.mark.parametrize("typename", sorted(set(messages.BASE_TYPES) | set(messages.NAVLOG_TYPES)))
def test_cdr_bytes_equal_the_humble_stores_both_ways(typename, humble):
    ours, theirs = _sample(messages.typestore(), typename), _sample(humble, typename)
    data = messages.serialize(ours, typename)
    assert data == bytes(humble.serialize_cdr(theirs, typename)) and len(data) > 4
    back = messages.deserialize(data, typename)
    assert type(back) is messages.msg_class(typename)
    assert messages.serialize(back, typename) == data


def test_a_replay_of_navlogs_types_never_loads_the_humble_store():
    store = messages.new_typestore()
    assert not store.types.complete and not store.fielddefs.complete
    twist = messages.twist(0.3, -0.1, 0.5)
    data = store.serialize_cdr(twist, messages.TWIST)
    assert store.deserialize_cdr(data, messages.TWIST) == twist
    assert messages.TWIST in store.types and store.fielddefs.get(messages.ODOMETRY) is not None
    assert store.generate_msgdef(messages.ODOMETRY, ros_version=2)[0].startswith("std_msgs/Header header\n")
    assert not store.types.complete and not store.fielddefs.complete


def test_another_type_loads_the_humble_store_once_and_the_base_classes_stay(humble):
    store = messages.new_typestore()
    twist_class = store.types[messages.TWIST]
    assert twist_class is messages.msg_class(messages.TWIST)  # one class per type in every store
    nav_sat_fix = store.types["sensor_msgs/msg/NavSatFix"]
    assert store.types.complete and nav_sat_fix is humble.types["sensor_msgs/msg/NavSatFix"]
    assert store.types[messages.TWIST] is twist_class
    assert "geometry_msgs/msg/AccelStamped" in store.fielddefs and store.fielddefs.complete
    assert "foo_msgs/msg/Nothing" not in store.types
    with pytest.raises(KeyError):
        store.types["foo_msgs/msg/Nothing"]
    assert set(store.types) == set(humble.types) == set(store.fielddefs)
    # a non-base type holding base types decodes into the base classes
    accel = humble.types["geometry_msgs/msg/AccelStamped"]
    msg = accel(humble.types["std_msgs/msg/Header"](humble.types["builtin_interfaces/msg/Time"](3, 4), "map"), None)
    msg.accel = humble.types["geometry_msgs/msg/Accel"](
        humble.types["geometry_msgs/msg/Vector3"](1.0, 2.0, 3.0), humble.types["geometry_msgs/msg/Vector3"](4, 5, 6.5)
    )
    back = store.deserialize_cdr(humble.serialize_cdr(msg, "geometry_msgs/msg/AccelStamped"), msg.__msgtype__)
    assert back.header == messages.header(3_000_000_004, "map") and back.accel.angular.z == 6.5


def test_listing_a_store_lists_the_humble_types_and_navlogs(humble):
    store = messages.new_typestore()
    assert len(store.types) == len(humble.types) and messages.EVENT_TYPE in dict(store.fielddefs)


def test_a_log_registering_a_humble_name_with_other_fields_is_refused_as_by_humble():
    from rosbags.typesys import TypesysError

    store = messages.new_typestore()
    odd = get_types_from_msg("float32 latitude\n", "sensor_msgs/msg/NavSatFix")
    with pytest.raises(TypesysError, match="different definition"):
        store.register(odd)
    same_as_base = get_types_from_msg("float32 x\n", messages.TWIST)
    with pytest.raises(TypesysError, match="different definition"):
        store.register(same_as_base)


def test_messages_from_two_stores_compare_equal():
    other = messages.new_typestore()
    odom = messages.odometry(5, "odom", "base_footprint", (1.0, 2.0, 0.0), (0, 0, 0, 1), (0.1, 0, 0), (0, 0, 0.2))
    data = messages.serialize(odom, messages.ODOMETRY)
    back = other.deserialize_cdr(data, messages.ODOMETRY)
    assert type(back) is type(odom) and back.pose.pose == odom.pose.pose and back.child_frame_id == "base_footprint"


def _wall_log(path: Path) -> Path:
    """One second of a robot standing at (1, 0.5) with a laser seeing a wall 2 m ahead."""
    n = 360
    inc = 2 * math.pi / n
    ranges = np.full(n, np.inf, dtype=np.float32)
    ranges[n // 2 - 3 : n // 2 + 4] = 2.0
    scan_type = messages.msg_class(messages.LASER_SCAN)
    with McapLogWriter(path) as w:
        static = messages.transform_stamped(0, "base_link", "laser", (0.2, 0.0, 0.1), (0, 0, 0, 1))
        w.write(Envelope("/tf_static", messages.TF_MESSAGE, 0, messages.tf_message([static])))
        for k in range(10):
            t = k * 100_000_000
            odom = messages.odometry(t, "world", "base_link", (1.0, 0.5, 0.0), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0))
            w.write(Envelope("/clock", messages.CLOCK, t, messages.clock(t)))
            w.write(Envelope("/odom/ground_truth", messages.ODOMETRY, t, odom))
            tf = messages.transform_stamped(t, "world", "base_link", (1.0, 0.5, 0.0), (0, 0, 0, 1))
            w.write(Envelope("/tf", messages.TF_MESSAGE, t, messages.tf_message([tf])))
            w.write(Envelope("/cmd_vel", messages.TWIST, t, messages.twist(0.0, 0.0, 0.0)))
            scan = scan_type(
                messages.header(t, "laser"),
                -math.pi,
                -math.pi + inc * (n - 1),
                inc,
                0.0,
                0.1,
                0.1,
                6.0,
                ranges,
                ranges[:0],
            )
            w.write(Envelope("/scan", messages.LASER_SCAN, t, scan))
    return path


def test_a_navlog_replay_process_leaves_the_humble_store_unloaded(tmp_path):
    log = _wall_log(tmp_path / "wall.mcap")
    out = tmp_path / "out"
    code = (
        "import sys\n"
        "from navlog.cli import main\n"
        f"rc = main(['-q', 'replay', {str(log)!r}, '--pipeline', 'mapping', '--set', 'lidar_mapper=off',"
        f" '--set', 'occupancy.minimum_travel_distance=0', '-o', {str(out)!r}])\n"
        f"print(rc, {HUMBLE_MODULE!r} in sys.modules)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "0 False"
    assert (out / "map.pgm").stat().st_size > 0


def test_threads_completing_one_store_at_once_all_see_every_type(humble):
    from concurrent.futures import ThreadPoolExecutor

    store = messages.new_typestore()
    with ThreadPoolExecutor(4) as pool:
        sizes = list(pool.map(lambda _: len(store.types), range(8)))
    assert sizes == [len(humble.types)] * 8 and store.types[messages.IMU] is messages.msg_class(messages.IMU)
