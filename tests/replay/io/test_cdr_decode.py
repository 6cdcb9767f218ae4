"""The fast decoders (/tf, odometry, scans, commands) against the type store's deserializer: equal objects, or a refusal."""

from __future__ import annotations

import dataclasses
import math
import struct

import numpy as np
import pytest
from rosbags.serde import SerdeError
from rosbags.typesys import get_types_from_msg

from navlog.replay import messages
from navlog.replay.io import cdr_decode

STORE = messages.typestore()
NAMES = ["", "a", "ab", "abc", "base_link", "odom", "front_laser_with_a_rather_long_frame_name" * 3, "ünï"]
EDGE = [0.0, -0.0, 1.5, -2.25e-308, 1e308, math.inf, -math.inf, math.nan]


def same(a, b) -> bool:
    """Field-by-field equality (arrays by dtype and bits, NaN equal to NaN), classes included."""
    if type(a) is not type(b):
        return False
    if isinstance(a, np.ndarray):
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if dataclasses.is_dataclass(a):
        return all(same(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a))
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, float):
        return struct.pack("<d", a) == struct.pack("<d", b)
    return a == b


def tf_message(rng: np.random.Generator, n: int):
    ts = []
    for _ in range(n):
        q = [float(rng.choice(EDGE)) if rng.random() < 0.3 else float(rng.normal()) for _ in range(7)]
        ts.append(
            messages.transform_stamped(
                int(rng.integers(0, 2**31 * 10**9)), str(rng.choice(NAMES)), str(rng.choice(NAMES)), q[:3], q[3:]
            )
        )
    return messages.msg_class(messages.TF_MESSAGE)(transforms=ts)


def odometry(rng: np.random.Generator):
    c = messages.msg_class
    v = [float(rng.choice(EDGE)) if rng.random() < 0.3 else float(rng.normal()) for _ in range(13)]
    cov = rng.normal(size=(2, 36))
    cov[0, :3] = [math.nan, math.inf, -0.0]
    return c(messages.ODOMETRY)(
        header=c("std_msgs/msg/Header")(
            stamp=c("builtin_interfaces/msg/Time")(
                sec=int(rng.integers(-(2**31), 2**31)), nanosec=int(rng.integers(0, 2**32))
            ),
            frame_id=str(rng.choice(NAMES)),
        ),
        child_frame_id=str(rng.choice(NAMES)),
        pose=c("geometry_msgs/msg/PoseWithCovariance")(
            pose=c("geometry_msgs/msg/Pose")(
                position=c("geometry_msgs/msg/Point")(x=v[0], y=v[1], z=v[2]),
                orientation=c("geometry_msgs/msg/Quaternion")(x=v[3], y=v[4], z=v[5], w=v[6]),
            ),
            covariance=cov[0],
        ),
        twist=c("geometry_msgs/msg/TwistWithCovariance")(
            twist=c("geometry_msgs/msg/Twist")(
                linear=c("geometry_msgs/msg/Vector3")(x=v[7], y=v[8], z=v[9]),
                angular=c("geometry_msgs/msg/Vector3")(x=v[10], y=v[11], z=v[12]),
            ),
            covariance=cov[1],
        ),
    )


@pytest.mark.parametrize("seed", range(5))
def test_tf_messages_decode_to_the_stores_objects(seed):
    rng = np.random.default_rng(seed)
    decode = cdr_decode.decoder(messages.TF_MESSAGE, STORE)
    for n in (0, 1, 2, 3, 7):
        data = messages.serialize(tf_message(rng, n), messages.TF_MESSAGE)
        got, want = decode(data), STORE.deserialize_cdr(data, messages.TF_MESSAGE)
        assert same(got, want) and len(got.transforms) == n


@pytest.mark.parametrize("seed", range(5))
def test_odometry_decodes_to_the_stores_objects(seed):
    rng = np.random.default_rng(seed)
    decode = cdr_decode.decoder(messages.ODOMETRY, STORE)
    for _ in range(10):
        data = messages.serialize(odometry(rng), messages.ODOMETRY)
        got, want = decode(data), STORE.deserialize_cdr(data, messages.ODOMETRY)
        assert same(got, want)
        assert not got.pose.covariance.flags.writeable and got.pose.covariance.dtype == np.float64


