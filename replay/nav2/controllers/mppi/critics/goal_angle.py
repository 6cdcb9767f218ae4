"""``mppi::critics::GoalAngleCritic``: the trajectories' mean heading error to the goal's yaw, near the goal."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.geometry import shortest_angular_distances
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class GoalAngleCriticParams(CriticParams):
    cost_weight: float = param(3.0, ge=0.0)
    threshold_to_consider: float = param(0.5, ge=0.0)
    symmetric_yaw_tolerance: bool = False


class GoalAngleCritic(Critic[GoalAngleCriticParams]):
    """Mean heading error to the path's last yaw, once the robot is within threshold_to_consider."""

    def score(self, data: CriticData) -> None:
        p = self.p
        if not data.robot_near_goal(p.threshold_to_consider):
            return
        goal_yaw = float(data.path[-1, 2])
        d = np.abs(shortest_angular_distances(data.yaw, goal_yaw))
        if p.symmetric_yaw_tolerance:
            flipped = math.remainder(goal_yaw + math.pi, 2 * math.pi)
            d = np.minimum(d, np.abs(shortest_angular_distances(data.yaw, flipped)))
        self.add(data, d.mean(axis=1))
