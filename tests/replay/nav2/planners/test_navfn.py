"""NavFn on hand-built grids, against a brute-force Dijkstra; the compiled kernels against the plain Python ones."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay.nav2.planners import NavfnParams, NavfnPlanner, PlanningError
from navlog.replay.nav2.planners.navfn import navfn_costs, navfn_potential
from tests.replay.nav2.planners.grids import RES, Grid, boxed_goal, free_grid, navfn_reference, wall_with_gap


def test_cost_conversion():
    costs = np.array(
        [[0, 0, 0, 0, 0, 0], [0, 0, 100, 252, 253, 0], [0, 254, 255, 0, 0, 0], [0, 0, 0, 0, 0, 0]], dtype=np.uint8
    )
    c = navfn_costs(costs, allow_unknown=True)
    assert c[1, 1:5].tolist() == [50, 130, 251, 254]
    assert c[2, 1:3].tolist() == [254, 253]
    assert (c[0] == 254).all() and (c[:, 0] == 254).all() and (c[:, -1] == 254).all()
    assert navfn_costs(costs, allow_unknown=False)[2, 2] == 254


@pytest.mark.parametrize("potential", ["exact", "python"])
def test_free_map_straight_diagonal(potential):
    g = free_grid()
    plan = NavfnPlanner(NavfnParams(), potential=potential).plan(g, (1.0, 1.0, 0.0), (5.0, 5.0, 0.7))
    assert plan.poses[0, :2] == pytest.approx((1.0, 1.0), abs=0.11)
    assert plan.poses[-1].tolist() == pytest.approx([5.0, 5.0, 0.7])
    assert plan.length == pytest.approx(4 * math.sqrt(2), rel=0.02)
    # every point within a cell of the straight line
    assert np.abs(plan.poses[:, 0] - plan.poses[:, 1]).max() < 0.1
    ref = navfn_reference(g, (1.0, 1.0), (5.0, 5.0))
    assert ref == pytest.approx(4 * math.sqrt(2))
    assert plan.cost == pytest.approx(ref, rel=0.01)


@pytest.mark.parametrize("potential", ["exact", "python"])
def test_wall_with_gap(potential):
    g = wall_with_gap()
    plan = NavfnPlanner(NavfnParams(), potential=potential).plan(g, (1.0, 1.0, 0.0), (5.1, 1.0, 0.0))
    at_wall = plan.poses[np.abs(plan.poses[:, 0] - 3.05) < 0.1]
    assert len(at_wall) and (at_wall[:, 1] >= 2.95).all() and (at_wall[:, 1] <= 3.7).all()
    ref = navfn_reference(g, (1.0, 1.0), (5.1, 1.0))
    # 20 diagonal steps to the gap's lowest cell (30, 30), one across, 20 diagonal down: also the any-angle optimum
    assert ref == pytest.approx((40 * math.sqrt(2) + 1) * RES)
    assert plan.cost == pytest.approx(ref, rel=0.01)


def test_compiled_and_python_potentials_are_the_same_bits():
    g = wall_with_gap()
    c = navfn_costs(g.costs)
    for use_astar in (False, True):
        a = navfn_potential(c, (10, 10), (50, 10), use_astar, "exact")
        b = navfn_potential(c, (10, 10), (50, 10), use_astar, "python")
        assert a.dtype == np.float32 and a.tobytes() == b.tobytes()
        assert a[10, 50] < 1e9
    # along the row next to the wall's foot... the seed's own row is open space: the quadratic update applies,
    # but the 4 cells beside the seed are one cost step away: 50
    assert a[10, 11] == 50.0 and a[11, 10] == 50.0


def test_astar_reaches_the_same_path_cost():
    g = wall_with_gap()
    dijkstra, astar = NavfnPlanner(NavfnParams()), NavfnPlanner(NavfnParams(use_astar=True))
    d = dijkstra.plan(g, (1.0, 1.0, 0.0), (5.0, 1.0, 0.0))
    a = astar.plan(g, (1.0, 1.0, 0.0), (5.0, 1.0, 0.0))
    # Nav2's A* stops when the goal first has a potential, a little above Dijkstra's (Nav2's navfn.cpp: 2958.5308
    # and 3095.0647 at the goal cell, 107 and 110 path points), so its path costs a little more
    assert dijkstra.last_potential is not None and astar.last_potential is not None
    assert dijkstra.last_potential[10, 50] == pytest.approx(2958.5308, rel=1e-6)
    assert astar.last_potential[10, 50] == pytest.approx(3095.0647, rel=1e-6)
    assert d.cost < a.cost < 1.03 * d.cost


def test_unreachable_goal_with_and_without_tolerance():
    g = boxed_goal()
    with pytest.raises(PlanningError, match="within tolerance 0.0 m"):
        NavfnPlanner(NavfnParams(tolerance=0.0)).plan(g, (1.0, 1.0, 0.0), (4.0, 4.0, 0.0))
    plan = NavfnPlanner(NavfnParams(tolerance=0.5)).plan(g, (1.0, 1.0, 0.0), (4.0, 4.0, 0.0))
    end = plan.poses[-1]
    # the nearest reachable point outside the 5-cell box around the pocket
    assert math.hypot(end[0] - 4.0, end[1] - 4.0) == pytest.approx(0.3, abs=0.05)
    assert plan.notes and "tolerance moved it" in plan.notes[0]


def test_goal_in_obstacle_message_says_what_tolerance_finds():
    g = free_grid()
    g.costs[30:40, 30:40] = 254
    with pytest.raises(PlanningError) as exc:
        NavfnPlanner(NavfnParams(tolerance=0.0)).plan(g, (1.0, 1.0, 0.0), (3.45, 3.45, 0.0))
    msg = str(exc.value)
    # the box spans 3.0 .. 4.0; the nearest free cell centre is 2.95, 0.5 m away
    assert "goal occupied" in msg and "tolerance >= 0.50" in msg


def test_start_or_goal_outside_and_unknown_only():
    g = free_grid()
    with pytest.raises(PlanningError, match="start .* outside the costmap"):
        NavfnPlanner(NavfnParams()).plan(g, (-1.0, 1.0, 0.0), (5.0, 5.0, 0.0))
    with pytest.raises(PlanningError, match="goal .* outside the costmap"):
        NavfnPlanner(NavfnParams()).plan(g, (1.0, 1.0, 0.0), (9.0, 5.0, 0.0))
    unknown = Grid(np.full((30, 30), 255, dtype=np.uint8))
    with pytest.raises(PlanningError, match="no free cell"):
        NavfnPlanner(NavfnParams(allow_unknown=False)).plan(unknown, (1.0, 1.0, 0.0), (2.0, 2.0, 0.0))
    plan = NavfnPlanner(NavfnParams(allow_unknown=True)).plan(unknown, (1.0, 1.0, 0.0), (2.0, 1.0, 0.0))
    assert plan.length == pytest.approx(1.0, abs=0.1)


def test_allow_unknown_changes_the_route():
    g = free_grid()
    g.costs[:, 25:35] = 255  # an unknown band between start and goal
    g.costs[50:, 25:35] = 0  # known free only near the top
    direct = NavfnPlanner(NavfnParams(allow_unknown=True)).plan(g, (1.0, 1.0, 0.0), (5.0, 1.0, 0.0))
    around = NavfnPlanner(NavfnParams(allow_unknown=False)).plan(g, (1.0, 1.0, 0.0), (5.0, 1.0, 0.0))
    assert direct.poses[:, 1].max() < 1.2
    assert around.poses[:, 1].max() > 4.9
    assert around.length > 2 * direct.length


def test_final_approach_orientation():
    g = free_grid()
    plan = NavfnPlanner(NavfnParams(use_final_approach_orientation=True)).plan(g, (1.0, 1.0, 0.0), (1.0, 4.0, 3.0))
    assert plan.poses[-1, 2] == pytest.approx(math.pi / 2, abs=0.05)


def _cluttered(seed: int) -> Grid:
    rng = np.random.default_rng(seed)
    g = free_grid(80)
    for _ in range(25):
        x, y = rng.integers(5, 70, 2)
        w, h = rng.integers(2, 7, 2)
        g.costs[y : y + h, x : x + w] = 254
    g.costs[:12, :12] = 0
    g.costs[-12:, -12:] = 0
    return g


@pytest.mark.parametrize("use_astar", [False, True])
def test_cluttered_plan_is_deterministic_and_near_the_reference(use_astar):
    g = _cluttered(4)
    planner = NavfnPlanner(NavfnParams(use_astar=use_astar))
    a = planner.plan(g, (0.5, 0.5, 0.0), (7.4, 7.4, 0.0))
    b = planner.plan(g, (0.5, 0.5, 0.0), (7.4, 7.4, 0.0))
    assert a.poses.tobytes() == b.poses.tobytes() and a.cost == b.cost
    assert np.array_equal(planner.last_potential, navfn_potential(navfn_costs(g.costs), (5, 5), (74, 74), use_astar))
    slow = NavfnPlanner(NavfnParams(use_astar=use_astar), potential="python").plan(g, (0.5, 0.5, 0.0), (7.4, 7.4, 0.0))
    assert slow.poses.tobytes() == a.poses.tobytes()
    # free cells only (cost 50): any-angle NavFn is at most the 8-connected optimum, and not far below it
    ref = navfn_reference(g, (0.5, 0.5), (7.4, 7.4))
    assert ref * 0.97 <= a.cost <= ref * 1.01