def test_a_known_transform_reads_back_its_numbers():
    msg = messages.tf_message(
        [messages.transform_stamped(1_500_000_000, "odom", "base_footprint", (1.0, -2.0, 0.0), (0.0, 0.0, 0.6, 0.8))]
    )
    got = cdr_decode.decoder(messages.TF_MESSAGE, STORE)(messages.serialize(msg, messages.TF_MESSAGE))
    (t,) = got.transforms
    assert (t.header.stamp.sec, t.header.stamp.nanosec) == (1, 500_000_000)
    assert (t.header.frame_id, t.child_frame_id) == ("odom", "base_footprint")
    assert (t.transform.translation.x, t.transform.translation.y, t.transform.rotation.w) == (1.0, -2.0, 0.8)


def laser_scan(rng: np.random.Generator, n: int):
    c = messages.msg_class
    ranges = rng.uniform(0.1, 30.0, n).astype(np.float32)
    ranges[: min(n, 3)] = [np.nan, np.inf, -0.0][: min(n, 3)]
    return c(messages.LASER_SCAN)(
        header=messages.header(int(rng.integers(0, 2**31 * 10**9)), str(rng.choice(NAMES))),
        **{k: float(np.float32(rng.normal())) for k in ("angle_min", "angle_max", "angle_increment")},
        time_increment=0.0,
        scan_time=float(np.float32(0.1)),
        range_min=float(np.float32(0.12)),
        range_max=float(np.float32(30.0)),
        ranges=ranges,
        intensities=rng.uniform(0, 100, n if rng.random() < 0.5 else 0).astype(np.float32),
    )


def imu(rng: np.random.Generator):
    c = messages.msg_class
    v = [float(rng.choice(EDGE)) if rng.random() < 0.3 else float(rng.normal()) for _ in range(10)]
    cov = rng.normal(size=(3, 9))
    cov[0, :3] = [math.nan, -math.inf, -0.0]
    stamp = int(rng.integers(0, 2**31 * 10**9))
    return c(messages.IMU)(
        header=messages.header(stamp, str(rng.choice(NAMES))),
        orientation=c("geometry_msgs/msg/Quaternion")(x=v[0], y=v[1], z=v[2], w=v[3]),
        orientation_covariance=cov[0],
        angular_velocity=c("geometry_msgs/msg/Vector3")(x=v[4], y=v[5], z=v[6]),
        angular_velocity_covariance=cov[1],
        linear_acceleration=c("geometry_msgs/msg/Vector3")(x=v[7], y=v[8], z=v[9]),
        linear_acceleration_covariance=cov[2],
    )


def twist(rng: np.random.Generator, stamped: bool):
    v = [float(rng.choice(EDGE)) if rng.random() < 0.3 else float(rng.normal()) for _ in range(3)]
    msg = messages.twist(*v)
    if not stamped:
        return msg
    stamp = int(rng.integers(0, 2**31 * 10**9))
    return messages.msg_class(messages.TWIST_STAMPED)(messages.header(stamp, str(rng.choice(NAMES))), msg)


@pytest.mark.parametrize("seed", range(5))
def test_scans_commands_and_imu_decode_to_the_stores_objects(seed):
    rng = np.random.default_rng(seed)
    cases = [(messages.LASER_SCAN, laser_scan(rng, n)) for n in (0, 1, 5, 720)]
    cases += [(messages.TWIST, twist(rng, False)), (messages.TWIST_STAMPED, twist(rng, True))]
    cases += [(messages.IMU, imu(rng)) for _ in range(5)]
    for typename, msg in cases:
        data = messages.serialize(msg, typename)
        got, want = cdr_decode.decoder(typename, STORE)(data), STORE.deserialize_cdr(data, typename)
        assert same(got, want)
        if typename == messages.LASER_SCAN:
            assert not got.ranges.flags.writeable and len(got.ranges) == len(msg.ranges)


