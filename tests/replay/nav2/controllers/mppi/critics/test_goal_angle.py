"""``GoalAngleCritic``: Nav2's test vector (critics_tests.cpp)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.replay.nav2.controllers.mppi.unit_setup import critic_data, make_critic


def test_goal_angle_critic_vector():
    path = np.zeros((10, 3))
    path[9] = (10.0, 0.0, 3.14)
    c = make_critic("GoalAngleCritic")
    for x, expected in ((1.0, 0.0), (9.2, 0.0), (9.7, 9.42)):
        d = critic_data(pose=(x, 0.0, 0.0), goal=(10.0, 0.0), path=path)
        c.score(d)
        assert d.costs[0] == pytest.approx(expected, abs=0.02)
