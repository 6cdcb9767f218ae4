"""Wheel odometry made worse than a log's own, for measuring how the SLAM copes with it.

``degraded_odometry`` takes the odometry poses at a log's scan stamps, degrades each increment between
them in the robot's frame (``ODOMETRY_ERRORS``: turns or step lengths scaled, a heading drift per metre,
seeded Gaussian noise) and composes them again from the first pose. Used by
``benchmarks/bench_slam_datasets.py --odometry-error`` and ``tests/replay/mapping/test_odometry_errors.py``.
"""

from __future__ import annotations

import math

import numpy as np

ODOMETRY_ERRORS = {
    "turn": "every turn scaled by 1 + VALUE (each step keeps its direction in the robot's frame)",
    "length": "every step's length scaled by 1 + VALUE",
    "drift": "VALUE rad of heading added per metre travelled",
    "noise": "each step's length and turn perturbed by Gaussian noise of VALUE times their size (seeded)",
}


def degraded_odometry(odom: np.ndarray, kind: str, value: float) -> np.ndarray:
    """``odom`` (n, 3) with its increments (in the robot's frame) degraded as ``ODOMETRY_ERRORS[kind]`` says and
    composed again from its first pose: wheel odometry worse than the dataset's own."""
    if kind not in ODOMETRY_ERRORS:
        raise ValueError(f"odometry error {kind!r}: one of {', '.join(ODOMETRY_ERRORS)}")
    rng = np.random.default_rng(0)
    out = [odom[0].copy()]
    for a, b in zip(odom[:-1], odom[1:], strict=True):
        c, s = math.cos(a[2]), math.sin(a[2])
        dx, dy = b[0] - a[0], b[1] - a[1]
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        turn = math.remainder(b[2] - a[2], 2 * math.pi)
        step = math.hypot(lx, ly)
        if kind == "turn":
            turn *= 1 + value
        elif kind == "length":
            lx, ly = lx * (1 + value), ly * (1 + value)
        elif kind == "drift":
            turn += value * step
        elif kind == "noise":
            lx, ly = lx + rng.normal() * value * step, ly + rng.normal() * value * step
            turn += rng.normal() * value * (abs(turn) + 0.2 * step)
        o = out[-1]
        co, so = math.cos(o[2]), math.sin(o[2])
        out.append(np.array([o[0] + co * lx - so * ly, o[1] + so * lx + co * ly, o[2] + turn]))
    return np.array(out)
