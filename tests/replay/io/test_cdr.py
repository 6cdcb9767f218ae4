"""Direct CDR encoding gives the rosbags serializer's bytes, and decoding its values, for random and edge values."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

from navlog.replay import messages
from navlog.replay.io.cdr import GrowingSequence, RepeatedShapes, layout

STORE = messages.typestore()
EDGE_FLOATS = (0.0, -0.0, 1.5, -1e300, 5e-324, math.inf, -math.inf, math.nan)
TYPES = (
    messages.IMU,
    messages.ODOMETRY,
    messages.TF_MESSAGE,
    messages.CLOCK,
    messages.TWIST,
    messages.LASER_SCAN,
    messages.POINT_CLOUD2,
    messages.OCCUPANCY_GRID,
    messages.PATH,
    messages.EVENT_TYPE,
    "sensor_msgs/msg/JointState",
    "diagnostic_msgs/msg/DiagnosticArray",
)
_INTS = {
    "bool": (0, 1),
    "byte": (0, 127),  # rosbags packs byte as int8; CDR writes the same octet for 0..127
    "char": (0, 255),
    "int8": (-128, 127),
    "uint8": (0, 255),
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1),
    "uint64": (0, 2**64 - 1),
}


def _random_base(name: str, rng: np.random.Generator, edge: bool):
    if name == "string":
        n = int(rng.choice([0, 1, 2, 3, 5, 300]))
        return "".join(rng.choice(list("abcäπ/_ "), size=n))
    if name in ("float32", "float64"):
        v = float(rng.choice(EDGE_FLOATS)) if edge else float(rng.normal(0, 100))
        if name == "float32":
            with np.errstate(over="ignore"):  # -1e300 becomes -inf, one more edge
                return float(np.float32(v))
        return v
    lo, hi = _INTS[name]
    v = (
        int(rng.choice([lo, hi]))
        if edge
        else int(rng.integers(lo, hi, endpoint=True, dtype=np.uint64 if lo == 0 else np.int64))
    )
    return bool(v) if name == "bool" else v


def _random(node, rng: np.random.Generator, edge: bool):
    """(message value, flat values for Layout.encode) of one field node of the type store."""
    kind, detail = node
    if kind == Nodetype.BASE:
        v = _random_base(detail[0], rng, edge)
        return v, [v]
    if kind == Nodetype.NAME:
        return _random_msg(detail, rng, edge)
    sub, count = detail
    if kind == Nodetype.SEQUENCE:
        count = int(rng.choice([0, 1, 3, 41]))
    if sub[0] == Nodetype.BASE and sub[1][0] != "string":
        code = {"bool": "bool", "byte": "uint8", "char": "uint8"}.get(sub[1][0], sub[1][0])
        dtype = np.dtype(code)
        vals = [_random_base(sub[1][0], rng, edge) for _ in range(count)]
        arr = np.array(vals, dtype=dtype)
        return arr, (arr.tolist() if kind == Nodetype.ARRAY else [arr])
    pairs = [_random(sub, rng, edge) for _ in range(count)]
    items = [p[0] for p in pairs]
    if kind == Nodetype.ARRAY:
        return items, [v for p in pairs for v in p[1]]
    if sub[0] == Nodetype.BASE:  # a sequence of strings
        return items, [items]
    return items, [[tuple(p[1]) for p in pairs]]


def _random_msg(typename: str, rng: np.random.Generator, edge: bool):
    kwargs, flat = {}, []
    for name, node in STORE.get_msgdef(typename).fields:
        kwargs[name], values = _random(node, rng, edge)
        flat.extend(values)
    return STORE.types[typename](**kwargs), flat


@pytest.mark.parametrize("typename", TYPES)
@pytest.mark.parametrize("edge", [False, True])
def test_bytes_equal_the_rosbags_serializer(typename, edge):
    rng = np.random.default_rng([TYPES.index(typename), edge])
    lay = layout(typename)
    for _ in range(10):
        msg, flat = _random_msg(typename, rng, edge)
        assert len(flat) == lay.size
        assert lay.encode(flat) == STORE.serialize_cdr(msg, typename)


def _decoded(node, value):
    """``value`` of a field node as ``Layout.decode`` gives it (a list of values, see there)."""
    kind, detail = node
    if kind == Nodetype.BASE:
        return [value]
    if kind == Nodetype.NAME:
        return _decoded_msg(detail, value)
    sub = detail[0]
    if sub[0] == Nodetype.BASE and sub[1][0] != "string":
        return [value]  # an array, fixed or not
    if kind == Nodetype.ARRAY:
        return [v for item in value for v in _decoded(sub, item)]
    if sub[0] == Nodetype.BASE:  # a sequence of strings
        return [list(value)]
    return [[_decoded_msg(sub[1], item) for item in value]]


def _decoded_msg(typename: str, msg) -> list:
    return [v for name, node in STORE.get_msgdef(typename).fields for v in _decoded(node, getattr(msg, name))]


def _same(a, b) -> bool:
    """Equal values: arrays by dtype and bytes, floats by bits."""
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and a.tobytes() == b.tobytes()
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float):
        return type(b) is float and struct.pack("<d", a) == struct.pack("<d", b)
    return type(a) is type(b) and a == b


def _split(values: list) -> list:
    """``Layout.decode``'s values as ``RepeatedShapes.read`` gives them: [numbers, strings, arrays]."""
    out: list = [[], [], []]
    for v in values:
        if isinstance(v, list):  # a sequence of messages
            for item in v:
                for part, more in zip(out, _split(item)):
                    part += more
        else:
            out[1 if isinstance(v, str) else 2 if isinstance(v, np.ndarray) else 0].append(v)
    return out


