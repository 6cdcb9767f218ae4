"""Nav2's planner server: its parameters, the planners it lists, and the planner they configure.

``read_planner_server`` reads the ``planner_server`` block with each plugin in ``planner_plugins``
as its registered type; ``make_planner`` builds the planner a pipeline or ``navlog plan`` runs,
with Nav2's check around its search (``GoalChecks``): a plan that fails from a start in an obstacle
says so.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import ClassVar, cast

from navlog.errors import ConfigError
from navlog.replay.config import suggest
from navlog.replay.limits import MAX_RATE_HZ
from navlog.replay.nav2.costmap.cost_values import INSCRIBED, LETHAL
from navlog.replay.nav2.planners.base import Planner, PlanningCostmap, PlanningError, PlanResult, Pose2D
from navlog.replay.nav2.planners.registry import PLANNER_NAMES, PLANNERS, PlannerParams
from navlog.replay.nav2.plugins import read_plugin_list
from navlog.replay.nav2.schema import WARNING, SectionReader, param


@dataclass(frozen=True)
class PlannerServerParams:
    """``planner_server`` node parameters with each listed planner's, by name."""

    expected_planner_frequency: float = param(1.0, ge=0.0, le=MAX_RATE_HZ)
    planner_plugins: tuple[str, ...] = ("GridBased",)
    costmap_update_timeout: float = param(1.0, ge=0.0)
    use_sim_time: bool = False
    planners: dict[str, PlannerParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "expected_planner_frequency",
        "costmap_update_timeout",
        "use_sim_time",
        "introspection_mode",
        "allow_partial_planning",  # Nav2 after Jazzy: a path to the nearest reachable pose (off by default)
    )


def read_planner_server(r: SectionReader, params: dict, path: tuple) -> PlannerServerParams:
    """The node's parameters and its planners; a section not listed in planner_plugins is warned about."""
    if params.get("allow_partial_planning", False) is True:
        r.add(
            WARNING,
            path + ("allow_partial_planning",),
            "allow_partial_planning: true has Nav2 return a path to the reachable pose nearest an unreachable goal; "
            "navlog's planners fail such a goal instead",
        )
    planners = read_plugin_list(
        r, params, path, "planner_plugins", PLANNERS, ["GridBased"], "nav2_navfn_planner::NavfnPlanner"
    )
    names = params.get("planner_plugins", ["GridBased"])
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    for s in sections:
        if isinstance(names, list) and s not in names:
            r.add(WARNING, path + (s,), f"section '{s}' is not in planner_plugins: Nav2 ignores it")
    return r.read(PlannerServerParams, params, path, sections=sections, extra={"planners": planners})


def make_planner(
    server: PlannerServerParams | None, planner: str, planner_id: str = "", potential: str = "exact"
) -> Planner:
    """The ``planner`` (a short name, ``PLANNER_NAMES``) as a planner server's parameters configure it.

    ``planner_id`` picks the planner_plugins entry by name; without it, the first entry of that type
    is used, or the planner's defaults if there is none (or no planner server). ``potential`` is
    NavFn's way to grow its potential (``NavfnPlanner``).
    """
    if planner not in PLANNER_NAMES:
        known = ", ".join(PLANNER_NAMES)
        raise ConfigError(f"unknown planner '{planner}'{suggest(planner, PLANNER_NAMES)}; known: {known}")
    plugin = PLANNER_NAMES[planner]
    found: dict[str, PlannerParams] = {}
    if server is not None:
        found = {k: v for k, v in server.planners.items() if v.plugin == plugin}
    if planner_id:
        if planner_id not in found:
            raise ConfigError(
                f"planner '{planner_id}' of type {planner} not in planner_server{suggest(planner_id, found)}"
            )
        params = found[planner_id]
    else:
        entry = PLANNERS[plugin]
        assert entry is not None
        params = next(iter(found.values()), cast(PlannerParams, entry.params()))
    options = {"potential": potential} if planner == "navfn" else {}
    return checked(PLANNERS.implementation(plugin))(params, **options)


class GoalChecks:
    """Nav2's check around a planner's own search, mixed into the planner class (``checked``): a failed
    plan whose start cell is an obstacle (lethal, or inscribed: the robot's footprint touches one) is
    reported as such, not as a goal or tolerance problem. (NavFn checks the goal's own potential before
    its tolerance search itself, as Nav2's ``makePlan`` does.)"""

    def plan(self, cm: PlanningCostmap, start: Pose2D, goal: Pose2D) -> PlanResult:
        try:
            return cast(Planner, super()).plan(cm, start, goal)
        except PlanningError as exc:
            blocked = start_in_obstacle(cm, start)
            if blocked:
                raise PlanningError(blocked) from exc
            raise


def start_in_obstacle(cm: PlanningCostmap, start: Pose2D) -> str:
    """'the start (x, y) is in an obstacle ...' when the start's cell is lethal or inscribed, else ''."""
    ny, nx = cm.costs.shape
    mx = math.floor((start[0] - cm.origin_x) / cm.resolution)
    my = math.floor((start[1] - cm.origin_y) / cm.resolution)
    if not (0 <= mx < nx and 0 <= my < ny):
        return ""
    cost = int(cm.costs[my, mx])
    if cost not in (INSCRIBED, LETHAL):
        return ""
    kind = "lethal: inside an obstacle" if cost == LETHAL else "inscribed: the footprint touches an obstacle"
    return (
        f"the start ({start[0]:.2f}, {start[1]:.2f}) is in an obstacle (cost {cost}, {kind}) and no path leaves it; "
        "check the robot pose (TF, --start) and the map, or lower the inflation / robot radius"
    )


@functools.cache
def checked(cls: type) -> type:
    """``cls`` with ``GoalChecks`` around its ``plan`` (same name, an instance of ``cls``)."""
    return type(cls.__name__, (GoalChecks, cls), {"__doc__": cls.__doc__, "__module__": cls.__module__})
