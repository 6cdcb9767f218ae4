"""What the MPPI critics score (Nav2's ``CriticData``) and the costmap lookup they and the path handler share."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

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
            d = (self.path[None, :, 0] - self.x[:, -1:]) ** 2 + (self.path[None, :, 1] - self.y[:, -1:]) ** 2
            n = d.shape[1]
            # nearest[i, r]: first index of the minimum of d[i, r:] (a suffix minimum and the next index holding it)
            suffix_min = np.minimum.accumulate(d[:, ::-1], axis=1)[:, ::-1]
            holds = np.where(d == suffix_min, np.arange(n), n)
            nearest = np.minimum.accumulate(holds[:, ::-1], axis=1)[:, ::-1]
            # r_i = nearest[i, r_(i-1)] from r = 0: compose the rows pairwise (the earlier row applied first)
            while len(nearest) > 1:
                if len(nearest) % 2:
                    nearest = np.vstack([nearest, np.arange(n)])
                nearest = np.take_along_axis(nearest[1::2], nearest[0::2], axis=1)
            self.furthest = int(nearest[0, 0])
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
