"""``mppi::critics::TwirlingCritic``: turning speed, away from the goal."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class TwirlingCriticParams(CriticParams):
    cost_weight: float = param(10.0, ge=0.0)


class TwirlingCritic(Critic[TwirlingCriticParams]):
    """Mean |wz|, except inside the goal checker's xy tolerance."""

    def score(self, data: CriticData) -> None:
        if data.goal_xy_tolerance is not None and data.robot_near_goal(data.goal_xy_tolerance):
            return
        self.add(data, np.abs(data.wz).mean(axis=1))
