"""A Smac-2D-like cost-aware planner: the cheapest 8-connected path on the costmap.

Step cost (1 or sqrt 2) * (1 + cost_travel_multiplier * c / 252) with c the cost of the cell entered
(nav2.md §2); cells >= 253 are blocked, unknown (255) is traversable as cost 252 only with
allow_unknown. A* with an admissible heuristic returns a path of exactly this least cost; here
scipy's compiled Dijkstra (``scipy.sparse.csgraph``) finds it over the whole grid, so the search
itself is exact. Not reproduced from Smac: its path smoother, downsampling and iteration limits.
Goals in an obstacle or unreachable move to the reachable cell nearest the goal within
``tolerance``. Cell convention: the costmap's (truncation, cell centres).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import lru_cache
from typing import ClassVar

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import dijkstra

from navlog.replay.limits import MAX_GOAL_TOLERANCE_M
from navlog.replay.nav2.planners.base import (
    PlanningCostmap,
    PlanningError,
    PlanResult,
    Pose2D,
    costmap_cell,
    path_length,
    tolerance_hint,
)
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param


@dataclass(frozen=True)
class Smac2DParams(PluginParams):
    """``nav2_smac_planner::SmacPlanner2D`` parameters (those Smac 2D adds beyond the search are read only)."""

    plugin: str = "nav2_smac_planner::SmacPlanner2D"
    tolerance: float = param(0.125, ge=0.0, le=MAX_GOAL_TOLERANCE_M)
    downsample_costmap: bool = False
    downsampling_factor: int = param(1, ge=1)
    allow_unknown: bool = True
    max_iterations: int = 1000000
    max_on_approach_iterations: int = 1000
    max_planning_time: float = param(2.0, gt=0.0)
    cost_travel_multiplier: float = param(2.0, ge=0.0)
    use_final_approach_orientation: bool = False
    terminal_checking_interval: int = param(5000, ge=1)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "downsample_costmap",
        "downsampling_factor",
        "max_planning_time",
        "terminal_checking_interval",
        "smoother",
    )


_MOVES = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1))


@lru_cache(maxsize=4)
def _structure(ny: int, nx: int):
    """Edges of the 8-connected grid: (src, dst, step length, side cells for diagonals), CSR order."""
    idx = np.arange(ny * nx).reshape(ny, nx)
    srcs, dsts, lens, side_a, side_b = [], [], [], [], []
    for dx, dy in _MOVES:
        ys = slice(max(-dy, 0), ny - max(dy, 0))
        xs = slice(max(-dx, 0), nx - max(dx, 0))
        src = idx[ys, xs].ravel()
        dst = src + dy * nx + dx
        srcs.append(src)
        dsts.append(dst)
        lens.append(np.full(src.shape, math.hypot(dx, dy)))
        side_a.append(src + dx)  # diagonals: the two cells beside the step
        side_b.append(src + dy * nx)
    src, dst = np.concatenate(srcs), np.concatenate(dsts)
    order = np.lexsort((dst, src))
    return (
        src[order],
        dst[order],
        np.concatenate(lens)[order],
        np.concatenate(side_a)[order],
        np.concatenate(side_b)[order],
    )


class Smac2DPlanner:
    """The cheapest 8-connected path on a costmap (anything with ``costs``, ``resolution``, ``origin_x``, ``origin_y``)."""

    def __init__(self, params: Smac2DParams) -> None:
        self.p = params

    def step_costs(self, costs: np.ndarray) -> np.ndarray:
        c = costs.astype(np.float64)
        unknown = costs == 255
        c[unknown] = 252.0
        factor = 1.0 + self.p.cost_travel_multiplier * c / 252.0
        blocked = (costs >= 253) & ~(unknown & self.p.allow_unknown)
        factor[blocked] = np.inf
        return factor

    def plan(self, cm: PlanningCostmap, start: Pose2D, goal: Pose2D) -> PlanResult:
        t0 = time.perf_counter()
        res = cm.resolution
        ny, nx = cm.costs.shape
        sx, sy = costmap_cell(cm, "start", start)
        gx, gy = costmap_cell(cm, "goal", goal)
        costs = cm.costs.copy()
        costs[sy, sx] = 0
        factor = self.step_costs(costs).ravel()
        src, dst, lens, sa, sb = _structure(ny, nx)
        w = lens * factor[dst]
        diag = lens > 1.0
        # no corner cutting between two blocked cells
        w[diag & np.isinf(factor[sa]) & np.isinf(factor[sb])] = np.inf
        ok = np.isfinite(w)
        graph = csr_matrix((w[ok], (src[ok], dst[ok])), shape=(nx * ny, nx * ny))
        s = sy * nx + sx
        dist, pred = dijkstra(graph, directed=True, indices=s, return_predecessors=True)
        dist = dist.reshape(ny, nx)
        target = (gx, gy)
        notes = []
        if not np.isfinite(dist[gy, gx]):
            tol_cells = int(math.floor(self.p.tolerance / res + 1e-9))
            y0, y1 = max(gy - tol_cells, 0), min(gy + tol_cells + 1, ny)
            x0, x1 = max(gx - tol_cells, 0), min(gx + tol_cells + 1, nx)
            win = dist[y0:y1, x0:x1]
            yy, xx = np.mgrid[y0:y1, x0:x1]
            d2 = (xx - gx) ** 2 + (yy - gy) ** 2
            d2 = np.where(np.isfinite(win) & (d2 <= tol_cells**2), d2, np.iinfo(np.int64).max)
            if tol_cells == 0 or d2.min() == np.iinfo(np.int64).max:
                raise PlanningError(
                    f"no path from ({start[0]:.2f}, {start[1]:.2f}) to ({goal[0]:.2f}, {goal[1]:.2f}) within "
                    f"tolerance {self.p.tolerance} m{tolerance_hint(cm, goal, self.p.allow_unknown)}"
                )
            k = int(np.argmin(d2))  # first in row-major order among the nearest: deterministic
            target = (int(xx.ravel()[k]), int(yy.ravel()[k]))
            notes.append(f"goal unreachable; tolerance moved it to cell {target}")
        cells = []
        n = target[1] * nx + target[0]
        while n != s and n >= 0:
            cells.append(n)
            n = int(pred[n])
        cells.append(s)
        cells.reverse()
        cells_arr = np.array(cells)
        xy = np.column_stack([cm.origin_x + (cells_arr % nx + 0.5) * res, cm.origin_y + (cells_arr // nx + 0.5) * res])
        xy[0] = start[:2]
        if target == (gx, gy):
            xy[-1] = goal[:2]
        poses = np.column_stack([xy, np.zeros(len(xy))])
        poses[-1, 2] = goal[2]
        if self.p.use_final_approach_orientation and len(poses) > 1:
            poses[-1, 2] = math.atan2(poses[-1, 1] - poses[-2, 1], poses[-1, 0] - poses[-2, 0])
        cost = float(dist[target[1], target[0]]) * res
        goal_used = (float(xy[-1, 0]), float(xy[-1, 1]), float(poses[-1, 2]))
        return PlanResult(poses, path_length(poses), cost, time.perf_counter() - t0, goal_used, "smac2d", notes)
