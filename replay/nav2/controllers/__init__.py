"""Controllers of Nav2's controller server and their goal and progress checkers.

Today their parameters are read and checked (one module per plugin: ``regulated_pure_pursuit``,
``mppi``, ``checkers``); the controllers themselves are not implemented yet, and will sit beside
their parameters, registered in ``registry``. ``server`` reads the controller server's parameters.

Names are imported on first use, so importing the package stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.checkers import GoalCheckerParams, ProgressCheckerParams
    from navlog.replay.nav2.controllers.mppi import MPPIParams
    from navlog.replay.nav2.controllers.registry import CONTROLLERS, GOAL_CHECKERS, PROGRESS_CHECKERS, ControllerParams
    from navlog.replay.nav2.controllers.regulated_pure_pursuit import RegulatedPurePursuitParams
    from navlog.replay.nav2.controllers.server import ControllerServerParams, read_controller_server

__all__ = [
    "CONTROLLERS",
    "GOAL_CHECKERS",
    "PROGRESS_CHECKERS",
    "ControllerParams",
    "ControllerServerParams",
    "GoalCheckerParams",
    "MPPIParams",
    "ProgressCheckerParams",
    "RegulatedPurePursuitParams",
    "read_controller_server",
]

# the module, below this package, that defines each public name
_MODULES = {
    "GoalCheckerParams": "checkers",
    "ProgressCheckerParams": "checkers",
    "MPPIParams": "mppi",
    "CONTROLLERS": "registry",
    "GOAL_CHECKERS": "registry",
    "PROGRESS_CHECKERS": "registry",
    "ControllerParams": "registry",
    "RegulatedPurePursuitParams": "regulated_pure_pursuit",
    "ControllerServerParams": "server",
    "read_controller_server": "server",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