def test_tf_messages_of_one_size_with_other_frames_read_their_own_frames():
    """The kept layout of a message size is used only when the frame strings are the same bytes."""
    light = cdr_decode.decoder(messages.TF_MESSAGE, STORE, light=True)
    objects = cdr_decode.decoder(messages.TF_MESSAGE, STORE)
    pairs = [("odom", "base"), ("map", "odom"), ("odom", "base"), ("abcd", "efgh"), ("odom", "base")]
    for k, (parent, child) in enumerate(pairs):
        q = (0.0, 0.0, math.sin(k / 2), math.cos(k / 2))
        msg = messages.tf_message([messages.transform_stamped(10**9 * k + 7, parent, child, (k, -k, 0.5), q)])
        data = messages.serialize(msg, messages.TF_MESSAGE)
        assert len(data) == 100 or parent == "map"
        assert light(data).entries == [(parent, child, 10**9 * k + 7, float(k), float(-k), 0.5, *q)]
        assert same(objects(data), STORE.deserialize_cdr(data, messages.TF_MESSAGE))


CASES = {
    messages.TF_MESSAGE: (lambda rng: tf_message(rng, 2), 16),
    messages.ODOMETRY: (odometry, 12),
    messages.LASER_SCAN: (lambda rng: laser_scan(rng, 10), 12),
    messages.TWIST_STAMPED: (lambda rng: twist(rng, True), 12),
    messages.IMU: (imu, 12),
}


@pytest.mark.parametrize("typename", sorted(CASES))
def test_bytes_the_decoder_does_not_accept_are_refused(typename):
    rng = np.random.default_rng(1)
    make, string_at = CASES[typename]
    data = messages.serialize(make(rng), typename)
    decode = cdr_decode.decoder(typename, STORE)
    big_endian = b"\x00\x00" + data[2:]
    trailing = data + bytes(8)
    cut = data[: len(data) - 9]
    bad_string = bytearray(data)
    struct.pack_into("<I", bad_string, string_at, 10**6)
    for bad in (big_endian, trailing, cut, bytes(bad_string), b"\x00"):
        with pytest.raises((ValueError, struct.error)):
            decode(bad)
    for bad in (trailing, cut, bytes(bad_string), b"\x00"):  # corrupt: the store refuses them too
        with pytest.raises(SerdeError):
            STORE.deserialize_cdr(bad, typename)


def test_only_types_with_their_standard_definition_get_a_decoder():
    assert cdr_decode.decoder(messages.POINT_CLOUD2, STORE) is None
    other = messages.new_typestore()
    assert cdr_decode.decoder(messages.ODOMETRY, other) is not None
    # a store whose Vector3 is float32 (not ROS 2's) decodes with its own deserializer
    odd = messages.new_typestore()
    odd.fielddefs = dict(odd.fielddefs)
    odd.fielddefs.update(get_types_from_msg("float32 x\nfloat32 y\nfloat32 z\n", "geometry_msgs/msg/Vector3"))
    assert cdr_decode.decoder(messages.TF_MESSAGE, odd) is None
    assert cdr_decode.decoder(messages.ODOMETRY, odd) is None


def test_the_twist_encoder_writes_the_serializers_bytes():
    encode = cdr_decode.encoder(messages.TWIST)
    assert encode is not None and cdr_decode.encoder(messages.TWIST_STAMPED) is None
    rng = np.random.default_rng(3)
    values = [
        *rng.normal(size=(200, 3)).tolist(),
        [-0.0, 0.0, -0.0],
        [math.inf, -math.inf, math.nan],
        [1e-310, 0.45, -1.2],
    ]
    for vx, vy, wz in values:
        msg = messages.twist(vx, vy, wz)
        assert encode(msg) == messages.serialize(msg, messages.TWIST)
    full = messages.msg_class(messages.TWIST)(
        messages.msg_class("geometry_msgs/msg/Vector3")(0.1, 0.2, 0.3),
        messages.msg_class("geometry_msgs/msg/Vector3")(0.4, 0.5, 0.6),
    )
    assert encode(full) == messages.serialize(full, messages.TWIST)
    assert struct.unpack("<6d", encode(full)[4:]) == (0.1, 0.2, 0.3, 0.4, 0.5, 0.6)


