"""``mppi::critics::PreferForwardCritic``: reverse speed, away from the goal."""

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
class PreferForwardCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    threshold_to_consider: float = param(0.5, ge=0.0)


def reverse_speeds(vx, dt, out):
    """Each trajectory's reverse speed integrated over time (``out``, float64), to be compiled."""
    for i in range(vx.shape[0]):
        total = 0.0
        for j in range(vx.shape[1]):
            total += max(-float(vx[i, j]), 0.0) * dt
        out[i] = total


@functools.cache
def compiled_reverse_speeds() -> Callable[..., None]:
    """``reverse_speeds`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (reverse_speeds,))["reverse_speeds"]


class PreferForwardCritic(Critic[PreferForwardCriticParams]):
    """Reverse speed integrated over time, except within threshold_to_consider of the goal."""

    def score(self, data: CriticData) -> None:
        if data.robot_near_goal(self.p.threshold_to_consider):
            return
        out = np.empty(data.vx.shape[0])
        compiled_reverse_speeds()(data.vx, float(data.model_dt), out)
        self.add(data, out)
