"""PointCloud2 <-> numpy, honouring field offsets, point_step, row_step and endianness.

navlog's 3D LiDAR publishes the Velodyne-style layout FAST-LIO's `lidar_type: 2` expects:
x, y, z, intensity float32 at 0/4/8/12, ring uint16 at 16, time float32 at 18 (point_step 22).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from navlog.replay import messages

# sensor_msgs/PointField datatypes
_DTYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}
_CODES = {np.dtype(v).newbyteorder("<").str[1:]: k for k, v in _DTYPES.items()}

VELODYNE_FIELDS = (("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 12, 7), ("ring", 16, 4), ("time", 18, 7))
VELODYNE_POINT_STEP = 22


def cloud_dtype(fields: Any, point_step: int, big_endian: bool = False) -> np.dtype:
    """Structured dtype for a PointCloud2's `fields` (count > 1 becomes a sub-array). A field that does not
    lie inside `point_step` bytes raises ValueError naming it (numpy itself lets an offset near 2^31 past
    its check, and reading such a field reads outside the buffer); an unknown datatype raises KeyError."""
    order = ">" if big_endian else "<"
    step = int(point_step)
    names, formats, offsets = [], [], []
    for f in fields:
        base = order + _DTYPES[int(f.datatype)]
        count, offset, single = max(1, int(f.count)), int(f.offset), np.dtype(base)
        if not 0 <= offset <= step - count * single.itemsize:
            raise ValueError(
                f"PointField {f.name!r}: {count} x {single.name} at offset {offset} lies outside point_step {step}"
            )
        names.append(f.name)
        formats.append((base, (count,)) if count > 1 else base)
        offsets.append(offset)
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": step})


def read_points(msg: Any, fields: tuple[str, ...] | None = None) -> np.ndarray:
    """The points of a PointCloud2 as a structured array (row padding dropped)."""
    dt = cloud_dtype(msg.fields, msg.point_step, bool(msg.is_bigendian))
    raw = np.asarray(msg.data, dtype=np.uint8)
    rows, width = int(msg.height), int(msg.width)
    if rows * width == 0:
        arr = np.zeros(0, dtype=dt)
    elif int(msg.row_step) == width * int(msg.point_step):
        arr = np.frombuffer(raw[: rows * width * int(msg.point_step)].tobytes(), dtype=dt)
    else:
        parts = [raw[r * msg.row_step : r * msg.row_step + width * msg.point_step].tobytes() for r in range(rows)]
        arr = np.frombuffer(b"".join(parts), dtype=dt)
    if fields is not None:
        missing = [f for f in fields if f not in arr.dtype.names]
        if missing:
            raise KeyError(f"PointCloud2 has no field(s) {missing}; it has {list(arr.dtype.names)}")
    return arr


def xyz(msg: Any) -> np.ndarray:
    """(N, 3) float64 coordinates of a PointCloud2; NaN points are dropped."""
    arr = read_points(msg, ("x", "y", "z"))
    pts = np.stack([arr["x"], arr["y"], arr["z"]], axis=1).astype(np.float64)
    return pts[np.isfinite(pts).all(axis=1)]


def make_cloud(
    ns: int, frame_id: str, columns: dict[str, np.ndarray], layout=VELODYNE_FIELDS, point_step=VELODYNE_POINT_STEP
) -> Any:
    """A dense PointCloud2 (height 1) from named columns, in the given field layout."""
    PointField = messages.msg_class(messages.POINT_FIELD)
    n = len(next(iter(columns.values()))) if columns else 0
    fields = [PointField(name=name, offset=off, datatype=code, count=1) for name, off, code in layout]
    dt = cloud_dtype(fields, point_step)
    arr = np.zeros(n, dtype=dt)
    for name, _, _ in layout:
        if name in columns:
            arr[name] = columns[name]
    return messages.msg_class(messages.POINT_CLOUD2)(
        header=messages.header(ns, frame_id),
        height=1,
        width=n,
        fields=fields,
        is_bigendian=False,
        point_step=point_step,
        row_step=point_step * n,
        data=np.frombuffer(arr.tobytes(), dtype=np.uint8),
        is_dense=True,
    )


def xyz_cloud(ns: int, frame_id: str, points: np.ndarray) -> Any:
    """A PointCloud2 of float32 x, y, z only (for registered clouds and maps)."""
    p = np.asarray(points, dtype=np.float32).reshape(-1, 3)
    return make_cloud(
        ns, frame_id, {"x": p[:, 0], "y": p[:, 1], "z": p[:, 2]}, (("x", 0, 7), ("y", 4, 7), ("z", 8, 7)), 12
    )


# ---------------------------------------------------------------- per-point times

# the names LiDAR drivers give the per-point time, in the order they are looked for
TIME_FIELDS = ("time", "t", "timestamp", "offset_time", "time_offset")
MAX_SWEEP_S = 1.0  # s: no offset within a sweep is larger; a point further from the sweep's median time is absurd


@dataclass(frozen=True)
class PointTimes:
    """Per-point times of a cloud, decoded: ``seconds`` after the header stamp (NaN where dropped)."""

    field: str  # the field they came from
    convention: str  # e.g. "relative s", "relative ns", "absolute s", "absolute ns"
    seconds: np.ndarray  # (N,) float64; NaN for non-finite or absurd times
    invalid: int  # how many points have a non-finite or absurd time


def time_field_name(names: tuple[str, ...], wanted: str = "auto") -> str | None:
    """The per-point time field of a cloud with fields ``names``: ``wanted`` if it is there, or with
    ``auto`` the first of ``TIME_FIELDS`` that is there; None when there is none."""
    if wanted != "auto":
        return wanted if wanted in names else None
    return next((n for n in TIME_FIELDS if n in names), None)


def point_times(arr: np.ndarray, field_name: str, stamp_ns: int) -> PointTimes:
    """Decode the per-point times of ``arr[field_name]`` into seconds after the header stamp.

    The unit follows the type: floats are seconds, integers nanoseconds. Times whose median is
    larger than a sweep could be (``MAX_SWEEP_S``) and closer to the header stamp than to zero are
    clock readings, taken relative to the stamp (Hesai's float64 ``timestamp``); otherwise they are
    already offsets from the stamp (Velodyne's float32 ``time``, Ouster's uint32 ``t``, Livox's
    uint32 ``offset_time``). Non-finite times, and times more than ``MAX_SWEEP_S`` from the sweep's median
    (a bit-flipped field), become NaN and are counted in ``invalid``.
    """
    raw = arr[field_name]
    if raw.ndim > 1:  # a field with count > 1: its first element
        raw = raw[:, 0]
    kind = raw.dtype.kind
    if kind == "f":
        v = raw.astype(np.float64)
        finite = np.isfinite(v)
        big = bool(finite.any()) and _is_clock(float(np.median(v[finite])), stamp_ns * 1e-9)
        convention = "absolute s" if big else "relative s"
        seconds = v
        if big:  # subtract the stamp in integers first: float64 seconds since 1970 keep only ~0.2 us
            whole = np.clip(np.floor(np.where(finite, v, 0.0)), -9e9, 9e9)
            seconds = (whole.astype(np.int64) * 1_000_000_000 - stamp_ns) * 1e-9 + (v - whole)
    elif kind in "iu":
        v = raw.astype(np.int64)  # (a uint64 clock reading fits: it is below 2**63 until 2262)
        finite = np.ones(len(v), dtype=bool)
        big = len(v) > 0 and _is_clock(float(np.median(v)) * 1e-9, stamp_ns * 1e-9)
        seconds = ((v - stamp_ns) if big else v) * 1e-9
        convention = "absolute ns" if big else "relative ns"
    else:
        raise ValueError(f"per-point time field {field_name!r} has type {raw.dtype}, not a number")
    seconds = np.where(finite, seconds, np.nan)
    ok = np.isfinite(seconds)
    if ok.any():
        ok &= np.abs(seconds - np.median(seconds[ok])) <= MAX_SWEEP_S
    seconds = np.where(ok, seconds, np.nan)
    return PointTimes(field_name, convention, seconds, int(len(seconds) - ok.sum()))


def _is_clock(median_s: float, stamp_s: float) -> bool:
    """Times with this median are clock readings (not offsets from the stamp ``stamp_s``)."""
    return abs(median_s) > MAX_SWEEP_S and abs(median_s - stamp_s) < abs(median_s)


def azimuth_times(points: np.ndarray, sweep_s: float, clockwise: bool | None = None) -> np.ndarray:
    """Per-point times (s after the stamp) of a spinning LiDAR's sweep from each point's azimuth,
    for clouds without a time field.

    With ``clockwise=None`` the turn is read from the cloud's point order (drivers store points in
    firing order): when the azimuths, in order, wind at least half a turn one way, the sweep starts
    at the first point and turns that way. Otherwise (an unordered cloud, or ``clockwise`` given) it
    starts behind the sensor and turns ``clockwise`` (seen from above, as Velodyne, Ouster and Hesai
    heads do; counterclockwise when False) over ``sweep_s``."""
    az = np.arctan2(points[:, 1], points[:, 0])  # (-pi, pi], 0 straight ahead
    seen = az[np.isfinite(az)]  # NaN points (organized clouds) keep their place but tell nothing
    if clockwise is None and len(seen) > 1:
        winding = float(np.sum(np.angle(np.exp(1j * np.diff(seen)))))  # the steps, each within (-pi, pi]
        if abs(winding) >= np.pi:
            turn = np.mod((az - seen[0]) * np.sign(winding), 2 * np.pi)
            return turn / (2 * np.pi) * sweep_s
    turn = -az if clockwise in (True, None) else az
    return (turn + np.pi) / (2 * np.pi) * sweep_s
