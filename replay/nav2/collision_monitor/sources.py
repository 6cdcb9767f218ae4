"""The collision monitor's sources as points in the base frame (Nav2 Jazzy ``scan.cpp``,
``pointcloud.cpp``, ``range.cpp``, ``source.cpp``).

The node finds the transform (a 4x4 matrix taking sensor points into the base frame); these
functions apply Nav2's selection rules and return ``(N, 2)`` points. A source whose data cannot be
used returns ``None``; the monitor then stops the robot ("invalid source") unless the source's
``source_timeout`` is 0.

- scan: a beam is kept when ``range_min <= r <= range_max`` (both inclusive, unlike the costmap's
  projection); beam angles accumulate in float32 as Nav2's ``float angle += angle_increment`` does;
- pointcloud: a point nearer than ``min_range`` to the sensor is dropped, the rest transformed, and
  kept when ``min_height <= z <= max_height`` in the base frame;
- range: a reading outside ``[min_range, max_range]`` (+inf "no echo" included) makes the source
  invalid; otherwise points at
  the range from ``-fov/2`` below ``fov/2`` every ``obstacles_angle`` (float32 steps), plus ``fov/2``.
"""

from __future__ import annotations

import functools
import math

import numpy as np


def source_fresh(stamp_ns: int, now_ns: int, timeout_s: float) -> bool:
    """Nav2's staleness rule: data is too old when ``now - stamp > source_timeout`` (0 turns it off)."""
    return timeout_s == 0.0 or (now_ns - stamp_ns) <= round(timeout_s * 1e9)


def to_base(points: np.ndarray, transform: np.ndarray) -> np.ndarray:
    """(N, 3) sensor points into the base frame with a 4x4 transform (base <- sensor)."""
    out = points @ transform[:3, :3].T
    out += transform[:3, 3]
    return out


def planar_points_beyond(transform: np.ndarray, nearest: float, reach: float) -> bool:
    """True when every sensor point in its z = 0 plane at least ``nearest`` from the sensor origin lies
    farther than ``reach`` from the base origin in x, y once ``transform`` (base <- sensor) maps it,
    by a margin (1 um, 1e-9 relative) far above the rounding of ``to_base`` and of a distance.

    A point p of the plane maps to ``A p + t`` (A the 2x2 block of the transform, t its x, y shift),
    at least ``s |p| - |t|`` from the base origin, s the smaller singular value of A; False when that
    bound says nothing (a sensor tilted so that s < 0.5, NaN). ``nearest`` may be off by rounding (a
    least range for the computed points' least distance): the margin covers it."""
    (a, b, _, tx), (c, d, _, ty) = transform[:2].tolist()
    return planar_block_beyond((a, b, c, d, tx, ty), nearest, reach)


def planar_block_beyond(block: tuple[float, float, float, float, float, float], nearest: float, reach: float) -> bool:
    """``planar_points_beyond`` of a transform given as its 2x2 block and x, y shift, ``(a, b, c, d, tx, ty)``
    for ``[[a, b], [c, d]]`` (plain floats; any values within rounding of the transform's will do)."""
    a, b, c, d, tx, ty = block
    s = 0.5 * (math.hypot(a + d, c - b) - math.hypot(a - d, b + c))
    return s > 0.5 and s * nearest * (1.0 - 1e-9) - math.hypot(tx, ty) * (1.0 + 1e-9) > reach + 1e-6


@functools.lru_cache(maxsize=16)
def _beam_directions(count: int, angle_min: float, angle_increment: float) -> tuple[np.ndarray, np.ndarray]:
    """The cosines and sines of a scan's ``count`` beam angles (read-only; kept for the next scan of
    the same geometry). The angles accumulate in float32 as Nav2's ``float angle += angle_increment``
    does, and are widened to float64 before the cosine and sine."""
    steps = np.full(count, np.float32(angle_increment), dtype=np.float32)
    if count:
        steps[0] = np.float32(angle_min)
    angles = np.cumsum(steps, dtype=np.float32).astype(np.float64)  # sequential float32 sums, as in Nav2
    cos, sin = np.cos(angles), np.sin(angles)
    cos.flags.writeable = sin.flags.writeable = False
    return cos, sin


def scan_points(
    ranges: np.ndarray, angle_min: float, angle_increment: float, range_min: float, range_max: float
) -> np.ndarray:
    """A LaserScan's kept beams as (N, 3) points in the sensor frame (z = 0)."""
    return scan_points_nearest(ranges, angle_min, angle_increment, range_min, range_max)[0]


def scan_nearest(ranges: np.ndarray, range_min: float, range_max: float) -> float:
    """A LaserScan's least kept range (inf when none is), as ``scan_points_nearest`` gives it, without the points."""
    r = np.asarray(ranges, dtype=np.float32)
    kept = r[(r >= np.float32(range_min)) & (r <= np.float32(range_max))]
    return float(kept.min()) if len(kept) else math.inf


def scan_points_nearest(
    ranges: np.ndarray, angle_min: float, angle_increment: float, range_min: float, range_max: float
) -> tuple[np.ndarray, float]:
    """``scan_points`` and the least range kept (inf when none is): the points' least distance from the
    sensor, to rounding (1e-15 relative; ``planar_points_beyond``'s margin is far wider)."""
    r = np.asarray(ranges, dtype=np.float32)
    cos, sin = _beam_directions(len(r), float(angle_min), float(angle_increment))
    keep = (r >= np.float32(range_min)) & (r <= np.float32(range_max))  # NaN compares False, quietly
    rk = r[keep].astype(np.float64)
    out = np.zeros((len(rk), 3))
    np.multiply(rk, cos[keep], out=out[:, 0])
    np.multiply(rk, sin[keep], out=out[:, 1])
    return out, float(rk.min()) if len(rk) else math.inf


def cloud_points(
    points: np.ndarray, transform: np.ndarray, min_height: float, max_height: float, min_range: float = 0.0
) -> np.ndarray:
    """A point cloud's (N, 3) sensor-frame points as (M, 2) base-frame points within the height band."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if min_range > 0.0:
        p = p[np.linalg.norm(p, axis=1) >= min_range]
    base = to_base(p, transform)
    keep = (base[:, 2] >= min_height) & (base[:, 2] <= max_height)
    return base[keep, :2]


def range_points(
    distance: float, min_range: float, max_range: float, field_of_view: float, obstacles_angle: float
) -> np.ndarray | None:
    """A Range reading as an arc of (N, 3) sensor-frame points; None when outside [min_range, max_range]."""
    if distance < min_range or distance > max_range:
        return None
    if distance != distance:  # NaN passes Nav2's test and gives points that are inside nothing
        return np.zeros((0, 3))
    half = np.float32(field_of_view) / np.float32(2.0)
    step = np.float32(obstacles_angle)
    angles = []
    a = -half
    while a < half:
        angles.append(float(a))
        a = np.float32(a + step)
    angles.append(float(half))
    ang = np.asarray(angles)
    d = float(np.float32(distance))
    return np.column_stack([d * np.cos(ang), d * np.sin(ang), np.zeros_like(ang)])
