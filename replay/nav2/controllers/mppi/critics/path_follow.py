"""``mppi::critics::PathFollowCritic``: the trajectories' end drawn to a path point ahead of the furthest reached."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class PathFollowCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    offset_from_furthest: int = param(6, ge=0)
    threshold_to_consider: float = param(1.4, ge=0.0)


class PathFollowCritic(Critic[PathFollowCriticParams]):
    """Distance of the trajectory's end to the path point ``offset_from_furthest`` ahead of the furthest reached."""

    def score(self, data: CriticData) -> None:
        p = self.p
        if len(data.path) < 2 or data.robot_near_goal(p.threshold_to_consider):
            return
        furthest = data.furthest_reached()
        valid = data.path_points_valid()
        size = len(data.path) - 1
        idx = min(furthest + p.offset_from_furthest, size)
        while idx < size - 1 and not valid[idx]:
            idx += 1
        self.add(data, np.hypot(data.x[:, -1] - data.path[idx, 0], data.y[:, -1] - data.path[idx, 1]))
