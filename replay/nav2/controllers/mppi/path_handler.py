"""Nav2's MPPI ``PathHandler``: the global plan pruned behind the robot, and the part of it the optimizer follows."""

from __future__ import annotations

import numpy as np

from navlog.replay.nav2.controllers.base import (
    InvalidPath,
    Pose2D,
    first_after_integrated_distance,
    transform_poses,
)
from navlog.replay.nav2.controllers.mppi.critic_data import costs_at
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from navlog.replay.nav2.costmap.grid import CostmapGrid


class PathHandler:
    """The global plan, pruned behind the robot as it moves, and its part the optimizer follows, in the
    costmap frame (Nav2's ``PathHandler``)."""

    def __init__(self, params: MPPIParams) -> None:
        self.p = params
        self.plan = np.zeros((0, 3))

    def set_path(self, path: np.ndarray) -> None:
        self.plan = np.asarray(path, dtype=np.float64).reshape(-1, 3).copy()

    def goal(self, global_to_local: np.ndarray) -> Pose2D:
        """The plan's last pose in the costmap frame."""
        if len(self.plan) == 0:
            raise InvalidPath("MPPI: received plan with zero length")
        g = transform_poses(self.plan[-1:], global_to_local)[0]
        return float(g[0]), float(g[1]), float(g[2])

    def transform_path(self, pose: Pose2D, global_to_local: np.ndarray, costmap: CostmapGrid) -> np.ndarray:
        """The plan from the pose closest to the robot up to ``prune_distance`` of integrated length, cut
        at the first pose outside the costmap, in the costmap frame (N, 3); the plan behind is dropped."""
        if len(self.plan) == 0:
            raise InvalidPath("MPPI: received plan with zero length")
        robot = transform_poses(np.array([pose], dtype=np.float64), np.linalg.inv(global_to_local))[0]
        search = self.p.max_robot_pose_search_dist
        if search <= 0.0:
            search = max(costmap.size_x, costmap.size_y) * costmap.resolution * 0.5
        upper = first_after_integrated_distance(self.plan, search)
        d = np.hypot(self.plan[:upper, 0] - robot[0], self.plan[:upper, 1] - robot[1])
        closest = int(np.argmin(d)) if upper > 0 else 0
        end = first_after_integrated_distance(self.plan, self.p.prune_distance, closest)
        local = transform_poses(self.plan[closest:end], global_to_local)
        _, inside = costs_at(costmap, local[:, 0], local[:, 1])
        out = np.nonzero(~inside)[0]
        if len(out):
            local = local[: out[0]]
        self.plan = self.plan[closest:]
        if len(local) == 0:
            raise InvalidPath("MPPI: resulting plan has 0 poses in it (the plan is off the local costmap)")
        return local
