"""Controllers of Nav2's controller server and their goal and progress checkers.

Their parameters are read and checked (one module per plugin: ``regulated_pure_pursuit``,
``checkers``; a package for each of ``mppi`` and ``dwb``); each implementation sits beside its
parameters and is registered in ``registry`` (``RegulatedPurePursuitController`` runs Nav2 Jazzy's
Regulated Pure Pursuit, ``MPPIController`` its MPPI with the critics of ``mppi.critics``, one module
per critic, ``DWBController`` Humble's DWB local planner).
``server`` reads the controller server's parameters; ``controller_server`` runs its FollowPath cycle
(``ControllerServer``), with the goal and progress checkers of ``checkers``.

Names are imported on first use, so importing the package stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.checkers import (
        GoalCheckerParams,
        PoseProgressChecker,
        PositionGoalChecker,
        ProgressCheckerParams,
        SimpleGoalChecker,
        SimpleProgressChecker,
        StoppedGoalChecker,
    )
    from navlog.replay.nav2.controllers.controller_server import ControllerServer, CycleOutcome
    from navlog.replay.nav2.controllers.dwb import DWBController, DWBParams
    from navlog.replay.nav2.controllers.mppi import MPPIController, MPPIParams
    from navlog.replay.nav2.controllers.registry import CONTROLLERS, GOAL_CHECKERS, PROGRESS_CHECKERS, ControllerParams
    from navlog.replay.nav2.controllers.regulated_pure_pursuit import (
        RegulatedPurePursuitController,
        RegulatedPurePursuitParams,
    )
    from navlog.replay.nav2.controllers.server import ControllerServerParams, read_controller_server

__all__ = [
    "CONTROLLERS",
    "GOAL_CHECKERS",
    "PROGRESS_CHECKERS",
    "ControllerParams",
    "ControllerServer",
    "ControllerServerParams",
    "CycleOutcome",
    "DWBController",
    "DWBParams",
    "GoalCheckerParams",
    "MPPIController",
    "MPPIParams",
    "PoseProgressChecker",
    "PositionGoalChecker",
    "ProgressCheckerParams",
    "RegulatedPurePursuitController",
    "RegulatedPurePursuitParams",
    "SimpleGoalChecker",
    "SimpleProgressChecker",
    "StoppedGoalChecker",
    "read_controller_server",
]

# the module, below this package, that defines each public name
_MODULES = {
    "GoalCheckerParams": "checkers",
    "ProgressCheckerParams": "checkers",
    "PoseProgressChecker": "checkers",
    "PositionGoalChecker": "checkers",
    "SimpleGoalChecker": "checkers",
    "SimpleProgressChecker": "checkers",
    "StoppedGoalChecker": "checkers",
    "ControllerServer": "controller_server",
    "CycleOutcome": "controller_server",
    "DWBController": "dwb",
    "DWBParams": "dwb",
    "MPPIController": "mppi",
    "MPPIParams": "mppi",
    "CONTROLLERS": "registry",
    "GOAL_CHECKERS": "registry",
    "PROGRESS_CHECKERS": "registry",
    "ControllerParams": "registry",
    "RegulatedPurePursuitController": "regulated_pure_pursuit",
    "RegulatedPurePursuitParams": "regulated_pure_pursuit",
    "ControllerServerParams": "server",
    "read_controller_server": "server",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
