"""``PathFollowCritic``: Nav2's test vector (critics_tests.cpp)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.replay.nav2.controllers.mppi.unit_setup import critic_data, make_critic


def test_path_follow_critic_vector():
    c = make_critic("PathFollowCritic")
    path = np.zeros((6, 3))
    path[5, 0] = 1.8
    d = critic_data(pose=(2.0, 0.0, 0.0), goal=(1.8, 0.0), path=path.copy())
    c.score(d)
    assert d.costs.sum() == 0.0
    path[5, 0] = 0.15
    d = critic_data(pose=(2.0, 0.0, 0.0), goal=(0.15, 0.0), path=path)
    c.score(d)
    assert d.costs.sum() == pytest.approx(750.0, abs=1e-2)  # 0.15 * 5 weight * 1000
