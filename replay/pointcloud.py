"""PointCloud2 <-> numpy, honouring field offsets, point_step, row_step and endianness.

navlog's 3D LiDAR publishes the Velodyne-style layout FAST-LIO's `lidar_type: 2` expects:
x, y, z, intensity float32 at 0/4/8/12, ring uint16 at 16, time float32 at 18 (point_step 22).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navlog.replay import messages

# sensor_msgs/PointField datatypes
_DTYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}
_CODES = {np.dtype(v).newbyteorder("<").str[1:]: k for k, v in _DTYPES.items()}

VELODYNE_FIELDS = (("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 12, 7), ("ring", 16, 4), ("time", 18, 7))
VELODYNE_POINT_STEP = 22


def cloud_dtype(fields: Any, point_step: int, big_endian: bool = False) -> np.dtype:
    """Structured dtype for a PointCloud2's `fields` (count > 1 becomes a sub-array)."""
    order = ">" if big_endian else "<"
    names, formats, offsets = [], [], []
    for f in fields:
        base = order + _DTYPES[int(f.datatype)]
        names.append(f.name)
        formats.append((base, (int(f.count),)) if int(f.count) > 1 else base)
        offsets.append(int(f.offset))
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": int(point_step)})


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
