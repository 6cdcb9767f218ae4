"""``MPPIParams``: every listed critic's section read and checked."""

from __future__ import annotations

from navlog.replay.nav2 import load_nav2_params, parse_nav2_text
from navlog.replay.nav2.controllers.mppi.controller import MPPIController
from navlog.replay.nav2.controllers.mppi.critics import CostCriticParams
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from navlog.replay.nav2.controllers.registry import CONTROLLERS
from tests.replay.nav2.controllers.mppi.unit_setup import JAZZY_ARTICLE


def test_seed_001_file_reads_every_critic_section_checked():
    p = load_nav2_params(JAZZY_ARTICLE)
    assert p.errors == []
    mppi = p.controller_server.controllers["FollowPath"]
    assert isinstance(mppi, MPPIParams) and mppi.batch_size == 2000 and mppi.regenerate_noises
    cost = mppi.critic_params["CostCritic"]
    assert isinstance(cost, CostCriticParams) and cost.consider_footprint and cost.near_goal_distance == 1.0
    assert mppi.critic_params["PathAlignCritic"].cost_weight == 14.0
    assert mppi.critic_params["PathAngleCritic"].max_angle_to_furthest == 1.0
    assert mppi.ackermann.min_turning_r == 0.2
    assert CONTROLLERS.implementation("nav2_mppi_controller::MPPIController") is MPPIController


def test_critic_typos_and_bad_values_are_reported():
    text = """
controller_server:
  ros__parameters:
    FollowPath:
      plugin: nav2_mppi_controller::MPPIController
      critics: [CostCritic, GoalCritik]
      CostCritic:
        cost_wieght: 3.0
        trajectory_point_step: 0
        near_collision_cost: 260
"""
    p = parse_nav2_text(text)
    msgs = {x.path.split("FollowPath.")[-1]: x.message for x in p.problems if x.severity == "error"}
    assert "did you mean 'GoalCritic'?" in msgs["critics"]
    assert "did you mean 'cost_weight'?" in msgs["CostCritic.cost_wieght"]
    assert "must be >= 1" in msgs["CostCritic.trajectory_point_step"]
    warnings = {x.path.split("FollowPath.")[-1]: x.message for x in p.problems if x.severity == "warning"}
    assert "critical_cost is never added" in warnings["CostCritic.near_collision_cost"]
