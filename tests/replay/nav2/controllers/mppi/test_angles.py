"""The MPPI critics' angle difference: its sign and its wrap."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay.nav2.controllers.mppi.angles import signed_angle_from_to


def test_the_angle_from_a_to_b_is_b_minus_a_wrapped():
    assert signed_angle_from_to(0.0, 0.5) == pytest.approx(0.5)
    assert signed_angle_from_to(0.5, 0.0) == pytest.approx(-0.5)
    assert signed_angle_from_to(3.0, -3.0) == pytest.approx(2 * math.pi - 6.0)  # across pi: the short way
    assert signed_angle_from_to(-3.0, 3.0) == pytest.approx(6.0 - 2 * math.pi)
    assert signed_angle_from_to(0.0, math.pi) == pytest.approx(-math.pi)  # [-pi, pi): pi wraps to -pi


def test_the_angle_difference_is_element_wise_over_a_batch():
    a = np.array([[0.0, 1.0], [2.0, -2.0]], dtype=np.float32)
    got = signed_angle_from_to(a, 1.5)
    assert got.shape == (2, 2)
    assert got == pytest.approx(np.array([[1.5, 0.5], [-0.5, 3.5 - 2 * math.pi]]), abs=1e-6)
