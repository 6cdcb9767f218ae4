"""``CostCritic``: collisions, the fail flag, the footprint check."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.nav2.controllers.base import ControllerSetup
from navlog.replay.nav2.controllers.mppi.critics.cost import CostCritic, CostCriticParams
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from tests.replay.nav2.controllers.mppi.unit_setup import B, T, critic_data, full, make_critic, nav2_test_costmap


def test_cost_critic_costs_collisions_and_fail_flag():
    c = make_critic("CostCritic")
    cm = nav2_test_costmap()
    cm.costs[:, 20:25] = 100  # a band of inflation at x 2.0-2.5 m
    cm.costs[:, 40:42] = 254  # a wall at x 4.0-4.2 m
    x = np.full((B, T), 2.2, dtype=np.float32)
    x[1] = 0.5  # free
    x[2, 20:] = 4.1  # ends in the wall
    y = np.full((B, T), 1.0, dtype=np.float32)
    d = critic_data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=x, y=y)
    d.costmap = cm
    c.score(d)
    assert d.costs[0] == pytest.approx(3.81 / 254 * 100, rel=1e-5)  # every sampled point at 100
    assert d.costs[1] == 0.0
    assert d.costs[2] == pytest.approx(3.81 / 254 * 1e6 / 15, rel=1e-5)  # collision_cost / 15 samples
    assert d.fail_flag is False
    d = critic_data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=full(4.1), y=y)
    d.costmap = cm
    c.score(d)
    assert d.fail_flag is True
    # near the goal, plain cost adds nothing; off the map is a collision (unknown space not tracked)
    d = critic_data(pose=(2.2, 1.0, 0.0), goal=(2.3, 1.0), x=x, y=y)
    d.costmap = cm
    c.score(d)
    assert d.costs[0] == 0.0
    d = critic_data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=full(-1.0), y=y)
    c.score(d)
    assert d.fail_flag is True


def test_cost_critic_footprint_check_lets_a_polygon_pass_beside_an_inscribed_cell():
    # a 0.2 x 0.2 m square robot; an inscribed (253) cell under its centre but nothing under its outline
    setup = ControllerSetup(footprint=np.array([[0.1, 0.1], [0.1, -0.1], [-0.1, -0.1], [-0.1, 0.1]]))
    params = CostCriticParams(consider_footprint=True)
    critic = CostCritic(params, MPPIParams(), setup)
    d = critic_data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=full(2.05), y=full(2.05))
    d.costmap.costs[20, 20] = 253
    critic.score(d)
    assert d.fail_flag is False and d.costs[0] == pytest.approx(3.81 / 254 * 300, rel=1e-5)  # critical_cost
    d = critic_data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=full(2.05), y=full(2.05))
    d.costmap.costs[20, 20] = 253
    d.costmap.costs[21, 19:23] = 254  # a lethal row under the square's top edge (y = 2.15)
    critic.score(d)
    assert d.fail_flag is True
