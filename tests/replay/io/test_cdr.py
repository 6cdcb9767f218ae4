"""Direct CDR encoding gives the rosbags serializer's bytes, for random and edge values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

from navlog.replay import messages
from navlog.replay.io.cdr import layout

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
