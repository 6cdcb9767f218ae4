"""What every MPPI critic shares (Nav2's ``CriticFunction``): its three parameters and how its cost is added."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, TypeVar

import numpy as np

from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.base import ControllerSetup
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
    from navlog.replay.nav2.controllers.mppi.params import MPPIParams


@dataclass(frozen=True)
class CriticParams:
    """What every MPPI critic reads (``CriticFunction``): enabled, cost_power, cost_weight."""

    enabled: bool = True
    cost_power: int = param(1, ge=1)
    cost_weight: float = param(1.0, ge=0.0)


P = TypeVar("P", bound=CriticParams)


class Critic(Generic[P]):
    """One critic: built from its parameters and the controller's; ``score`` adds to ``data.costs``."""

    def __init__(self, p: P, mppi: MPPIParams, setup: ControllerSetup) -> None:
        self.p = p

    def add(self, data: CriticData, cost: np.ndarray, weight: float | None = None) -> None:
        """``data.costs += (cost * weight) ** cost_power`` (the power only when above 1), as every critic."""
        w = self.p.cost_weight if weight is None else weight
        data.costs += (cost * w) ** self.p.cost_power if self.p.cost_power > 1 else cost * w

    def score(self, data: CriticData) -> None:  # pragma: no cover - every critic overrides it
        raise NotImplementedError
