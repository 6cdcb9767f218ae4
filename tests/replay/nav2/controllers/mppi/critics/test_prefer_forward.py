"""``PreferForwardCritic``: Nav2's test vector (critics_tests.cpp)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.replay.nav2.controllers.mppi.unit_setup import critic_data, full, make_critic


def test_prefer_forward_critic_vector():
    path = np.zeros((10, 3))
    c = make_critic("PreferForwardCritic")
    d = critic_data(pose=(1.0, 0.0, 0.0), goal=(0.15, 0.0), path=path, vx=full(1.0))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = critic_data(pose=(1.0, 0.0, 0.0), goal=(0.15, 0.0), path=path, vx=full(-1.0))
    c.score(d)
    assert d.costs[0] == pytest.approx(15.0, abs=1e-3)  # 1.0 * 0.1 dt * 5.0 weight * 30
