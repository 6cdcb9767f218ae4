"""``mppi::critics::ConstraintCritic``: speeds beyond the limits (and, Ackermann, turns too tight)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.base import ControllerSetup
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
    from navlog.replay.nav2.controllers.mppi.params import MPPIParams


@dataclass(frozen=True)
class ConstraintCriticParams(CriticParams):
    cost_weight: float = param(4.0, ge=0.0)


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
        v = np.where(data.vx > 0.0, 1.0, -1.0) * np.hypot(data.vx, data.vy) if self.model == "Omni" else data.vx
        out = np.maximum(v - self.max_vel, 0.0) + np.maximum(self.min_vel - v, 0.0)
        if self.model == "Ackermann":
            with np.errstate(divide="ignore", invalid="ignore"):
                out = out + np.maximum(self.min_turning_r - np.abs(data.vx) / np.abs(data.wz), 0.0)
        self.add(data, (out * data.model_dt).sum(axis=1))
