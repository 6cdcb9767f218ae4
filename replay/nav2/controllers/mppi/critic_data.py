"""What the MPPI critics score (Nav2's ``CriticData``) and the costmap lookup they and the path handler share."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from navlog.replay.compiled import compile_together
from navlog.replay.nav2.controllers.base import Pose2D
from navlog.replay.nav2.costmap.cost_values import INSCRIBED, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.grid import CostmapGrid


def costs_at(cm: CostmapGrid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(costs, inside) at world points as Nav2's ``worldToMap``; outside points read NO_INFORMATION."""
    fx = (np.asarray(x) - cm.origin_x) / cm.resolution
    fy = (np.asarray(y) - cm.origin_y) / cm.resolution
    inside = (fx >= 0) & (fy >= 0) & (fx < cm.size_x) & (fy < cm.size_y)
    mx = np.where(inside, fx, 0).astype(np.int64)
    my = np.where(inside, fy, 0).astype(np.int64)
    return np.where(inside, cm.costs[my, mx], NO_INFORMATION), inside


def furthest_reached_index(px, py, end_x, end_y):
    """Nav2's ``findPathFurthestReachedPoint``, to be compiled: per trajectory in order, the first path
    index nearest its end point (squared distance in float64) searched from the previous answer."""
    r = 0
    for i in range(end_x.shape[0]):
        ex, ey = float(end_x[i]), float(end_y[i])
        best, at = np.inf, r
        for j in range(r, px.shape[0]):
            d = (px[j] - ex) ** 2 + (py[j] - ey) ** 2
            if d < best:
                best, at = d, j
        r = at
    return r


@functools.cache
def compiled_furthest_reached_index() -> Callable[..., int]:
    """``furthest_reached_index`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (furthest_reached_index,))["furthest_reached_index"]


@dataclass
class CriticData:
    """What the critics score (Nav2's ``CriticData``): the batch's velocities and poses, the path, the goal.

    ``vx``/``vy``/``wz`` and ``x``/``y``/``yaw`` are (batch, time_steps); column 0 of the velocities
    is the robot's speed. ``path`` is (N, 3) in the costmap frame. ``costs`` (batch,) is added to.
    ``furthest`` and ``path_valid`` are computed on first use (a test may set them).
    """

    pose: Pose2D
    goal: tuple[float, float]
    path: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    wz: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    model_dt: float
    costmap: CostmapGrid | None = None
    goal_xy_tolerance: float | None = None  # the goal checker's; None without one
    holonomic: bool = False
    costs: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fail_flag: bool = False
    furthest: int | None = None
    path_valid: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.costs.shape != (self.x.shape[0],):
            self.costs = np.zeros(self.x.shape[0])

    def robot_near_goal(self, radius: float) -> bool:
        """Nav2's ``withinPositionGoalTolerance``: robot-goal distance strictly below ``radius``."""
        dx, dy = self.pose[0] - self.goal[0], self.pose[1] - self.goal[1]
        return dx * dx + dy * dy < radius * radius

    def furthest_reached(self) -> int:
        """Nav2's ``findPathFurthestReachedPoint``: per trajectory (in order), the path index nearest its
        last point searched from the running maximum; the maximum over the batch."""
        if self.furthest is None:
            path = np.ascontiguousarray(self.path[:, :2], dtype=np.float64).T
            self.furthest = int(compiled_furthest_reached_index()(path[0], path[1], self.x[:, -1], self.y[:, -1]))
        return self.furthest

    def path_points_valid(self) -> np.ndarray:
        """Nav2's ``findPathCosts``: per path point but the last, in the map and not lethal, inscribed or
        (unless unknown space is tracked) unknown."""
        if self.path_valid is None:
            pts = self.path[:-1]
            if self.costmap is None:
                self.path_valid = np.ones(len(pts), dtype=bool)
            else:
                cost, inside = costs_at(self.costmap, pts[:, 0], pts[:, 1])
                tracking = bool(self.costmap.params.track_unknown_space)
                bad = (cost == LETHAL) | (cost == INSCRIBED) | ((cost == NO_INFORMATION) & (not tracking))
                self.path_valid = inside & ~bad
        return self.path_valid
