"""The degraded odometry the SLAM benchmark measures against: each kind of error does what it says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.replay.mapping.odometry_errors import ODOMETRY_ERRORS, degraded_odometry


def square_tour() -> np.ndarray:
    """A 4 x 4 m square driven once counter-clockwise in 1 m steps, turning a quarter at each corner."""
    poses, x, y, yaw = [], 0.0, 0.0, 0.0
    for _ in range(4):
        for _ in range(4):
            poses.append((x, y, yaw))
            x, y = x + math.cos(yaw), y + math.sin(yaw)
        poses.append((x, y, yaw))
        yaw += math.pi / 2
    poses.append((x, y, yaw))
    return np.array(poses)


def test_a_zero_error_gives_the_odometry_back():
    tour = square_tour()
    for kind in ODOMETRY_ERRORS:
        assert np.allclose(degraded_odometry(tour, kind, 0.0), tour, atol=1e-12)


def test_each_error_degrades_the_increments_as_named():
    tour = square_tour()
    turned = degraded_odometry(tour, "turn", 0.1)
    assert turned[-1, 2] == pytest.approx(1.1 * 2 * math.pi)  # four quarter turns, each 10 % too much
    assert np.allclose(turned[:5, :2], tour[:5, :2])  # the first side, before any turn, is as driven
    longer = degraded_odometry(tour, "length", 0.1)
    assert np.allclose(longer[:, :2], 1.1 * tour[:, :2]) and np.allclose(longer[:, 2], tour[:, 2])
    drifted = degraded_odometry(tour, "drift", 0.01)
    assert drifted[-1, 2] - tour[-1, 2] == pytest.approx(0.16)  # 16 m travelled
    noisy = degraded_odometry(tour, "noise", 0.05)
    assert np.array_equal(noisy, degraded_odometry(tour, "noise", 0.05))  # seeded: the same every time
    steps = np.hypot(*np.diff(noisy[:, :2], axis=0).T)
    assert 0 < np.abs(steps[steps > 0.5] - 1.0).max() < 0.25  # 1 m steps off by a few centimetres
    with pytest.raises(ValueError, match="one of turn, length, drift, noise"):
        degraded_odometry(tour, "slip", 0.1)
