"""``GoalCritic``: Nav2's test vector (critics_tests.cpp)."""

from __future__ import annotations

import pytest

from tests.replay.nav2.controllers.mppi.unit_setup import critic_data, make_critic


def test_goal_critic_vector():
    c = make_critic("GoalCritic")
    d = critic_data(pose=(1.0, 0.0, 0.0), goal=(0.5, 0.0))
    c.score(d)
    assert d.costs[0] == pytest.approx(2.5, abs=1e-5)  # 0.5 m * weight 5
    assert d.costs.sum() == pytest.approx(2500.0, rel=1e-5)
    d = critic_data(pose=(10.0, 0.0, 0.0), goal=(0.5, 0.0))  # beyond threshold_to_consider 1.4
    c.score(d)
    assert d.costs.sum() == 0.0
