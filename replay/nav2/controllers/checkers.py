"""Goal and progress checkers of the controller server: their parameters (read and checked; not run yet).

A goal checker decides when the robot has reached its goal (``nav2_controller::SimpleGoalChecker``,
``StoppedGoalChecker``); a progress checker when it has stopped making progress
(``SimpleProgressChecker``, ``PoseProgressChecker``).
"""

from __future__ import annotations

from dataclasses import dataclass

from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param


@dataclass(frozen=True)
class GoalCheckerParams(PluginParams):
    """``nav2_controller::SimpleGoalChecker`` / ``StoppedGoalChecker`` parameters."""

    plugin: str = "nav2_controller::SimpleGoalChecker"
    xy_goal_tolerance: float = param(0.25, ge=0.0)
    yaw_goal_tolerance: float = param(0.25, ge=0.0)
    stateful: bool = True
    trans_stopped_velocity: float = param(0.25, ge=0.0)
    rot_stopped_velocity: float = param(0.25, ge=0.0)


@dataclass(frozen=True)
class ProgressCheckerParams(PluginParams):
    """``nav2_controller::SimpleProgressChecker`` / ``PoseProgressChecker`` parameters."""

    plugin: str = "nav2_controller::SimpleProgressChecker"
    required_movement_radius: float = param(0.5, ge=0.0)
    movement_time_allowance: float = param(10.0, ge=0.0)
    required_movement_angle: float = param(0.5, ge=0.0)
