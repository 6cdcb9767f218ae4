"""NavFn against Nav2's own numbers: hand-derived potentials and paths, Nav2's edge cases, the benchmark maps.

The benchmark maps' reference (``nav2_navfn_reference.npz``: Nav2's paths in cells and its potential on
every 20th cell) was written by Nav2's navfn.cpp itself, built around a harness by
``benchmarks/bench_planner.py --nav2-src DIR --write-reference FILE``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.distance import directed_hausdorff

from navlog.replay.nav2.planners import NavfnParams, NavfnPlanner, PlanningError
from navlog.replay.nav2.planners.base import path_length
from navlog.replay.nav2.planners.navfn import navfn_costs, navfn_path, navfn_potential, poses_from_cells
from navlog.replay.nav2.planners.navfn_kernels import PATH_FOUND, PATH_OUT_OF_CYCLES
from tests.replay.nav2.planners.grids import Grid, free_grid
from tests.replay.nav2.planners.navfn_maps import bench_maps

REFERENCE = Path(__file__).with_name("nav2_navfn_reference.npz")
F32 = np.float32


def test_potential_around_the_seed_by_hand():
    pot = navfn_potential(navfn_costs(np.zeros((20, 20), dtype=np.uint8)), (5, 5), (15, 5))
    # along the axes one free-cell cost (50) per cell: the other axis' neighbours are more than 50 higher
    assert pot[5, 5:16].tolist() == [50.0 * k for k in range(11)]
    assert pot[5, 4] == pot[4, 5] == pot[6, 5] == 50.0
    # the diagonal cell: both lowest neighbours at 50 (dc = 0): 50 + 50 * 0.7040, in float32
    assert pot[6, 6] == F32(50.0) + F32(50.0) * F32(0.7040) == pytest.approx(85.2, rel=1e-6)
    # (7, 6): lowest neighbours 85.2 (left) and 100 (up): r = 14.8 / 50 on NavFn's quadratic
    r = np.float64((F32(100.0) - pot[6, 6]) / F32(50.0))
    expected = pot[6, 6] + F32(50.0) * F32(-0.2301 * r * r + 0.5307 * r + 0.7040)
    assert pot[6, 7] == expected == pytest.approx(127.24634, rel=1e-6)  # Nav2's navfn.cpp: 127.24634
    assert pot[7, 7] == pytest.approx(162.44633, rel=1e-6)  # Nav2's navfn.cpp: 162.44633


def corridor() -> Grid:
    """A one-cell corridor (row 2, x 1..18) in a 20 x 5 grid at 0.1 m; the cell at x 8 costs 100."""
    g = Grid(np.full((5, 20), 254, dtype=np.uint8))
    g.costs[2, 1:19] = 0
    g.costs[2, 8] = 100
    return g


def test_corridor_potential_and_path_by_hand():
    g = corridor()
    planner = NavfnPlanner(NavfnParams())
    plan = planner.plan(g, (0.3, 0.2, 0.0), (1.5, 0.2, 1.0))
    pot = planner.last_potential
    assert pot is not None
    # no second neighbour in a corridor: the potential is the sum of the NavFn costs (50; 50 + 0.8 * 100 = 130)
    assert pot[2, 3:16].tolist() == [0, 50, 100, 150, 200, 330, 380, 430, 480, 530, 580, 630, 680]
    # every step has a neighbour without potential: NavFn follows the grid, one whole cell a step, and the
    # goal replaces the last point (the same position)
    assert plan.poses[:, 0] == pytest.approx([0.1 * k for k in range(3, 16)])
    assert (plan.poses[:, 1] == 0.2).all()
    assert plan.poses[:-1, 2].tolist() == [0.0] * 12 and plan.poses[-1, 2] == 1.0
    assert plan.length == pytest.approx(1.2)


def test_max_cycles_as_nav2_tests_it():
    # Nav2's test_max_cycles.cpp: 20 x 20 free cells, potential from (2, 10), path from (10, 10)
    pot = navfn_potential(navfn_costs(np.zeros((20, 20), dtype=np.uint8)), (2, 10), (10, 10))
    status, _, _ = navfn_path(pot, (10, 10), (2, 10), 1)
    assert status == PATH_OUT_OF_CYCLES
    status, xs, ys = navfn_path(pot, (10, 10), (2, 10), 4 * 20)
    assert status == PATH_FOUND
    # Dijkstra stopped when (10, 10) got its potential: its right-hand neighbours have none, so NavFn follows the
    # grid for two whole cells, then the gradient in 0.5-cell steps, then the end cell (Nav2's navfn.cpp, the same)
    assert xs.tolist() == [10.0, 9.0, 8.0, 7.5, 7.0, 6.5, 6.0, 5.5, 5.0, 4.5, 4.0, 3.5, 3.0, 2.0]
    assert set(ys.tolist()) == {10.0}
    assert pot[10, 10] == 400.0 and pot[10, 11] >= 1e10 and pot[9, 10] >= 1e10


def test_max_cycles_factor_names_the_limit():
    g = free_grid()
    with pytest.raises(PlanningError, match=r"within 60 steps \(max_cycles_factor 1 x 60 cells") as exc:
        NavfnPlanner(NavfnParams(max_cycles_factor=1)).plan(g, (0.5, 0.5, 0.0), (5.5, 5.5, 0.0))
    assert "raise max_cycles_factor" in str(exc.value)
    assert len(NavfnPlanner(NavfnParams(max_cycles_factor=3)).plan(g, (0.5, 0.5, 0.0), (5.5, 5.5, 0.0)).poses) > 100


def test_goal_in_the_last_half_cell_goes_through_the_tolerance_search():
    g = free_grid()  # x [0, 6): NavFn rounds x = 5.97 to cell 60, outside its grid
    plan = NavfnPlanner(NavfnParams(tolerance=0.5)).plan(g, (1.0, 3.0, 0.0), (5.97, 3.0, 0.0))
    # cell 59 is NavFn's border: the nearest scanned point with a potential rounds to cell 58
    assert plan.goal_used[:2] == pytest.approx((5.77, 3.0), abs=1e-9)
    assert plan.poses[-1].tolist() == pytest.approx([5.77, 3.0, 0.0], abs=1e-9)
    assert "tolerance moved it by 0.200 m" in plan.notes[0]
    with pytest.raises(PlanningError, match="within tolerance 0.0 m"):
        NavfnPlanner(NavfnParams(tolerance=0.0)).plan(g, (1.0, 3.0, 0.0), (5.97, 3.0, 0.0))


def test_start_equal_to_goal_gives_one_pose_and_one_cell_two():
    g = free_grid()
    one = NavfnPlanner(NavfnParams()).plan(g, (1.0, 1.0, 0.3), (1.0, 1.0, 1.2))
    assert one.poses.tolist() == [[1.0, 1.0, 1.2]]
    keep = NavfnPlanner(NavfnParams(use_final_approach_orientation=True)).plan(g, (1.0, 1.0, 0.3), (1.0, 1.0, 1.2))
    assert keep.poses.tolist() == [[1.0, 1.0, 0.3]]
    # both in NavFn cell (10, 10): the cell's own point, then the goal
    two = NavfnPlanner(NavfnParams()).plan(g, (1.0, 1.0, 0.3), (1.02, 1.01, 1.2))
    np.testing.assert_allclose(two.poses, [[1.0, 1.0, 0.0], [1.02, 1.01, 1.2]], atol=1e-12)


def test_robot_cell_is_cleared_with_navfn_rounding():
    g = free_grid()
    g.costs[10, 10:12] = 254  # the robot at x 1.06 stands in cell 10 (floor) and NavFn's cell 11 (round)
    planner = NavfnPlanner(NavfnParams())
    plan = planner.plan(g, (1.06, 1.0, 0.0), (3.0, 1.0, 0.0))
    pot = planner.last_potential
    assert pot is not None
    assert pot[10, 11] == 0.0 and pot[10, 10] >= 1e10  # NavFn's cell is the seed; the floor cell stays blocked
    assert plan.poses[0, :2].tolist() == pytest.approx([1.1, 1.0])


@pytest.mark.parametrize("use_astar", [False, True])
def test_robot_cell_ringed_by_inscribed_cells_fails_as_nav2_does(use_astar):
    # a robot at x 1.16 in an inscribed band (253) beside a 241 column: its floor cell 11 touches that
    # column, but NavFn clears and seeds its rounded cell 12, whose 4 neighbours are all 253 (blocked).
    # Nav2's makePlan on this grid (its navfn.cpp through a harness): one cell with a potential, the
    # goal and the 9 points of its tolerance scan without one: "Failed to create plan with tolerance".
    g = free_grid(20)
    g.costs[:, 10] = 241
    g.costs[:, 11:14] = 253
    g.costs[:, 14:] = 254
    planner = NavfnPlanner(NavfnParams(tolerance=0.1, use_astar=use_astar))
    with pytest.raises(PlanningError, match="within tolerance 0.1 m"):
        planner.plan(g, (1.16, 1.0, 0.0), (0.5, 1.0, 0.0))
    pot = planner.last_potential
    assert pot is not None
    assert np.argwhere(pot < 1e10).tolist() == [[10, 12]] and pot[10, 12] == 0.0
    # with the floor cell free as well, Nav2 plans: 34 (Dijkstra) or 24 (A*) cells with a potential,
    # 542 at the goal (50 into cell 11, 242 into the 241 column, 5 x 50), 12 path points from x 1.2
    g.costs[10, 11] = 0
    plan = planner.plan(g, (1.16, 1.0, 0.0), (0.5, 1.0, 0.0))
    pot = planner.last_potential
    assert pot is not None
    assert int((pot < 1e10).sum()) == (24 if use_astar else 34) and pot[10, 5] == 542.0
    xs = [1.2, 1.1, 1.05, 1.0, 0.95, 0.9, 0.85, 0.8, 0.75, 0.7, 0.6, 0.5]
    np.testing.assert_allclose(plan.poses[:, :2], [[x, 1.0] for x in xs], atol=1e-9)


def test_goal_replaces_a_last_pose_farther_away():
    g = free_grid()
    poses = poses_from_cells(np.array([12.0, 11.0, 10.0], F32), np.array([10.0] * 3, F32), g, (1.15, 1.0, 0.5))
    # (1.2, 1.0) is farther from (1.1, 1.0) than the goal is: replaced
    np.testing.assert_allclose(poses, [[1.0, 1.0, 0.0], [1.1, 1.0, 0.0], [1.15, 1.0, 0.5]], atol=1e-12)
    poses = poses_from_cells(np.array([12.0, 11.0, 10.0], F32), np.array([10.0] * 3, F32), g, (1.3, 1.0, 0.5))
    assert len(poses) == 4 and poses[-1].tolist() == pytest.approx([1.3, 1.0, 0.5])


@pytest.fixture(scope="module")
def maps():
    return bench_maps()


@pytest.mark.parametrize("use_astar", [False, True])
def test_benchmark_maps_plan_nav2s_path(maps, use_astar):
    ref = np.load(REFERENCE)
    for bm in maps:
        key = f"{bm.name.replace(' ', '_')}_{'astar' if use_astar else 'dijkstra'}"
        planner = NavfnPlanner(NavfnParams(use_astar=use_astar))
        plan = planner.plan(bm.costmap, bm.start, bm.goal)
        theirs = poses_from_cells(ref[f"{key}_x"], ref[f"{key}_y"], bm.costmap, plan.goal_used)
        res = bm.costmap.resolution
        hausdorff = max(
            directed_hausdorff(plan.poses[:, :2], theirs[:, :2])[0],
            directed_hausdorff(theirs[:, :2], plan.poses[:, :2])[0],
        )
        assert hausdorff <= res, bm.name
        assert plan.length == pytest.approx(path_length(theirs), rel=1e-3), bm.name
        pot = planner.last_potential
        assert pot is not None
        nav2 = ref[f"{key}_potential"]
        ours = pot[::20, ::20]
        assert np.array_equal(ours < 1e10, nav2 < 1e10), bm.name
        both = nav2 < 1e10
        assert both.sum() > 0.1 * both.size
        np.testing.assert_allclose(ours[both], nav2[both], rtol=1e-6, err_msg=bm.name)
        assert math.isfinite(plan.cost)


def test_kernels_compile_without_a_cache_directory(monkeypatch):
    import numba

    from navlog.replay.nav2.planners import navfn_kernels

    calls = []

    def njit(cache=False, **options):
        calls.append(cache)
        if cache:
            raise RuntimeError("cannot cache function: no locator available")  # numba's error: no writable directory
        return lambda fn: fn  # "compiled": the function itself, so the test stays fast

    monkeypatch.setattr(numba, "njit", njit)
    k = navfn_kernels.kernels.__wrapped__()
    assert k.compiled and calls == [True, False] * 7
    cost = navfn_costs(np.zeros((20, 20), dtype=np.uint8))
    pot = k.propagate(cost.ravel(), 20, 20, 10 * 20 + 2, 10, 10, False, 80)
    assert pot[10 * 20 + 10] == 400.0
