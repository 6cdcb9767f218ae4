"""``mppi::critics::GoalCritic``: the trajectories' mean distance to the goal, near the goal."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class GoalCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    threshold_to_consider: float = param(1.4, ge=0.0)


class GoalCritic(Critic[GoalCriticParams]):
    """Mean distance of the trajectory to the goal, once the robot is within threshold_to_consider."""

    def score(self, data: CriticData) -> None:
        if not data.robot_near_goal(self.p.threshold_to_consider):
            return
        self.add(data, np.hypot(data.x - data.goal[0], data.y - data.goal[1]).mean(axis=1))
