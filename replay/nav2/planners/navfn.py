"""NavFn as Nav2's ``nav2_navfn_planner`` plans: cost conversion, potential, gradient path, poses.

Steps (reference: nav2.md §2), each as Nav2 does it:
1. start and goal must lie in the costmap (its own convention: floor); with tolerance 0 a lethal goal
   fails (goal occupied). A start equal to the goal gives one pose.
2. NavFn's cells: world -> cell = round((w - o) / res), cell -> world = o + m * res (half a cell off the
   costmap's). The robot's NavFn cell is cleared to free space.
3. costmap costs c -> NavFn costs: c < 253 -> 50 + 0.8 c (int, capped 253); 253, 254 -> 254 (blocked);
   255 -> 253 if allow_unknown else 254; the outer border -> 254.
4. the potential is seeded at the robot cell (0) and grown until the goal cell has one, with NavFn's
   priority buffers, threshold increments and quadratic update, in float32 (``navfn_kernels``;
   Dijkstra, or A* with the distance to the goal times 50 added to the priority).
5. a goal without potential (blocked, or in the map's last half cell, which NavFn's rounding puts
   outside its grid): the reachable point within goal +- tolerance (steps of one cell) closest to it.
6. the path runs from the goal down the gradient (``navfn_kernels.trace_path``), at most
   ``max_cycles_factor * max(nx, ny)`` steps, and is reversed (robot -> goal); the goal pose replaces
   the last pose if that is farther from the one before than the goal is, or lies on the goal;
   otherwise it is appended.

The kernels run compiled by numba (``potential="exact"``, the default; compiled once and cached on
disk) or as plain Python on NumPy float32 scalars (``potential="python"``: the same bits, slowly).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.limits import MAX_GOAL_TOLERANCE_M
from navlog.replay.nav2.planners.base import (
    PlanningCostmap,
    PlanningError,
    PlanResult,
    Pose2D,
    costmap_cell,
    costmap_extent,
    path_cost,
    path_length,
    tolerance_hint,
)
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.planners.navfn_kernels import Kernels

POT_HIGH = 1.0e10
COST_OBS = 254
COST_NEUTRAL = 50
COST_FACTOR = 0.8
POTENTIALS = ("exact", "python")  # compiled kernels (default), or the same code as plain Python


@dataclass(frozen=True)
class NavfnParams(PluginParams):
    """``nav2_navfn_planner::NavfnPlanner`` parameters."""

    plugin: str = "nav2_navfn_planner::NavfnPlanner"
    tolerance: float = param(0.5, ge=0.0, le=MAX_GOAL_TOLERANCE_M)
    use_astar: bool = False
    allow_unknown: bool = True
    use_final_approach_orientation: bool = False
    max_cycles_factor: int = param(4, ge=1)


def _cost_table(allow_unknown: bool) -> np.ndarray:
    """NavFn's cost for each costmap cost 0..255."""
    c = np.arange(256)
    out = np.full(256, COST_OBS, dtype=np.uint8)
    low = c < 253
    out[low] = np.minimum((COST_NEUTRAL + COST_FACTOR * c[low]).astype(np.int32), COST_OBS - 1)
    if allow_unknown:
        out[255] = COST_OBS - 1
    return out


_COST_TABLES = {flag: _cost_table(flag) for flag in (False, True)}


def navfn_costs(costs: np.ndarray, allow_unknown: bool = True) -> np.ndarray:
    """NavFn's cost array (uint8, same shape) from costmap costs (uint8), border set to 254."""
    out = _COST_TABLES[bool(allow_unknown)][np.asarray(costs, dtype=np.uint8)]
    out[0, :] = out[-1, :] = COST_OBS
    out[:, 0] = out[:, -1] = COST_OBS
    return out


def _kernels(potential: str) -> Kernels:
    """The kernels for ``potential``; navfn_kernels (and numba) are imported on first use."""
    from navlog.replay.nav2.planners import navfn_kernels

    return navfn_kernels.kernels() if potential == "exact" else navfn_kernels.PYTHON


