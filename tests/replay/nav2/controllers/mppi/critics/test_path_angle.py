"""``PathAngleCritic``: Nav2's test vectors (critics_tests.cpp) and its modes."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from tests.replay.nav2.controllers.mppi.unit_setup import critic_data, make_critic


def test_path_angle_critic_vectors():
    path = np.zeros((10, 3))
    path[9, 0] = 0.95
    cases = [(0, (1.0, 0.0), 0.0), (0, (-1.0, 4.0), 3.9947), (1, (1.0, 0.0), 0.0), (1, (-1.0, 0.0), 0.0)]
    cases += [(1, (-1.0, 4.0), 2.9167), (2, (1.0, 0.0), 0.0), (2, (-1.0, 0.0), 0.0), (2, (-1.0, 4.0), 2.9167)]
    for mode, point, expected in cases:
        path[6, :2] = point
        c = make_critic("PathAngleCritic", mode=mode)
        d = critic_data(goal=(0.95, 0.0), path=path.copy())
        d.furthest = 2  # so it takes point 2 + offset_from_furthest 4 = 6
        c.score(d)
        assert d.costs[0] == pytest.approx(expected, abs=1e-2), (mode, point)
    # within the goal's threshold it does nothing
    d = critic_data(goal=(0.15, 0.0), path=path.copy())
    make_critic("PathAngleCritic").score(d)
    assert d.costs.sum() == 0.0


def test_path_angle_mode_1_without_reversing_is_forward_preference():
    c = make_critic("PathAngleCritic", MPPIParams(vx_min=0.0), mode=1)
    assert c.mode == 0
