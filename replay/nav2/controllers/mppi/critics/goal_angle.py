"""``mppi::critics::GoalAngleCritic``: the trajectories' mean heading error to the goal's yaw, near the goal."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.compiled import compile_together
from navlog.replay.geometry import remainder_angle
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class GoalAngleCriticParams(CriticParams):
    cost_weight: float = param(3.0, ge=0.0)
    threshold_to_consider: float = param(0.5, ge=0.0)
    symmetric_yaw_tolerance: bool = False


def _wrapped(d):
    """``d`` wrapped to [-pi, pi) as Nav2's MPPI does it (``fmod(d + pi, 2 pi)`` shifted by pi)."""
    t = np.fmod(d + math.pi, 2.0 * math.pi)
    return t + math.pi if t < 0.0 else t - math.pi


def heading_errors(yaw, goal_yaw, flipped, symmetric, out):
    """Each trajectory's mean |heading error| to ``goal_yaw`` (``out``, float64), to be compiled; with
    ``symmetric`` the smaller of it and the error to ``flipped`` (the goal's yaw turned by pi)."""
    for i in range(yaw.shape[0]):
        total = 0.0
        for j in range(yaw.shape[1]):
            e = abs(_wrapped(goal_yaw - float(yaw[i, j])))
            if symmetric:
                e = min(e, abs(_wrapped(flipped - float(yaw[i, j]))))
            total += e
        out[i] = total / yaw.shape[1]


@functools.cache
def compiled_heading_errors() -> Callable[..., None]:
    """``heading_errors`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (_wrapped, heading_errors))["heading_errors"]


class GoalAngleCritic(Critic[GoalAngleCriticParams]):
    """Mean heading error to the path's last yaw, once the robot is within threshold_to_consider."""

    def score(self, data: CriticData) -> None:
        p = self.p
        if not data.robot_near_goal(p.threshold_to_consider):
            return
        goal_yaw = float(data.path[-1, 2])
        flipped = remainder_angle(goal_yaw + math.pi)
        out = np.empty(data.yaw.shape[0])
        compiled_heading_errors()(data.yaw, goal_yaw, flipped, p.symmetric_yaw_tolerance, out)
        self.add(data, out)
