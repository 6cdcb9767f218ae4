"""``VelocityDeadbandCritic``: Nav2's test vector (critics_tests.cpp)."""

from __future__ import annotations

import pytest

from tests.replay.nav2.controllers.mppi.unit_setup import critic_data, full, make_critic


def test_velocity_deadband_critic_vector():
    c = make_critic("VelocityDeadbandCritic", deadband_velocities=(0.08, 0.08, 0.08))
    d = critic_data(holonomic=True, vx=full(0.8), vy=full(0.6), wz=full(0.8))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = critic_data(holonomic=True, vx=full(0.01), vy=full(0.02), wz=full(0.021))
    c.score(d)
    assert d.costs[1] == pytest.approx(19.845, abs=0.01)  # 35 * 0.1 * (0.07 + 0.06 + 0.059) * 30
