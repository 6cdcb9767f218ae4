"""The geometry of a sensor_msgs/LaserScan: whether its angle fields and beam count agree, and its beam angles.

A scan's beams lie at ``angle_min + i * angle_increment`` for ``i < len(ranges)``. Drivers end the
sweep either at the last beam (``angle_max = angle_min + (n - 1) * angle_increment``, REP 117's
reading) or one increment past it (a full turn of ``n`` beams, as navlog's recorder writes it), so
``(angle_max - angle_min) / angle_increment`` must lie within half a beam of ``n - 1`` or ``n``. A
scan outside that (an increment of 0, of the sign opposite to ``angle_max - angle_min``, or a beam
count the limits do not give) would place its ranges at the wrong bearings: every consumer skips it
and counts it under its ``fault`` and ``navlog check`` fails the topic.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

NOT_FINITE = "NaN or infinite angle/range fields"
ZERO_INCREMENT = "angle_increment is 0"
WRONG_SIGN = "angle_increment of the wrong sign for angle_min..angle_max"
INCONSISTENT = "len(ranges) inconsistent with angle_min, angle_max and angle_increment"
ANGLE_SETS_KEPT = 16  # ScanAngles keeps the angles of this many (angle_min, increment, beams) at most


def geometry_fault(angle_min: float, angle_max: float, angle_increment: float, beams: int) -> str | None:
    """Why a scan's angle fields and beam count cannot be used together (one of this module's
    constants), or None when they agree."""
    if not all(math.isfinite(v) for v in (angle_min, angle_max, angle_increment)):
        return NOT_FINITE
    if angle_increment == 0.0:
        return ZERO_INCREMENT
    steps = (angle_max - angle_min) / angle_increment  # beams - 1 (last beam at angle_max) or beams
    if steps < -0.5:
        return WRONG_SIGN
    if not abs(beams - 0.5 - steps) <= 1.0:  # also refuses an infinite quotient (a subnormal increment)
        return INCONSISTENT
    return None


def scan_fault(msg: Any) -> str | None:
    """``geometry_fault`` of a LaserScan message, with NaN range limits refused too."""
    if math.isnan(msg.range_min) or math.isnan(msg.range_max):
        return NOT_FINITE
    return geometry_fault(msg.angle_min, msg.angle_max, msg.angle_increment, len(msg.ranges))


class ScanAngles:
    """The beam angles of LaserScan messages (``angle_min + i * angle_increment``), computed once per
    (angle_min, angle_increment, beam count); None for a scan whose fields cannot be used (``fault``
    then says why)."""

    def __init__(self) -> None:
        self._cache: dict[tuple[float, float, int], np.ndarray] = {}
        self.fault: str | None = None  # why the last scan given had no angles

    def __call__(self, msg: Any) -> np.ndarray | None:
        self.fault = scan_fault(msg)
        if self.fault is not None:
            return None
        key = (float(msg.angle_min), float(msg.angle_increment), len(msg.ranges))
        angles = self._cache.get(key)
        if angles is None:
            if len(self._cache) >= ANGLE_SETS_KEPT:  # a log whose scans all differ: the cache stays bounded
                self._cache.clear()
            angles = self._cache[key] = msg.angle_min + msg.angle_increment * np.arange(len(msg.ranges))
        return angles
