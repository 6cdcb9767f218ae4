"""``mppi::critics::PathAlignCritic``: the trajectories' distance to the path at the same integrated length."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.geometry import shortest_angular_distances
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class PathAlignCriticParams(CriticParams):
    cost_weight: float = param(10.0, ge=0.0)
    max_path_occupancy_ratio: float = param(0.07, ge=0.0)
    offset_from_furthest: int = param(20, ge=0)
    trajectory_point_step: int = param(4, ge=1)
    threshold_to_consider: float = param(0.5, ge=0.0)
    use_path_orientations: bool = False


class PathAlignCritic(Critic[PathAlignCriticParams]):
    """Mean distance of sampled trajectory points to the path point at the same integrated length."""

    def score(self, data: CriticData) -> None:
        p = self.p
        if data.robot_near_goal(p.threshold_to_consider):
            return
        count = data.furthest_reached()
        if count < p.offset_from_furthest or count == 0:
            return
        valid = data.path_points_valid()
        invalid_running = np.cumsum(~valid[:count])
        over = (invalid_running / count > p.max_path_occupancy_ratio) & (invalid_running > 2.0)
        if over.any():
            return
        path = data.path[:count]
        seg = np.hypot(np.diff(path[:, 0]), np.diff(path[:, 1]))
        along = np.concatenate([[0.0], np.cumsum(seg)])
        step = p.trajectory_point_step
        tx, ty, tyaw = data.x[:, ::step], data.y[:, ::step], data.yaw[:, ::step]
        traj_len = np.cumsum(np.hypot(np.diff(tx, axis=1), np.diff(ty, axis=1)), axis=1)
        # Nav2's findClosestPathPt, searched from the previous answer: the running maximum of the global one
        i = np.searchsorted(along, traj_len, side="right")
        last = len(along) - 1
        ic = np.minimum(i, last)
        prev = along[np.maximum(ic - 1, 0)]
        nearest = np.where(i > last, last, np.where(traj_len - prev < along[ic] - traj_len, ic - 1, ic))
        nearest = np.maximum.accumulate(nearest, axis=1)
        ok = valid[nearest]
        dx, dy = path[nearest, 0] - tx[:, 1:], path[nearest, 1] - ty[:, 1:]
        if p.use_path_orientations:
            dyaw = shortest_angular_distances(path[nearest, 2], tyaw[:, 1:])
            dist = np.sqrt(dx * dx + dy * dy + dyaw * dyaw)
        else:
            dist = np.sqrt(dx * dx + dy * dy)
        samples = ok.sum(axis=1)
        total = np.where(ok, dist, 0.0).sum(axis=1)
        self.add(data, np.where(samples > 0, total / np.maximum(samples, 1), 0.0))
