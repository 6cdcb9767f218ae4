"""The MPPI critics' registry: names as ``critics`` lists them, the critics a controller runs."""

from __future__ import annotations

import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2.controllers.base import ControllerSetup
from navlog.replay.nav2.controllers.mppi.controller import MPPIController
from navlog.replay.nav2.controllers.mppi.critics import (
    CostCritic,
    GoalCritic,
    GoalCriticParams,
    PathAlignCritic,
    PathAlignCriticParams,
    TwirlingCritic,
    build_critics,
    critic_entry,
)
from navlog.replay.nav2.controllers.mppi.params import MPPIParams


def test_a_critic_navlog_does_not_run_is_a_clear_error():
    with pytest.raises(ConfigError, match="ObstaclesCritic' is read, not implemented by navlog; use one of"):
        MPPIController(MPPIParams(critics=("ObstaclesCritic",)), ControllerSetup())


def test_plugin_and_short_names_build_the_same_critics_in_order():
    setup = ControllerSetup()
    names = ("mppi::critics::GoalCritic", "TwirlingCritic", "mppi::critics::CostCritic")
    critics = build_critics(MPPIParams(critics=names), setup)
    assert [type(c) for c in critics] == [GoalCritic, TwirlingCritic, CostCritic]
    assert critic_entry("mppi::critics::PathAlignCritic") == (PathAlignCriticParams, PathAlignCritic)
    assert critic_entry("mppi::critics::GoalCritik") is None
    with pytest.raises(ConfigError, match="did you mean 'GoalCritic'"):
        build_critics(MPPIParams(critics=("GoalCritik",)), setup)


def test_a_disabled_critic_is_not_built():
    params = MPPIParams(
        critics=("GoalCritic", "TwirlingCritic"), critic_params={"GoalCritic": GoalCriticParams(enabled=False)}
    )
    assert [type(c) for c in build_critics(params, ControllerSetup())] == [TwirlingCritic]
