"""Controller, goal checker and progress checker plugins by Nav2 type name.

navlog reads and checks the parameters of Regulated Pure Pursuit, MPPI and the simple checkers; it
runs none of them yet (no implementation is registered). The other controllers Nav2 ships are known,
so a file using them is not an error, but navlog neither reads nor runs them.
"""

from __future__ import annotations

from navlog.replay.nav2.controllers.checkers import GoalCheckerParams, ProgressCheckerParams
from navlog.replay.nav2.controllers.mppi import MPPIParams
from navlog.replay.nav2.controllers.regulated_pure_pursuit import RegulatedPurePursuitParams
from navlog.replay.nav2.plugins import Plugin, PluginRegistry

CONTROLLERS: PluginRegistry[object] = PluginRegistry(
    "controller",
    {
        "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController": Plugin(RegulatedPurePursuitParams),
        "nav2_mppi_controller::MPPIController": Plugin(MPPIParams),
        # known to Nav2, read but not implemented
        "dwb_core::DWBLocalPlanner": None,
        "nav2_rotation_shim_controller::RotationShimController": None,
        "nav2_graceful_controller::GracefulController": None,
    },
)
GOAL_CHECKERS: PluginRegistry[object] = PluginRegistry(
    "goal checker",
    {
        "nav2_controller::SimpleGoalChecker": Plugin(GoalCheckerParams),
        "nav2_controller::StoppedGoalChecker": Plugin(GoalCheckerParams),
    },
)
PROGRESS_CHECKERS: PluginRegistry[object] = PluginRegistry(
    "progress checker",
    {
        "nav2_controller::SimpleProgressChecker": Plugin(ProgressCheckerParams),
        "nav2_controller::PoseProgressChecker": Plugin(ProgressCheckerParams),
    },
)

ControllerParams = RegulatedPurePursuitParams | MPPIParams
