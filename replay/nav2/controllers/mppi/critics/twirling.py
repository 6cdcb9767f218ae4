"""``mppi::critics::TwirlingCritic``: turning speed, away from the goal."""

from __future__ import annotations

import functools
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
class TwirlingCriticParams(CriticParams):
    cost_weight: float = param(10.0, ge=0.0)


def mean_turn_rates(wz, out):
    """Each trajectory's mean |wz| (``out``, float64), to be compiled."""
    for i in range(wz.shape[0]):
        total = 0.0
        for j in range(wz.shape[1]):
            total += abs(float(wz[i, j]))
        out[i] = total / wz.shape[1]


@functools.cache
def compiled_mean_turn_rates() -> Callable[..., None]:
    """``mean_turn_rates`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (mean_turn_rates,))["mean_turn_rates"]


class TwirlingCritic(Critic[TwirlingCriticParams]):
    """Mean |wz|, except inside the goal checker's xy tolerance."""

    def score(self, data: CriticData) -> None:
        if data.goal_xy_tolerance is not None and data.robot_near_goal(data.goal_xy_tolerance):
            return
        out = np.empty(data.wz.shape[0])
        compiled_mean_turn_rates()(data.wz, out)
        self.add(data, out)
