"""``mppi::critics::PreferForwardCritic``: reverse speed, away from the goal."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class PreferForwardCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    threshold_to_consider: float = param(0.5, ge=0.0)


class PreferForwardCritic(Critic[PreferForwardCriticParams]):
    """Reverse speed integrated over time, except within threshold_to_consider of the goal."""

    def score(self, data: CriticData) -> None:
        if data.robot_near_goal(self.p.threshold_to_consider):
            return
        self.add(data, (np.maximum(-data.vx, 0.0) * data.model_dt).sum(axis=1))
