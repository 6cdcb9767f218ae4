"""Global planners as Nav2's planner plugins compute them: NavFn and a Smac-2D-like planner.

Each planner module holds its parameters and its code (``navfn``, ``smac2d``); ``base`` what they
share (``PlanResult``, ``PlanningError``, path length and cost); ``registry`` maps Nav2 plugin types
to them (``PLANNERS``); ``server`` reads the planner server's parameters and builds the planner they
configure (``make_planner``).

Names are imported on first use, so importing the package stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.nav2.planners.base import (
        Planner,
        PlanningCostmap,
        PlanningError,
        PlanResult,
        Pose2D,
        path_cost,
        path_length,
    )
    from navlog.replay.nav2.planners.navfn import NavfnParams, NavfnPlanner
    from navlog.replay.nav2.planners.registry import PLANNER_NAMES, PLANNERS, PlannerParams
    from navlog.replay.nav2.planners.server import PlannerServerParams, make_planner, read_planner_server
    from navlog.replay.nav2.planners.smac2d import Smac2DParams, Smac2DPlanner

__all__ = [
    "PLANNERS",
    "PLANNER_NAMES",
    "NavfnParams",
    "NavfnPlanner",
    "PlanResult",
    "Planner",
    "PlannerParams",
    "PlannerServerParams",
    "PlanningCostmap",
    "PlanningError",
    "Pose2D",
    "Smac2DParams",
    "Smac2DPlanner",
    "make_planner",
    "path_cost",
    "path_length",
    "read_planner_server",
]

# the module, below this package, that defines each public name
_MODULES = {
    "Planner": "base",
    "PlanningCostmap": "base",
    "PlanningError": "base",
    "PlanResult": "base",
    "Pose2D": "base",
    "path_cost": "base",
    "path_length": "base",
    "NavfnParams": "navfn",
    "NavfnPlanner": "navfn",
    "PLANNER_NAMES": "registry",
    "PLANNERS": "registry",
    "PlannerParams": "registry",
    "PlannerServerParams": "server",
    "make_planner": "server",
    "read_planner_server": "server",
    "Smac2DParams": "smac2d",
    "Smac2DPlanner": "smac2d",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
