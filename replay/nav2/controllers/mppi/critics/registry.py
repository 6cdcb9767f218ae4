"""The MPPI critics by Nav2 plugin name: each name's parameters and code, and the critics a controller runs.

``critics`` lists a critic by its plugin name, ``mppi::critics::GoalCritic``, or by its short name,
``GoalCritic``, as Nav2 accepts both; ``CRITICS`` is keyed by the short name.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from navlog.errors import ConfigError
from navlog.replay.config import suggest
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.controllers.mppi.critics.constraint import ConstraintCritic, ConstraintCriticParams
from navlog.replay.nav2.controllers.mppi.critics.cost import CostCritic, CostCriticParams
from navlog.replay.nav2.controllers.mppi.critics.goal import GoalCritic, GoalCriticParams
from navlog.replay.nav2.controllers.mppi.critics.goal_angle import GoalAngleCritic, GoalAngleCriticParams
from navlog.replay.nav2.controllers.mppi.critics.obstacles import ObstaclesCriticParams
from navlog.replay.nav2.controllers.mppi.critics.path_align import PathAlignCritic, PathAlignCriticParams
from navlog.replay.nav2.controllers.mppi.critics.path_angle import PathAngleCritic, PathAngleCriticParams
from navlog.replay.nav2.controllers.mppi.critics.path_follow import PathFollowCritic, PathFollowCriticParams
from navlog.replay.nav2.controllers.mppi.critics.prefer_forward import PreferForwardCritic, PreferForwardCriticParams
from navlog.replay.nav2.controllers.mppi.critics.twirling import TwirlingCritic, TwirlingCriticParams
from navlog.replay.nav2.controllers.mppi.critics.velocity_deadband import (
    VelocityDeadbandCritic,
    VelocityDeadbandCriticParams,
)

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.base import ControllerSetup
    from navlog.replay.nav2.controllers.mppi.params import MPPIParams

PLUGIN_PREFIX = "mppi::critics::"

CRITICS: dict[str, tuple[type[CriticParams], type[Critic[Any]] | None]] = {
    "ConstraintCritic": (ConstraintCriticParams, ConstraintCritic),
    "CostCritic": (CostCriticParams, CostCritic),
    "GoalCritic": (GoalCriticParams, GoalCritic),
    "GoalAngleCritic": (GoalAngleCriticParams, GoalAngleCritic),
    "ObstaclesCritic": (ObstaclesCriticParams, None),
    "PathAlignCritic": (PathAlignCriticParams, PathAlignCritic),
    "PathAngleCritic": (PathAngleCriticParams, PathAngleCritic),
    "PathFollowCritic": (PathFollowCriticParams, PathFollowCritic),
    "PreferForwardCritic": (PreferForwardCriticParams, PreferForwardCritic),
    "TwirlingCritic": (TwirlingCriticParams, TwirlingCritic),
    "VelocityDeadbandCritic": (VelocityDeadbandCriticParams, VelocityDeadbandCritic),
}
"""Critic short name -> (its parameters, its code; None: read and checked, not run)."""


def critic_entry(name: str) -> tuple[type[CriticParams], type[Critic[Any]] | None] | None:
    """The ``CRITICS`` entry of a name as ``critics`` lists it (plugin or short name); None if unknown."""
    return CRITICS.get(name.removeprefix(PLUGIN_PREFIX))


def build_critics(params: MPPIParams, setup: ControllerSetup) -> list[Critic[Any]]:
    """The enabled critics of ``params.critics``, in order (ConfigError for one navlog does not run)."""
    out: list[Critic[Any]] = []
    for name in params.critics:
        entry = critic_entry(name)
        if entry is None:
            raise ConfigError(f"unknown MPPI critic '{name}'{suggest(name, list(CRITICS))}")
        ptype, ctype = entry
        if ctype is None:
            runnable = ", ".join(n for n, (_, c) in CRITICS.items() if c is not None)
            raise ConfigError(f"MPPI critic '{name}' is read, not implemented by navlog; use one of {runnable}")
        p = params.critic_params.get(name, ptype())
        if p.enabled:
            out.append(ctype(p, params, setup))
    return out
