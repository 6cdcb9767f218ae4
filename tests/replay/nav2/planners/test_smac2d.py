"""The Smac-2D-like planner on hand-built grids, against a brute-force Dijkstra."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay.nav2.planners import PlanningError, Smac2DParams, Smac2DPlanner
from tests.replay.nav2.planners.grids import RES, boxed_goal, brute_force_cost, wall_with_gap


def test_smac2d_matches_brute_force():
    g = wall_with_gap()
    g.costs[5:25, 10:20] = 200  # an expensive patch on the direct diagonal
    p = Smac2DParams()
    plan = Smac2DPlanner(p).plan(g, (1.05, 1.05, 0.0), (5.05, 1.05, 0.0))
    step = np.where(g.costs >= 253, np.inf, 1.0 + p.cost_travel_multiplier * g.costs / 252.0)
    ref = brute_force_cost(step, (10, 10), (50, 10)) * RES
    assert plan.cost == pytest.approx(ref, rel=1e-9)
    at_wall = plan.poses[np.abs(plan.poses[:, 0] - 3.05) < 0.05]
    assert (at_wall[:, 1] > 3.0).all() and (at_wall[:, 1] < 3.7).all()


def test_smac2d_tolerance():
    g = boxed_goal()
    with pytest.raises(PlanningError, match="tolerance >= "):
        Smac2DPlanner(Smac2DParams(tolerance=0.0)).plan(g, (1.0, 1.0, 0.0), (4.05, 4.05, 0.0))
    plan = Smac2DPlanner(Smac2DParams(tolerance=0.4)).plan(g, (1.0, 1.0, 0.0), (4.05, 4.05, 0.0))
    assert math.hypot(plan.poses[-1, 0] - 4.05, plan.poses[-1, 1] - 4.05) == pytest.approx(0.3)