@pytest.mark.parametrize("typename", TYPES)
@pytest.mark.parametrize("edge", [False, True])
def test_decoded_values_are_the_rosbags_deserializers(typename, edge):
    rng = np.random.default_rng([TYPES.index(typename), edge, 1])
    lay = layout(typename)
    for _ in range(10):
        data = bytes(STORE.serialize_cdr(_random_msg(typename, rng, edge)[0], typename))  # as a log reader gives them
        got = lay.decode(data, STORE.max_sequence_length)
        assert _same(got, _decoded_msg(typename, STORE.deserialize_cdr(data, typename)))
        arrays = [v for v in got if isinstance(v, np.ndarray)]
        assert all(not a.flags.writeable for a in arrays)  # views over the bytes, as the store makes them
        if RepeatedShapes.supports(lay):  # the same values by the kept shape: first walked, then seen again
            shapes = RepeatedShapes(lay, STORE.max_sequence_length)
            for _ in range(2):
                numbers, strings, arrays = shapes.read(data)
                assert _same([list(numbers), strings, arrays], _split(got))
    with pytest.raises((ValueError, struct.error)):
        lay.decode(data + bytes(8), STORE.max_sequence_length)  # more than 3 bytes after the message


def test_a_sequence_longer_than_allowed_is_refused():
    data = bytes(STORE.serialize_cdr(messages.tf_message([]), messages.TF_MESSAGE))
    lay = layout(messages.TF_MESSAGE)
    assert lay.decode(data, 10) == [[]]
    long = data[:4] + struct.pack("<I", 11) + bytes(11 * 64)
    with pytest.raises(ValueError, match="bad sequence length 11"):
        lay.decode(long, 10)


def test_repeated_shapes_read_the_numbers_and_strings_of_each_message():
    lay = layout(messages.TF_MESSAGE)
    assert RepeatedShapes.supports(lay) and not RepeatedShapes.supports(layout("sensor_msgs/msg/JointState"))
    shapes = RepeatedShapes(lay, STORE.max_sequence_length)
    frames = [("odom", "base"), ("map", "odom"), ("abcd", "efgh"), ("odom", "base"), ("odom", "base")]
    for k, (parent, child) in enumerate(frames):  # all of one size but the second
        msg = messages.tf_message(
            [
                messages.transform_stamped(10**9 * k + 7, parent, child, (k, -k, 0.5), (0.0, 0.0, 0.6, 0.8)),
                messages.transform_stamped(3, "world", parent, (1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0)),
            ]
        )
        numbers, strings, arrays = shapes.read(bytes(STORE.serialize_cdr(msg, messages.TF_MESSAGE)))
        assert strings == [parent, child, "world", parent] and arrays == []
        assert numbers == (k, 7, float(k), float(-k), 0.5, 0.0, 0.0, 0.6, 0.8, 0, 3, 1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0)
    assert len(shapes._by_size) == 2


