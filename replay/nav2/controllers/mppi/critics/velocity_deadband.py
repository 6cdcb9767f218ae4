"""``mppi::critics::VelocityDeadbandCritic``: speeds inside the deadband a drive cannot hold."""

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
class VelocityDeadbandCriticParams(CriticParams):
    cost_weight: float = param(35.0, ge=0.0)
    deadband_velocities: tuple[float, ...] = (0.0, 0.0, 0.0)


def deadband_speeds(vx, vy, wz, deadband, holonomic, dt, out):
    """Each trajectory's speeds inside the deadband (|vx|, |wz|, and |vy| when ``holonomic``, each below
    its ``deadband``) integrated over time (``out``, float64), to be compiled."""
    for i in range(vx.shape[0]):
        total = 0.0
        for j in range(vx.shape[1]):
            step = max(deadband[0] - abs(float(vx[i, j])), 0.0) + max(deadband[2] - abs(float(wz[i, j])), 0.0)
            if holonomic:
                step += max(deadband[1] - abs(float(vy[i, j])), 0.0)
            total += step * dt
        out[i] = total


@functools.cache
def compiled_deadband_speeds() -> Callable[..., None]:
    """``deadband_speeds`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (deadband_speeds,))["deadband_speeds"]


class VelocityDeadbandCritic(Critic[VelocityDeadbandCriticParams]):
    """Speeds inside the deadband (per axis, vy for Omni only), integrated over time."""

    def score(self, data: CriticData) -> None:
        db = [abs(v) for v in (tuple(self.p.deadband_velocities) + (0.0, 0.0, 0.0))[:3]]
        out = np.empty(data.vx.shape[0])
        compiled_deadband_speeds()(data.vx, data.vy, data.wz, np.array(db), data.holonomic, float(data.model_dt), out)
        self.add(data, out)
