"""Nav2's planner server: its parameters, the planners it lists, and the planner they configure.

``read_planner_server`` reads the ``planner_server`` block with each plugin in ``planner_plugins``
as its registered type; ``make_planner`` builds the planner a pipeline or ``navlog plan`` runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, cast

from navlog.errors import ConfigError
from navlog.replay.config import suggest
from navlog.replay.nav2.planners.base import Planner
from navlog.replay.nav2.planners.registry import PLANNER_NAMES, PLANNERS, PlannerParams
from navlog.replay.nav2.plugins import read_plugin_list
from navlog.replay.nav2.schema import WARNING, SectionReader, param


@dataclass(frozen=True)
class PlannerServerParams:
    """``planner_server`` node parameters with each listed planner's, by name."""

    expected_planner_frequency: float = param(1.0, ge=0.0)
    planner_plugins: tuple[str, ...] = ("GridBased",)
    costmap_update_timeout: float = param(1.0, ge=0.0)
    use_sim_time: bool = False
    planners: dict[str, PlannerParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "expected_planner_frequency",
        "costmap_update_timeout",
        "use_sim_time",
        "introspection_mode",
    )


def read_planner_server(r: SectionReader, params: dict, path: tuple) -> PlannerServerParams:
    """The node's parameters and its planners; a section not listed in planner_plugins is warned about."""
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
    server: PlannerServerParams | None, planner: str, planner_id: str = "", potential: str = "wavefront"
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
    return PLANNERS.create(plugin, params, **options)