def navfn_potential(
    cost: np.ndarray,
    robot: tuple[int, int],
    goal: tuple[int, int],
    use_astar: bool = False,
    potential: str = "exact",
) -> np.ndarray:
    """NavFn's potential (float32, (ny, nx)) seeded at the ``robot`` cell, grown until the ``goal`` cell has one.

    cost: ``navfn_costs`` (ny, nx). ``goal`` may lie one column or row past the grid (a goal in the
    map's last half cell): the propagation then runs until its buffers empty or its cycles run out.
    """
    ny, nx = cost.shape
    flat = np.ascontiguousarray(cost, dtype=np.uint8).ravel()
    cycles = max(nx * ny // 20, nx + ny)
    seed = robot[1] * nx + robot[0]
    pot = _kernels(potential).propagate(flat, nx, ny, seed, goal[0], goal[1], use_astar, cycles)
    return pot.reshape(ny, nx)


def navfn_path(
    pot: np.ndarray, start: tuple[int, int], end: tuple[int, int], max_cycles: int, potential: str = "exact"
) -> tuple[int, np.ndarray, np.ndarray]:
    """NavFn's gradient path from ``start`` (the goal cell) down to ``end`` (the robot cell), in cells.

    Returns (status, x, y) with the ``navfn_kernels`` status (``PATH_FOUND``, ``PATH_OUT_OF_CYCLES``,
    ``PATH_STUCK``) and float32 cell coordinates (empty unless found).
    """
    ny, nx = pot.shape
    flat = np.ascontiguousarray(pot, dtype=np.float32).ravel()
    status, xs, ys = _kernels(potential).trace_path(flat, nx, ny, start[0], start[1], end[0], end[1], max_cycles)
    return int(status), xs, ys


def poses_from_cells(xs: np.ndarray, ys: np.ndarray, cm: PlanningCostmap, goal: Pose2D) -> np.ndarray:
    """Nav2's plan from NavFn's path (goal -> robot, cells): reversed, in world coordinates, the goal pose last.

    Returns (N, 3) poses x, y, yaw; yaw 0 except the goal's. The goal replaces the last pose if that is
    farther from the pose before than the goal is, or within 1 mm of the goal; else it is appended.
    """
    res = cm.resolution
    wx = cm.origin_x + xs[::-1].astype(np.float64) * res
    wy = cm.origin_y + ys[::-1].astype(np.float64) * res
    poses = np.column_stack([wx, wy, np.zeros(len(wx))])
    if len(poses) >= 2:
        last, before = poses[-1], poses[-2]
        last_gap = (last[0] - before[0]) ** 2 + (last[1] - before[1]) ** 2
        goal_gap = (goal[0] - before[0]) ** 2 + (goal[1] - before[1]) ** 2
        if last_gap > goal_gap or (last[0] - goal[0]) ** 2 + (last[1] - goal[1]) ** 2 < 1e-6:
            poses[-1] = goal
            return poses
    return np.vstack([poses, np.array([goal], dtype=np.float64)])


def _round_half_away(v: float) -> int:
    """C's round(): the nearest integer, halves away from zero (Python's round() takes halves to even)."""
    r = math.floor(abs(v))
    if abs(v) - r >= 0.5:
        r += 1
    return int(math.copysign(r, v))


class NavfnPlanner:
    """Plan on a costmap (anything with ``costs``, ``resolution``, ``origin_x``, ``origin_y``)."""

    def __init__(self, params: NavfnParams, potential: str = "exact") -> None:
        if potential not in POTENTIALS:
            raise NavlogError(
                f"NavFn potential must be one of {', '.join(POTENTIALS)}, got {potential!r} "
                "(exact: Nav2's NavFn compiled; python: the same code, uncompiled)"
            )
        self.p = params
        self.potential = potential
        self.last_potential: np.ndarray | None = None

    # NavFn's cell convention (half a cell off the costmap's): the cell, and whether it lies in the grid
    @staticmethod
    def _navfn_cell(cm: PlanningCostmap, x: float, y: float) -> tuple[int, int, bool]:
        mx = _round_half_away((x - cm.origin_x) / cm.resolution)
        my = _round_half_away((y - cm.origin_y) / cm.resolution)
        ny, nx = cm.costs.shape
        inside = x >= cm.origin_x and y >= cm.origin_y and mx < nx and my < ny
        return mx, my, inside

    def plan(self, cm: PlanningCostmap, start: Pose2D, goal: Pose2D) -> PlanResult:
        t0 = time.perf_counter()
        res = cm.resolution
        ny, nx = cm.costs.shape
        costmap_cell(cm, "start", start)
        gx0, gy0 = costmap_cell(cm, "goal", goal)
        if self.p.tolerance == 0.0 and cm.costs[gy0, gx0] == 254:
            raise PlanningError(
                f"goal ({goal[0]:.2f}, {goal[1]:.2f}) is in a lethal cell (goal occupied) and "
                f"tolerance is 0{self._hint(cm, goal)}"
            )
        if start[0] == goal[0] and start[1] == goal[1]:
            pose = (goal[0], goal[1], start[2] if self.p.use_final_approach_orientation else goal[2])
            return PlanResult(np.array([pose]), 0.0, 0.0, time.perf_counter() - t0, pose, "navfn")
        rx, ry, robot_inside = self._navfn_cell(cm, start[0], start[1])
        if not robot_inside:
            raise PlanningError(
                f"start ({start[0]:.2f}, {start[1]:.2f}) is in the costmap's last half cell, which NavFn's "
                f"rounding puts at cell ({rx}, {ry}), outside its {nx} x {ny} grid {costmap_extent(cm)}; "
                "move the start half a cell inwards"
            )
        if not (cm.costs < 253).any() and not (self.p.allow_unknown and (cm.costs == 255).any()):
            raise PlanningError(
                "the costmap has no free cell"
                + ("" if self.p.allow_unknown else " (unknown cells are not allowed: allow_unknown false)")
            )
        costs = cm.costs.copy()
        costs[ry, rx] = 0  # the robot's own (NavFn) cell is free
        cost = navfn_costs(costs, self.p.allow_unknown)
        gx, gy, _ = self._navfn_cell(cm, goal[0], goal[1])
        pot = navfn_potential(cost, (rx, ry), (gx, gy), self.p.use_astar, self.potential)
        self.last_potential = pot
        best = self._reachable_goal(cm, pot, goal)
        if best is None:
            raise PlanningError(
                f"no path from ({start[0]:.2f}, {start[1]:.2f}) to ({goal[0]:.2f}, {goal[1]:.2f}) "
                f"within tolerance {self.p.tolerance} m{self._hint(cm, goal)}"
            )
        bx, by, _ = self._navfn_cell(cm, best[0], best[1])
        max_cycles = self.p.max_cycles_factor * max(nx, ny)
        status, xs, ys = navfn_path(pot, (bx, by), (rx, ry), max_cycles, self.potential)
        if status != 0:
            raise PlanningError(self._path_failure(status, max_cycles, nx, ny))
        goal_pose = (best[0], best[1], goal[2])
        poses = poses_from_cells(xs, ys, cm, goal_pose)
        if self.p.use_final_approach_orientation:
            self._final_approach(poses, start)
        notes = []
        moved = math.hypot(best[0] - goal[0], best[1] - goal[1])
        if moved > 0.0:
            notes.append(f"goal unreachable; tolerance moved it by {moved:.3f} m to ({best[0]:.3f}, {best[1]:.3f})")
        length = path_length(poses)
        pcost = path_cost(poses, cost, res, (cm.origin_x - 0.5 * res, cm.origin_y - 0.5 * res), COST_NEUTRAL)
        return PlanResult(poses, length, pcost, time.perf_counter() - t0, goal_pose, "navfn", notes)

    def _reachable_goal(self, cm: PlanningCostmap, pot: np.ndarray, goal: Pose2D) -> tuple[float, float] | None:
        """The goal if its NavFn cell has a potential, else the nearest such point of Nav2's tolerance scan."""

        def reachable(x: float, y: float) -> bool:
            mx, my, inside = self._navfn_cell(cm, x, y)
            return inside and pot[my, mx] < POT_HIGH

        if reachable(goal[0], goal[1]):
            return goal[0], goal[1]
        best, best_d = None, math.inf
        tol, res = self.p.tolerance, cm.resolution
        py = goal[1] - tol
        while py <= goal[1] + tol:
            px = goal[0] - tol
            while px <= goal[0] + tol:
                if reachable(px, py):
                    d = (px - goal[0]) ** 2 + (py - goal[1]) ** 2
                    if d < best_d:
                        best_d, best = d, (px, py)
                px += res
            py += res
        return best

    def _path_failure(self, status: int, max_cycles: int, nx: int, ny: int) -> str:
        from navlog.replay.nav2.planners.navfn_kernels import PATH_OUT_OF_CYCLES

        if status == PATH_OUT_OF_CYCLES:
            return (
                f"the gradient path did not reach the robot within {max_cycles} steps (max_cycles_factor "
                f"{self.p.max_cycles_factor} x {max(nx, ny)} cells, the larger side of the {nx} x {ny} costmap); "
                "raise max_cycles_factor"
            )
        return (
            "a potential reaches the goal but the gradient path failed (as NavFn can, "
            "navigation2#4655); try use_astar or the smac2d planner"
        )

    @staticmethod
    def _final_approach(poses: np.ndarray, start: Pose2D) -> None:
        """use_final_approach_orientation: the last pose takes the heading of the last segment (in place)."""
        if len(poses) == 1:
            poses[-1, 2] = start[2]
            return
        before = poses[-2]
        # NavFn often ends with two equal poses (the goal cell and the goal): look one further back
        if abs(poses[-1, 0] - before[0]) < 1e-4 and abs(poses[-1, 1] - before[1]) < 1e-4 and len(poses) > 2:
            before = poses[-3]
        poses[-1, 2] = math.atan2(poses[-1, 1] - before[1], poses[-1, 0] - before[0])

    def _hint(self, cm: PlanningCostmap, goal: Pose2D) -> str:
        return tolerance_hint(cm, goal, self.p.allow_unknown)
