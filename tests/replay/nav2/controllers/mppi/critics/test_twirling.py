"""``TwirlingCritic``: Nav2's test vector (critics_tests.cpp)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.replay.nav2.controllers.mppi.unit_setup import B, T, critic_data, make_critic


def test_twirling_critic_vector():
    c = make_critic("TwirlingCritic")
    wz = np.zeros((B, T), dtype=np.float32)
    wz[0] = 10.0
    d = critic_data(pose=(1.0, 0.0, 0.0), goal=(0.15, 0.0), wz=wz)
    c.score(d)
    assert d.costs[0] == pytest.approx(100.0, abs=1e-4)
    assert d.costs[1:].sum() == 0.0
    d = critic_data(pose=(0.2, 0.0, 0.0), goal=(0.15, 0.0), wz=wz)  # inside the goal checker's 0.25 m
    c.score(d)
    assert d.costs.sum() == 0.0
