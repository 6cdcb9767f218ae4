"""Planners by Nav2 plugin type, and the planner a planner server's parameters configure."""

from __future__ import annotations

import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2 import parse_nav2_text
from navlog.replay.nav2.planners import (
    PLANNER_NAMES,
    PLANNERS,
    NavfnParams,
    NavfnPlanner,
    PlannerServerParams,
    Smac2DParams,
    Smac2DPlanner,
    make_planner,
)
from tests.replay.nav2.planners.grids import free_grid

BUILT = {"nav2_navfn_planner::NavfnPlanner": NavfnPlanner, "nav2_smac_planner::SmacPlanner2D": Smac2DPlanner}


@pytest.mark.parametrize("plugin", [name for name in PLANNERS if PLANNERS[name] is not None])
def test_each_registered_planner_builds_and_plans(plugin):
    params = PLANNERS[plugin].params()
    planner = PLANNERS.create(plugin, params)
    assert type(planner) is BUILT[plugin] and planner.p is params
    plan = planner.plan(free_grid(), (1.0, 1.0, 0.0), (2.0, 1.0, 0.0))
    assert plan.length == pytest.approx(1.0, abs=0.1)


def test_short_names_and_humble_slash_names():
    assert set(PLANNER_NAMES.values()) == set(BUILT)
    assert PLANNERS.implementation("nav2_navfn_planner/NavfnPlanner") is NavfnPlanner


def test_unknown_or_not_implemented_planner():
    with pytest.raises(ConfigError, match=r"did you mean 'nav2_navfn_planner::NavfnPlanner'\?"):
        PLANNERS.implementation("nav2_navfn_planner::NavFnPlanner")
    with pytest.raises(ConfigError, match="read, not implemented by navlog"):
        PLANNERS.implementation("nav2_smac_planner::SmacPlannerHybrid")
    with pytest.raises(ConfigError, match="did you mean 'smac2d'"):
        make_planner(None, "smac2", "")


SERVER = """\
planner_server:
  ros__parameters:
    planner_plugins: ["Fast", "Careful", "Smac"]
    Fast:
      plugin: nav2_navfn_planner/NavfnPlanner
      tolerance: 0.3
    Careful:
      plugin: nav2_navfn_planner::NavfnPlanner
      use_astar: true
    Smac:
      plugin: nav2_smac_planner::SmacPlanner2D
      cost_travel_multiplier: 1.5
"""


def test_make_planner_picks_the_configured_entry():
    server = parse_nav2_text(SERVER).planner_server
    assert isinstance(server, PlannerServerParams) and list(server.planners) == ["Fast", "Careful", "Smac"]
    first = make_planner(server, "navfn")
    assert isinstance(first, NavfnPlanner) and first.p.tolerance == 0.3 and first.potential == "exact"
    careful = make_planner(server, "navfn", "Careful", potential="python")
    assert careful.p.use_astar and careful.potential == "python"
    smac = make_planner(server, "smac2d")
    assert isinstance(smac, Smac2DPlanner) and smac.p.cost_travel_multiplier == 1.5
    with pytest.raises(ConfigError, match="did you mean 'Careful'"):
        make_planner(server, "navfn", "Carefull")
    # no planner server, or none of the type: the planner's defaults
    assert make_planner(None, "smac2d").p == Smac2DParams()
    assert make_planner(PlannerServerParams(), "navfn").p == NavfnParams()