def test_an_imu_sample_by_hand():
    """Odd alignments: a 1-char frame puts the header's end at offset 14, so orientation starts at 16."""
    Imu = STORE.types[messages.IMU]
    cov = np.arange(9, dtype=np.float64)
    msg = Imu(
        messages.header(1_500_000_000, "a"),
        messages.quaternion((0.0, 0.0, math.sin(0.25), math.cos(0.25))),
        cov,
        messages.vector3(0.1, -0.2, 9.81),
        cov,
        messages.vector3(1.0, 2.0, 3.0),
        cov,
    )
    c = cov.tolist()
    values = (1, 500_000_000, "a", 0.0, 0.0, math.sin(0.25), math.cos(0.25), *c, 0.1, -0.2, 9.81, *c, 1.0, 2.0, 3.0, *c)
    data = layout(messages.IMU).encode(values)
    assert data == messages.serialize(msg, messages.IMU)
    assert len(data) == 4 + 16 + 4 * 8 + 3 * (9 * 8) + 2 * (3 * 8)  # 4 + 14 padded to 16, then doubles
    assert data[4 + 8 : 4 + 16] == b"\x02\x00\x00\x00a\x00\x00\x00"


def test_a_tf_message_of_two_transforms():
    tfs = [
        messages.transform_stamped(5, "map", "odom", (1.0, 2.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
        messages.transform_stamped(5, "odom", "base_footprint", (0.5, -0.5, 0.0), (0.0, 0.0, 1.0, 0.0)),
    ]
    values = [
        [
            (0, 5, "map", "odom", 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0),
            (0, 5, "odom", "base_footprint", 0.5, -0.5, 0.0, 0.0, 0.0, 1.0, 0.0),
        ]
    ]
    assert layout(messages.TF_MESSAGE).encode(values) == messages.serialize(
        messages.tf_message(tfs), messages.TF_MESSAGE
    )


@pytest.mark.parametrize("frame", ["", "a", "ab", "abc", "laser", "front_laser", "π/scan"])  # every alignment
def test_a_laser_scan_with_special_ranges(frame):
    """Ranges hold NaN, both infinities (REP 117) and signed zeros; the float32 array follows a header of any
    length; intensities may be empty or not."""
    LaserScan = STORE.types[messages.LASER_SCAN]
    rng = np.random.default_rng(len(frame))
    ranges = rng.uniform(0.1, 6.0, 37).astype(np.float32)
    ranges[[0, 5, 9, 30]] = [np.inf, -np.inf, np.nan, -0.0]
    for intensities in (np.zeros(0, dtype=np.float32), rng.normal(size=37).astype(np.float32)):
        head = (-0.5, 6.25, 0.125, 0.0, 0.1, 0.12, 6.0)  # Python floats: both round 0.1 and 0.12 to float32
        msg = LaserScan(messages.header(3_000_000_007, frame), *head, ranges, intensities)
        data = layout(messages.LASER_SCAN).encode((3, 7, frame, *head, ranges, intensities))
        assert data == messages.serialize(msg, messages.LASER_SCAN)
        n_frame = len(frame.encode()) + 1
        start = 4 + 8 + 4 + n_frame + (-(8 + 4 + n_frame) % 4) + 7 * 4 + 4  # ranges after their count
        assert np.array_equal(np.frombuffer(data[start : start + 37 * 4], dtype="<f4"), ranges, equal_nan=True)
    # an empty scan, and ranges given as float64 values or a strided view: converted as the serializer does
    empty = LaserScan(messages.header(0, frame), *head, np.zeros(0, np.float32), np.zeros(0, np.float32))
    assert layout(messages.LASER_SCAN).encode((0, 0, frame, *head, [], [])) == messages.serialize(
        empty, messages.LASER_SCAN
    )
    wide = np.repeat(ranges, 2)[::2]
    assert layout(messages.LASER_SCAN).encode((3, 7, frame, *head, wide.astype(np.float64), wide)) == (
        messages.serialize(LaserScan(messages.header(3_000_000_007, frame), *head, ranges, ranges), messages.LASER_SCAN)
    )


@pytest.mark.parametrize("n", [0, 1, 3, 1000])
@pytest.mark.parametrize("frame", ["", "l", "lidar", "livox_frame"])
def test_a_point_cloud_blob(n, frame):
    """A PointCloud2's fields list and its data blob given as the uint8 view of a structured array (22-byte
    points, so odd lengths), with NaN and infinite coordinates."""
    PointCloud2 = STORE.types[messages.POINT_CLOUD2]
    PointField = STORE.types[messages.POINT_FIELD]
    fields = [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("intensity", 12, 7, 1), ("ring", 16, 4, 1)]
    fields.append(("time", 18, 7, 1))
    dtype = np.dtype(
        {
            "names": [f[0] for f in fields],
            "formats": ["<f4"] * 4 + ["<u2", "<f4"],
            "offsets": [f[1] for f in fields],
            "itemsize": 22,
        }
    )
    rng = np.random.default_rng(n)
    points = np.zeros(n, dtype=dtype)
    for name in ("x", "y", "z", "intensity", "time"):
        points[name] = rng.normal(size=n)
    points["ring"] = rng.integers(0, 2**16, n)
    if n >= 3:
        points["x"][:3] = [np.nan, np.inf, -np.inf]
    blob = points.view(np.uint8)
    msg = PointCloud2(
        messages.header(12_000_000_345, frame), 1, n, [PointField(*f) for f in fields], False, 22, 22 * n, blob, True
    )
    data = layout(messages.POINT_CLOUD2).encode((12, 345, frame, 1, n, fields, False, 22, 22 * n, blob, True))
    assert data == messages.serialize(msg, messages.POINT_CLOUD2)
    assert data[-1 - 22 * n : -1] == points.tobytes()  # the blob as it is, then is_dense
    assert data == layout(messages.POINT_CLOUD2).encode(
        (12, 345, frame, 1, n, fields, False, 22, 22 * n, points.tobytes(), True)
    )


def _pose_stamped(i: int, frame: str) -> tuple:
    return (i, 1000 * i, frame, 0.5 * i, -1.25, 3.0, 0.0, 0.0, math.sin(i), math.cos(i))


@pytest.mark.parametrize("frame", ["", "m", "map", "odom", "child_frame"])
def test_a_growing_path_gives_the_whole_message_bytes(frame):
    """Each publish adds poses; the bytes equal those of the whole path's message, whatever the frame's
    length (it moves where the first pose starts modulo 8, and so every pose's padding)."""
    path, values = GrowingSequence(messages.PATH), []
    for added in (0, 1, 2, 5, 0, 3):
        new = [_pose_stamped(len(values) + k, frame) for k in range(added)]
        values += new
        head = (len(values), 7, frame)
        got = path.encode(head, iter(new))  # a generator is fine
        assert got == layout(messages.PATH).encode((*head, values))
        msg = messages.deserialize(got, messages.PATH)
        assert [p.header.stamp.sec for p in msg.poses] == list(range(len(values)))
        assert len(path) == len(values)


def test_a_growing_sequence_keeps_its_elements_when_an_element_fails():
    path = GrowingSequence(messages.PATH)
    first = path.encode((1, 0, "map"), [_pose_stamped(0, "map")])
    with pytest.raises(struct.error):
        path.encode((2, 0, "map"), [_pose_stamped(1, "map"), (1, 2, "map", "not a number")])
    assert len(path) == 1 and path.encode((1, 0, "map")) == first


def test_a_growing_sequence_refuses_a_head_that_moves_the_alignment():
    path = GrowingSequence(messages.PATH)
    path.encode((1, 0, "map"), [_pose_stamped(0, "map")])
    with pytest.raises(ValueError, match="size modulo 8"):
        path.encode((1, 0, "odom"))
    path.encode((1, 0, "map12345678"))  # 8 more bytes: the same alignment
    with pytest.raises(ValueError, match="not a sequence of messages"):
        GrowingSequence(messages.IMU)
