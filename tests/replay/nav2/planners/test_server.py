"""The planner server's checks around a planner: the goal's own potential first, a start in an obstacle."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.nav2.planners import NavfnParams, NavfnPlanner, PlanningError, Smac2DPlanner, make_planner
from navlog.replay.nav2.planners.server import PlannerServerParams, start_in_obstacle
from tests.replay.nav2.planners.grids import Grid


def navfn(tolerance: float) -> NavfnPlanner:
    server = PlannerServerParams(planners={"GridBased": NavfnParams(tolerance=tolerance)})
    planner = make_planner(server, "navfn")
    assert isinstance(planner, NavfnPlanner) and planner.p.tolerance == tolerance
    return planner


def open_space(res: float = 0.03, n: int = 100) -> Grid:
    return Grid(np.zeros((n, n), dtype=np.uint8), resolution=res)


@pytest.mark.parametrize("goal", [(2.0, 1.5, 0.3), (1.013, 2.2, 0.0), (0.5, 0.5, 1.0)])
def test_a_reachable_goal_is_planned_to_as_given(goal):
    # a 0.03 m map in open space, tolerance 0.1: samples at goal - 0.1 + k * 0.03 miss the goal itself
    # (the closest lies 0.01 m away), so a search without Nav2's goal check moves every goal
    plan = navfn(0.1).plan(open_space(), (0.3, 0.3, 0.0), goal)
    assert plan.goal_used == goal
    assert tuple(plan.poses[-1, :2]) == pytest.approx(goal[:2], abs=1e-12)
    assert not any("tolerance moved" in n for n in plan.notes)


def test_an_unreachable_goal_still_moves_within_the_tolerance():
    g = open_space()
    g.costs[60:70, 60:70] = 254  # a block; the goal (1.95, 1.95) is inside it, 0.15 m from its edge
    plan = navfn(0.3).plan(g, (0.3, 0.3, 0.0), (1.95, 1.95, 0.0))
    gx, gy, _ = plan.goal_used
    assert np.hypot(gx - 1.95, gy - 1.95) == pytest.approx(0.15, abs=0.031)  # to the block's edge
    assert any("tolerance moved" in n for n in plan.notes)


@pytest.mark.parametrize("planner", ["navfn", "smac2d"])
def test_a_start_inside_a_wall_is_said_to_be_in_an_obstacle(planner):
    g = open_space()
    g.costs[:, 40:50] = 254  # a wall x 1.2 .. 1.5 m, 10 cells thick
    chosen = make_planner(None, planner)
    assert isinstance(chosen, NavfnPlanner if planner == "navfn" else Smac2DPlanner)
    with pytest.raises(PlanningError, match=r"the start \(1\.35, 1\.00\) is in an obstacle \(cost 254, lethal"):
        chosen.plan(g, (1.35, 1.0, 0.0), (2.5, 1.0, 0.0))
    # from a free cell the same goal is planned
    assert chosen.plan(g, (2.0, 1.0, 0.0), (2.5, 1.0, 0.0)).length == pytest.approx(0.5, abs=0.05)


def test_start_in_obstacle_names_the_cost():
    g = open_space()
    g.costs[10, 10] = 253
    g.costs[10, 11] = 254
    assert "cost 253, inscribed" in start_in_obstacle(g, (0.31, 0.31, 0.0))
    assert "cost 254, lethal" in start_in_obstacle(g, (0.34, 0.31, 0.0))
    assert start_in_obstacle(g, (0.5, 0.5, 0.0)) == "" and start_in_obstacle(g, (-1.0, 0.5, 0.0)) == ""
