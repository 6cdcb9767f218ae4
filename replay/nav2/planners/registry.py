"""Planner plugins by Nav2 type name: the parameters each reads and the planner class that runs it.

navlog runs ``nav2_navfn_planner::NavfnPlanner`` (NavFn) and ``nav2_smac_planner::SmacPlanner2D``
(a Smac-2D-like planner); the other planners Nav2 ships are known, so a file using them is not an
error, but navlog neither reads nor runs them. On the command line the planners are named by their
short names (``PLANNER_NAMES``).
"""

from __future__ import annotations

from navlog.replay.nav2.planners.base import Planner
from navlog.replay.nav2.planners.navfn import NavfnParams, NavfnPlanner
from navlog.replay.nav2.planners.smac2d import Smac2DParams, Smac2DPlanner
from navlog.replay.nav2.plugins import Plugin, PluginRegistry

PLANNERS: PluginRegistry[Planner] = PluginRegistry(
    "planner",
    {
        "nav2_navfn_planner::NavfnPlanner": Plugin(NavfnParams, NavfnPlanner),
        "nav2_smac_planner::SmacPlanner2D": Plugin(Smac2DParams, Smac2DPlanner),
        # known to Nav2, read but not implemented
        "nav2_smac_planner::SmacPlannerHybrid": None,
        "nav2_smac_planner::SmacPlannerLattice": None,
        "nav2_theta_star_planner::ThetaStarPlanner": None,
    },
)

# short name (``--planner``) -> plugin type
PLANNER_NAMES = {
    "navfn": "nav2_navfn_planner::NavfnPlanner",
    "smac2d": "nav2_smac_planner::SmacPlanner2D",
}

# the parameter classes of the planners navlog reads
PlannerParams = NavfnParams | Smac2DParams
