"""Controller, goal checker and progress checker plugins by Nav2 type name.

navlog reads and checks the parameters of Regulated Pure Pursuit, MPPI, DWB and the simple checkers,
and runs those registered with an implementation (``Plugin(params, implementation)``). The other
controllers Nav2 ships are known, so a file using them is not an error, but navlog neither reads nor
runs them.
"""

from __future__ import annotations

from navlog.replay.nav2.controllers.checkers import (
    GoalCheckerParams,
    PoseProgressChecker,
    PositionGoalChecker,
    ProgressCheckerParams,
    SimpleGoalChecker,
    SimpleProgressChecker,
    StoppedGoalChecker,
)
from navlog.replay.nav2.controllers.dwb import DWBController, DWBParams
from navlog.replay.nav2.controllers.mppi import MPPIController, MPPIParams
from navlog.replay.nav2.controllers.regulated_pure_pursuit import (
    RegulatedPurePursuitController,
    RegulatedPurePursuitParams,
)
from navlog.replay.nav2.plugins import Plugin, PluginRegistry

CONTROLLERS: PluginRegistry[object] = PluginRegistry(
    "controller",
    {
        "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController": Plugin(
            RegulatedPurePursuitParams, RegulatedPurePursuitController
        ),
        "nav2_mppi_controller::MPPIController": Plugin(MPPIParams, MPPIController),
        "dwb_core::DWBLocalPlanner": Plugin(DWBParams, DWBController),
        # known to Nav2, read but not implemented
        "nav2_rotation_shim_controller::RotationShimController": None,
        "nav2_graceful_controller::GracefulController": None,
    },
)
GOAL_CHECKERS: PluginRegistry[object] = PluginRegistry(
    "goal checker",
    {
        "nav2_controller::SimpleGoalChecker": Plugin(GoalCheckerParams, SimpleGoalChecker),
        "nav2_controller::StoppedGoalChecker": Plugin(GoalCheckerParams, StoppedGoalChecker),
        "nav2_controller::PositionGoalChecker": Plugin(GoalCheckerParams, PositionGoalChecker),
    },
)
PROGRESS_CHECKERS: PluginRegistry[object] = PluginRegistry(
    "progress checker",
    {
        "nav2_controller::SimpleProgressChecker": Plugin(ProgressCheckerParams, SimpleProgressChecker),
        "nav2_controller::PoseProgressChecker": Plugin(ProgressCheckerParams, PoseProgressChecker),
    },
)

ControllerParams = RegulatedPurePursuitParams | MPPIParams | DWBParams