def test_a_recorded_log_reads_the_same_objects_as_the_stores_deserializer(teleop_log):
    from navlog.replay.io.mcap_reader import McapLogReader

    topics = ["/tf", "/tf_static", "/odom", "/odom/ground_truth", "/scan", "/cmd_vel", "/imu/data"]
    with McapLogReader(teleop_log) as reader:
        fast = list(reader.messages(topics))
    with McapLogReader(teleop_log) as reader:
        raw = list(reader.messages(topics, decode=False))
    assert len(fast) == len(raw) > 1000
    counts: dict[str, int] = {}
    for a, b in zip(fast, raw):
        assert (a.topic, a.time_ns) == (b.topic, b.time_ns)
        assert same(a.msg, STORE.deserialize_cdr(b.msg, b.typename))
        counts[a.typename] = counts.get(a.typename, 0) + 1
    assert counts[messages.TF_MESSAGE] > 500 and counts[messages.ODOMETRY] > 1000
    assert counts[messages.LASER_SCAN] > 100 and counts[messages.TWIST] > 100 and counts[messages.IMU] > 1000


@pytest.mark.parametrize("seed", range(3))
def test_the_light_form_of_tf_holds_the_objects_numbers(seed):
    rng = np.random.default_rng(seed)
    light = cdr_decode.decoder(messages.TF_MESSAGE, STORE, light=True)
    for n in (0, 1, 3, 7):
        data = messages.serialize(tf_message(rng, n), messages.TF_MESSAGE)
        got = light(data)
        assert type(got) is messages.TFTransforms and len(got.entries) == n
        want = messages.tf_entries(STORE.deserialize_cdr(data, messages.TF_MESSAGE))
        assert struct.pack(f"<{n * 7}d", *(v for e in got.entries for v in e[3:])) == struct.pack(
            f"<{n * 7}d", *(v for e in want for v in e[3:])
        )
        assert [e[:3] for e in got.entries] == [e[:3] for e in want]
    # the bytes the object decoder refuses, the light one refuses too (the reader then asks the store)
    data = messages.serialize(tf_message(rng, 2), messages.TF_MESSAGE)
    for bad in (b"\x00\x00" + data[2:], data + bytes(8), data[:-9], b"\x00"):
        with pytest.raises((ValueError, struct.error)):
            light(bad)
    assert cdr_decode.decoder(messages.ODOMETRY, STORE, light=True) is None  # no light form: objects


def test_a_log_read_with_light_tf_gives_a_tf_buffer_the_same_transforms(teleop_log):
    from navlog.replay.io.mcap_reader import McapLogReader
    from navlog.replay.runtime.tf import TFBuffer

    buffers = []
    for light in (set(), {"/tf", "/tf_static"}):
        tf, kinds = TFBuffer(), set()
        with McapLogReader(teleop_log) as reader:
            for env in reader.messages(["/tf", "/tf_static", "/odom"], light=light):
                if env.topic != "/odom":
                    tf.add_message(env.msg, static=env.topic == "/tf_static")
                kinds.add((env.topic, type(env.msg).__name__))
        buffers.append(tf)
        if light:  # the TF topics come light, the others as objects
            assert kinds == {
                ("/tf", "TFTransforms"),
                ("/tf_static", "TFTransforms"),
                ("/odom", "nav_msgs__msg__Odometry"),
            }
    objects, light = buffers
    lo, hi = objects.time_range("base_link")
    for t in np.linspace(lo, hi, 50).astype(int).tolist():
        a, b = objects.lookup("map", "front_laser", t), light.lookup("map", "front_laser", t)
        assert a.tobytes() == b.tobytes()
