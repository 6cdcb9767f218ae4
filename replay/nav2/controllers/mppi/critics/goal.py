"""``mppi::critics::GoalCritic``: the trajectories' mean distance to the goal, near the goal."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.compiled import compile_together
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class GoalCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    threshold_to_consider: float = param(1.4, ge=0.0)


def goal_distances(x, y, gx, gy, out):
    """Each trajectory's mean distance to the goal (gx, gy) (``out``, float64), to be compiled."""
    for i in range(x.shape[0]):
        total = 0.0
        for j in range(x.shape[1]):
            dx, dy = float(x[i, j]) - gx, float(y[i, j]) - gy
            total += math.sqrt(dx * dx + dy * dy)
        out[i] = total / x.shape[1]


@functools.cache
def compiled_goal_distances() -> Callable[..., None]:
    """``goal_distances`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (goal_distances,))["goal_distances"]


class GoalCritic(Critic[GoalCriticParams]):
    """Mean distance of the trajectory to the goal, once the robot is within threshold_to_consider."""

    def score(self, data: CriticData) -> None:
        if not data.robot_near_goal(self.p.threshold_to_consider):
            return
        out = np.empty(data.x.shape[0])
        compiled_goal_distances()(data.x, data.y, float(data.goal[0]), float(data.goal[1]), out)
        self.add(data, out)
