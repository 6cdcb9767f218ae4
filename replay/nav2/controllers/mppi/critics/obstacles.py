"""``mppi::critics::ObstaclesCritic``: its parameters, read and checked; navlog runs the CostCritic instead."""

from __future__ import annotations

from dataclasses import dataclass

from navlog.replay.nav2.controllers.mppi.critics.base import CriticParams
from navlog.replay.nav2.schema import param


@dataclass(frozen=True)
class ObstaclesCriticParams(CriticParams):
    """Read and checked; navlog runs the CostCritic (Nav2's default since Iron) instead."""

    consider_footprint: bool = False
    critical_weight: float = param(20.0, ge=0.0)
    repulsion_weight: float = param(1.5, ge=0.0)
    collision_cost: float = param(100000.0, ge=0.0)
    collision_margin_distance: float = param(0.10, ge=0.0)
    near_goal_distance: float = param(0.5, ge=0.0)
    inflation_layer_name: str = ""
