"""``mppi::critics::VelocityDeadbandCritic``: speeds inside the deadband a drive cannot hold."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class VelocityDeadbandCriticParams(CriticParams):
    cost_weight: float = param(35.0, ge=0.0)
    deadband_velocities: tuple[float, ...] = (0.0, 0.0, 0.0)


class VelocityDeadbandCritic(Critic[VelocityDeadbandCriticParams]):
    """Speeds inside the deadband (per axis, vy for Omni only), integrated over time."""

    def score(self, data: CriticData) -> None:
        db = [abs(v) for v in (tuple(self.p.deadband_velocities) + (0.0, 0.0, 0.0))[:3]]
        out = np.maximum(db[0] - np.abs(data.vx), 0.0) + np.maximum(db[2] - np.abs(data.wz), 0.0)
        if data.holonomic:
            out = out + np.maximum(db[1] - np.abs(data.vy), 0.0)
        self.add(data, (out * data.model_dt).sum(axis=1))
