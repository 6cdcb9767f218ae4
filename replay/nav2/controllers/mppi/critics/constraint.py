"""``mppi::critics::ConstraintCritic``: speeds beyond the limits (and, Ackermann, turns too tight)."""

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
    from navlog.replay.nav2.controllers.base import ControllerSetup
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
    from navlog.replay.nav2.controllers.mppi.params import MPPIParams


@dataclass(frozen=True)
class ConstraintCriticParams(CriticParams):
    cost_weight: float = param(4.0, ge=0.0)


def limit_excess(vx, vy, wz, max_vel, min_vel, model, min_turning_r, dt, out):
    """Each trajectory's speed beyond [min_vel, max_vel] (``model`` 1, Omni: the signed norm of vx, vy;
    2, Ackermann: plus the turn tighter than ``min_turning_r``) integrated over time (``out``, float64),
    to be compiled."""
    for i in range(vx.shape[0]):
        total = 0.0
        for j in range(vx.shape[1]):
            v = float(vx[i, j])
            if model == 1:
                v = math.hypot(v, float(vy[i, j])) * (1.0 if v > 0.0 else -1.0)
            step = max(v - max_vel, 0.0) + max(min_vel - v, 0.0)
            if model == 2:
                w = abs(float(wz[i, j]))
                r = abs(float(vx[i, j])) / w if w != 0.0 else (math.inf if vx[i, j] != 0.0 else math.nan)
                step += max(min_turning_r - r, 0.0) if r == r else math.nan  # standing still: NaN, as NumPy's
            total += step * dt
        out[i] = total


@functools.cache
def compiled_limit_excess() -> Callable[..., None]:
    """``limit_excess`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (limit_excess,))["limit_excess"]


class ConstraintCritic(Critic[ConstraintCriticParams]):
    """Speeds beyond the limits, integrated over time (Ackermann: turns tighter than min_turning_r too).

    The limits are those the controller declares: ``vmax = hypot(vx_max, vy_max)`` even for DiffDrive.
    """

    def __init__(self, p: ConstraintCriticParams, mppi: MPPIParams, setup: ControllerSetup) -> None:
        super().__init__(p, mppi, setup)
        self.max_vel = math.hypot(mppi.vx_max, mppi.vy_max)
        self.min_vel = math.copysign(math.hypot(mppi.vx_min, mppi.vy_max), 1.0 if mppi.vx_min > 0 else -1.0)
        self.model = mppi.motion_model
        self.min_turning_r = mppi.ackermann.min_turning_r

    def score(self, data: CriticData) -> None:
        out = np.empty(data.vx.shape[0])
        model = ("DiffDrive", "Omni", "Ackermann").index(self.model)
        compiled_limit_excess()(
            data.vx, data.vy, data.wz, self.max_vel, self.min_vel, model, self.min_turning_r, float(data.model_dt), out
        )
        self.add(data, out)
