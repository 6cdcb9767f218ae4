"""Small grids for the planner tests, and a brute-force least-cost reference."""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numpy as np

from navlog.replay.nav2.planners.navfn import navfn_costs

RES = 0.1


@dataclass
class Grid:
    costs: np.ndarray
    resolution: float = RES
    origin_x: float = 0.0
    origin_y: float = 0.0


def free_grid(n=60) -> Grid:
    return Grid(np.zeros((n, n), dtype=np.uint8))


def wall_with_gap() -> Grid:
    g = free_grid()
    g.costs[:, 30] = 254  # wall at x = 3.0 .. 3.1
    g.costs[30:37, 30] = 0  # gap y = 3.0 .. 3.7: its lower corner lies on the 45-degree line from (1, 1)
    return g


def brute_force_cost(step_cost: np.ndarray, start: tuple[int, int], goal: tuple[int, int]) -> float:
    """Least sum of (step length * cost of the cell entered) over 8-connected moves (cells, not metres)."""
    ny, nx = step_cost.shape
    dist = {start: 0.0}
    heap = [(0.0, start)]
    while heap:
        d, (x, y) = heapq.heappop(heap)
        if (x, y) == goal:
            return d
        if d > dist[(x, y)]:
            continue
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                if dx == dy == 0:
                    continue
                u, v = x + dx, y + dy
                if not (0 <= u < nx and 0 <= v < ny) or not np.isfinite(step_cost[v, u]):
                    continue
                if dx and dy and not (np.isfinite(step_cost[y, u]) or np.isfinite(step_cost[v, x])):
                    continue
                nd = d + math.hypot(dx, dy) * step_cost[v, u]
                if nd < dist.get((u, v), math.inf):
                    dist[(u, v)] = nd
                    heapq.heappush(heap, (nd, (u, v)))
    return math.inf


def navfn_reference(grid: Grid, start, goal) -> float:
    """Brute-force least cost on NavFn's cost field, in cost-weighted metres (free cell = 1)."""
    c = navfn_costs(grid.costs).astype(np.float64)
    step = np.where(c >= 254, np.inf, c / 50.0)
    cell = lambda p: (int(round((p[0] - grid.origin_x) / RES)), int(round((p[1] - grid.origin_y) / RES)))  # noqa: E731
    return brute_force_cost(step, cell(start), cell(goal)) * RES


def boxed_goal() -> Grid:
    g = free_grid()
    g.costs[38:43, 38:43] = 254
    g.costs[39:42, 39:42] = 0  # a free pocket at (4.0, 4.0) walled in
    return g
