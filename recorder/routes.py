"""Routes through a world: the true free space, the optimal path, its difficulty, random start/goal pairs.

Everything here works on the world's true geometry (``navlog.recorder.world.occupancy`` with no
margin), never on what a robot's sensors saw:

- ``TrueGrid``: the obstacle grid and, per cell, the clearance (m) from its centre to the nearest
  obstacle cell's edge; a robot of radius ``r`` fits where the clearance is at least ``r``;
- ``optimal_path``: Nav2's NavFn planner on that configuration space (cells closer than the robot's
  radius lethal, every other cell free: no inflation cost), the shortest path NavFn finds; its length
  over the robot's top speed is the optimal time of the BARN metric;
- ``path_difficulty``: how tight the optimal path is: the mean over its points of ``radius / clearance``
  (1.0: every point only just fits the robot; near 0: open space) and its minimum clearance;
- ``sample_routes``: seeded start/goal pairs in free space, at least ``min_distance`` apart (straight
  line) and in the same connected free region, so that a path exists.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.world import World, occupancy

GRID_RESOLUTION = 0.05  # m: the true grid's cell
Pose = tuple[float, float, float]


@dataclass
class TrueGrid:
    """The world's obstacles at ``GRID_RESOLUTION`` and each cell's clearance (m)."""

    occupied: np.ndarray  # bool (ny, nx), row 0 = lowest y
    clearance: np.ndarray  # float (ny, nx): centre to the nearest occupied cell's edge (0 on occupied cells)
    resolution: float
    origin: tuple[float, float]  # x, y of cell (0, 0)'s outer corner

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """(column, row) of the cell holding (x, y)."""
        return int(math.floor((x - self.origin[0]) / self.resolution)), int(
            math.floor((y - self.origin[1]) / self.resolution)
        )

    def centre(self, col: np.ndarray, row: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.origin[0] + (col + 0.5) * self.resolution, self.origin[1] + (row + 0.5) * self.resolution

    def clearance_at(self, xy: np.ndarray) -> np.ndarray:
        """Clearance (m) at points (N, 2); 0 outside the grid."""
        xy = np.atleast_2d(xy)
        col = np.floor((xy[:, 0] - self.origin[0]) / self.resolution).astype(int)
        row = np.floor((xy[:, 1] - self.origin[1]) / self.resolution).astype(int)
        ny, nx = self.clearance.shape
        inside = (col >= 0) & (row >= 0) & (col < nx) & (row < ny)
        out = np.zeros(len(xy))
        out[inside] = self.clearance[row[inside], col[inside]]
        return out


def true_grid(world: World, resolution: float = GRID_RESOLUTION) -> TrueGrid:
    """The ``TrueGrid`` of ``world`` (its obstacles at heights 0..2 m, no margin)."""
    from scipy.ndimage import distance_transform_edt

    grid = occupancy(world, resolution=resolution, margin=0.0)
    occupied = np.asarray(grid.data) >= 65
    if occupied.any():
        clear = np.maximum(distance_transform_edt(~occupied) * resolution - resolution / 2, 0.0)
    else:
        clear = np.full(occupied.shape, np.inf)
    return TrueGrid(occupied, clear, resolution, (grid.origin[0], grid.origin[1]))


@dataclass(frozen=True)
class OptimalPath:
    poses: np.ndarray  # (N, 3) x, y, yaw from start to goal
    length_m: float
    min_clearance_m: float
    difficulty: float  # mean of radius / clearance along the path (``path_difficulty``)


def optimal_path(grid: TrueGrid, start: Pose, goal: Pose, radius: float) -> OptimalPath | None:
    """NavFn's path from ``start`` to ``goal`` through the cells where a robot of ``radius`` fits, or None
    when no path reaches the goal."""
    from navlog.replay.nav2.planners.base import PlanningError
    from navlog.replay.nav2.planners.navfn import NavfnParams, NavfnPlanner

    costs = np.where(grid.clearance < radius, 254, 0).astype(np.uint8)
    cm = SimpleNamespace(costs=costs, resolution=grid.resolution, origin_x=grid.origin[0], origin_y=grid.origin[1])
    planner = NavfnPlanner(NavfnParams(tolerance=0.0, allow_unknown=False))
    try:
        plan = planner.plan(cm, start, goal)  # type: ignore[arg-type]
    except PlanningError:
        return None
    min_clear, difficulty = path_difficulty(grid, plan.poses[:, :2], radius)
    return OptimalPath(plan.poses, float(plan.length), min_clear, difficulty)


def path_difficulty(grid: TrueGrid, xy: np.ndarray, radius: float) -> tuple[float, float]:
    """(minimum clearance, difficulty) along a path: difficulty is the mean of ``radius / clearance``
    with the clearance floored at ``radius`` (so 1.0 is a path that only just fits everywhere)."""
    c = grid.clearance_at(xy)
    if not len(c):
        return math.inf, 0.0
    return float(c.min()), float(np.mean(radius / np.maximum(c, radius)))


def sample_routes(
    world: World,
    radius: float,
    count: int,
    seed: int,
    *,
    min_distance: float = 2.0,
    margin: float = 0.1,
    grid: TrueGrid | None = None,
    tries: int = 2000,
) -> list[tuple[Pose, Pose]]:
    """``count`` (start, goal) pairs drawn from ``seed``: both at least ``radius + margin`` from every
    obstacle, ``min_distance`` apart, and connected through cells where the robot fits (the same
    8-connected free region). Yaws are drawn uniformly. ConfigError when no such pair exists."""
    from scipy.ndimage import label

    g = grid if grid is not None else true_grid(world)
    fits = g.clearance >= radius
    regions, _ = label(fits, structure=np.ones((3, 3), dtype=int))
    rows, cols = np.nonzero(g.clearance >= radius + margin)
    x0, y0, x1, y1 = world.bounds()  # not in the grid's padding, outside the world
    cx, cy = g.centre(cols, rows)
    inside = (cx > x0) & (cx < x1) & (cy > y0) & (cy < y1)
    rows, cols = rows[inside], cols[inside]
    if not len(rows):
        raise ConfigError(
            f"world '{world.name}': no free cell {radius + margin:.2f} m from every obstacle "
            f"(robot radius {radius} m + margin {margin} m); the world is too cluttered for this robot"
        )
    xs, ys = g.centre(cols, rows)
    region = regions[rows, cols]
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x726F757465]))  # "route"
    out: list[tuple[Pose, Pose]] = []
    for _ in range(count):
        for _attempt in range(tries):
            i = int(rng.integers(len(xs)))
            far = (np.hypot(xs - xs[i], ys - ys[i]) >= min_distance) & (region == region[i])
            candidates = np.flatnonzero(far)
            if not len(candidates):
                continue
            j = int(candidates[rng.integers(len(candidates))])
            yaw0, yaw1 = (float(v) for v in rng.uniform(-math.pi, math.pi, 2))
            out.append(((float(xs[i]), float(ys[i]), yaw0), (float(xs[j]), float(ys[j]), yaw1)))
            break
        else:
            raise ConfigError(
                f"world '{world.name}': no start/goal pair {min_distance} m apart in one free region after "
                f"{tries} tries (robot radius {radius} m); lower min_distance"
            )
    return out
