"""What planners share: the cost of a path over a cost grid, the start and goal checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay.nav2.planners import NavfnParams, NavfnPlanner, PlanningError, Smac2DParams, Smac2DPlanner, path_cost
from tests.replay.nav2.planners.grids import RES, free_grid


def test_path_cost_of_known_segments():
    # 20 x 5 cells at 0.1 m: cost 50 (one unit per metre) for x < 1.0 m, 100 (two units) beyond
    cell_cost = np.full((5, 20), 50, dtype=np.int16)
    cell_cost[:, 10:] = 100
    xs = np.linspace(0.2, 1.8, 33)  # 32 steps of 0.05 m: 16 on each side of x = 1.0
    fine = np.column_stack([xs, np.full(33, 0.25), np.zeros(33)])
    assert path_cost(fine, cell_cost, RES, (0.0, 0.0), 50.0) == pytest.approx(0.8 * 1 + 0.8 * 2, rel=1e-12)
    # one 1.6 m segment: 64 samples, 32 on each side
    assert path_cost(fine[[0, -1]], cell_cost, RES, (0.0, 0.0), 50.0) == pytest.approx(1.6 * 75 / 50, rel=1e-12)
    # repeated points add nothing; a single point costs nothing
    doubled = np.repeat(fine, 2, axis=0)
    assert path_cost(doubled, cell_cost, RES, (0.0, 0.0), 50.0) == path_cost(fine, cell_cost, RES, (0.0, 0.0), 50.0)
    assert path_cost(fine[:1], cell_cost, RES, (0.0, 0.0), 50.0) == 0.0


@pytest.mark.parametrize(
    "planner", [NavfnPlanner(NavfnParams()), Smac2DPlanner(Smac2DParams())], ids=["navfn", "smac2d"]
)
def test_far_or_non_finite_start_or_goal_is_outside_the_costmap(planner):
    g = free_grid()  # 60 x 60 cells of 0.1 m: x and y [0.00, 6.00)
    extent = r"is outside the costmap x \[0\.00, 6\.00\), y \[0\.00, 6\.00\)$"
    with pytest.raises(PlanningError, match=r"^start \(1e\+308, 1\.00\) " + extent):
        planner.plan(g, (1e308, 1.0, 0.0), (5.0, 5.0, 0.0))
    with pytest.raises(PlanningError, match=r"^goal \(1\.00, -1e\+308\) " + extent):
        planner.plan(g, (1.0, 1.0, 0.0), (1.0, -1e308, 0.0))
    with pytest.raises(PlanningError, match=r"^goal \(inf, nan\) " + extent):
        planner.plan(g, (1.0, 1.0, 0.0), (math.inf, math.nan, 0.0))
    with pytest.raises(PlanningError, match=r"^goal \(6\.00, 1\.00\) " + extent):
        planner.plan(g, (1.0, 1.0, 0.0), (6.0, 1.0, 0.0))
    assert len(planner.plan(g, (0.0, 1.0, 0.0), (5.0, 5.0, 0.0)).poses) > 1  # from the lower edge (x = 0 is inside)
