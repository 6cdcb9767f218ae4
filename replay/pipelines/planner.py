"""The planner pipeline: regenerate the global costmap and /plan from a log's map or scans, TF and goals.

Nav2 parameters come from a Nav2 file (``nav2_params``; the defaults of Nav2 when empty) with
overrides in Nav2 key paths: ``--set global_costmap.global_costmap.ros__parameters.inflation_layer.
inflation_radius=0.5`` or the shorter ``--set global_costmap.inflation_layer.inflation_radius=0.5``
(any ordered subset of the path that names one parameter). Goals: /goal_pose from the log, or a goals
YAML (``goals``: a name in config/goals/ or a path), planned in turn from the robot pose.

Outputs: /global_costmap/costmap, /global_costmap/published_footprint, /plan and plan events in
replay.mcap; plans.json (length, cost, goal of every plan) as an artifact.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from navlog.errors import ConfigError
from navlog.replay.config import find_config, known_configs, load_yaml, suggest
from navlog.replay.io.map_server import load_map
from navlog.replay.nav2.params import (
    CostmapParams,
    InflationLayerParams,
    NavfnParams,
    ObstacleLayerParams,
    Smac2DParams,
    StaticLayerParams,
    apply_nav2_overrides,
    load_nav2_params,
    parse_nav2_params,
)
from navlog.replay.nav2.planners.navfn import NavfnPlanner
from navlog.replay.nav2.planners.smac2d import Smac2DPlanner
from navlog.replay.nodes.planner import CostmapNode, PlannerNode
from navlog.replay.runtime.pipeline import Pipeline

# `navlog replay --pipeline planner --params nav2_params.yaml` fills this key
PARAMS_FILE_KEY = "nav2_params"


@dataclass(frozen=True)
class Params:
    nav2_params: str = ""  # a Nav2 parameter file; empty: Nav2's defaults
    planner: Literal["navfn", "smac2d"] = "navfn"
    planner_id: str = ""  # the planner_plugins entry to use; empty: the first of its type
    navfn_potential: Literal["wavefront", "exact"] = "wavefront"
    map: str = ""  # a map_server YAML used as the static layer instead of the log's /map
    goals: str = ""  # a goals YAML (name in config/goals/ or a path); empty: /goal_pose from the log
    goal_frame: str = "map"
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)  # first leg's start when the log has no robot TF
    replan_period_s: float = 1.0
    goal_tolerance: float = 0.25  # the goal counts as reached within this distance (SimpleGoalChecker)
    # Nav2 overrides, as nested mappings under the node names (filled by --set NODE.a.b=value)
    global_costmap: dict[str, Any] = field(default_factory=dict)
    planner_server: dict[str, Any] = field(default_factory=dict)


def _flatten(prefix: str, d: Any) -> list[str]:
    if isinstance(d, dict):
        out = []
        for k, v in d.items():
            out += _flatten(f"{prefix}.{k}", v)
        return out
    return [f"{prefix}={json.dumps(d)}"]


def nav2_overrides(params: Params) -> list[str]:
    return (
        _flatten("global_costmap", params.global_costmap) + _flatten("planner_server", params.planner_server)
        if (params.global_costmap or params.planner_server)
        else []
    )


def load_goals(spec: str) -> tuple[list[tuple[float, float, float]], str]:
    """Goals (x, y, yaw) and their frame from a goals YAML: name in config/goals/ or a path."""
    path = Path(spec)
    if not path.is_file():
        found = find_config("goals", spec)
        if found is None:
            known = known_configs("goals")
            raise ConfigError(f"goals '{spec}' not found{suggest(spec, known)}; known: {', '.join(known) or 'none'}")
        path = found
    doc = load_yaml(path)
    if not isinstance(doc, dict) or not isinstance(doc.get("goals"), list):
        raise ConfigError(f"{path}: expected 'goals:' with a list of {{name, x, y, yaw}}")
    goals = []
    for i, g in enumerate(doc["goals"]):
        try:
            goals.append((float(g["x"]), float(g["y"]), float(g.get("yaw", 0.0))))
        except (TypeError, KeyError, ValueError):
            raise ConfigError(f"{path}: goals[{i}]: expected x, y and yaw numbers, got {g!r}") from None
    return goals, str(doc.get("frame_id", "map"))


def nav2_config(params: Params):
    """The Nav2 parameters the pipeline runs with (file + overrides), errors raised at once."""
    overrides = nav2_overrides(params)
    if params.nav2_params:
        nav2 = load_nav2_params(params.nav2_params, overrides)
    else:
        nav2 = parse_nav2_params(apply_nav2_overrides({}, overrides) if overrides else {}, source="<defaults>")
    nav2.require_valid(("global_costmap", "planner_server"))
    return nav2


def make_planner(nav2, planner: str, planner_id: str = "", potential: str = "wavefront"):
    wanted = NavfnParams if planner == "navfn" else Smac2DParams
    found = {}
    if nav2.planner_server is not None:
        found = {k: v for k, v in nav2.planner_server.planners.items() if isinstance(v, wanted)}
    if planner_id:
        if planner_id not in found:
            raise ConfigError(
                f"planner '{planner_id}' of type {planner} not in planner_server{suggest(planner_id, found)}"
            )
        p = found[planner_id]
    else:
        p = next(iter(found.values()), wanted())
    return NavfnPlanner(p, potential=potential) if planner == "navfn" else Smac2DPlanner(p)


def default_costmap() -> CostmapParams:
    layers = {
        "static_layer": StaticLayerParams(),
        "obstacle_layer": ObstacleLayerParams(),
        "inflation_layer": InflationLayerParams(),
    }
    return CostmapParams(layers=layers)


def build(params: Params, log_topics: set[str]) -> Pipeline:
    nav2 = nav2_config(params)
    cparams = nav2.global_costmap or default_costmap()
    static_map = load_map(params.map) if params.map else None
    cm_node = CostmapNode(cparams, "global_costmap", static_map=static_map)
    planner = make_planner(nav2, params.planner, params.planner_id, params.navfn_potential)
    goals, frame = load_goals(params.goals) if params.goals else ([], params.goal_frame)
    pl = PlannerNode(
        cm_node,
        planner,
        goals,
        goal_frame=frame,
        replan_period_s=params.replan_period_s,
        goal_tolerance=params.goal_tolerance,
        start=params.start,
    )
    inputs: list[str] = []
    optional = ["/tf", "/tf_static"]
    if cm_node.costmap.static_layers and static_map is None:
        inputs.append("/map")
    optional += [t for t in cm_node.topics if t not in inputs]
    if not params.goals:
        inputs.append("/goal_pose")

    def write_artifacts(out: Path) -> dict[str, Path]:
        path = out / "plans.json"
        rows = [
            {
                "time_ns": t,
                "planner": p.planner,
                "length_m": round(p.length, 6),
                "cost": round(p.cost, 6),
                "goal": [round(v, 6) for v in p.goal_used],
                "poses": len(p.poses),
                "notes": p.notes,
            }
            for t, p in pl.plans
        ]
        fails = [{"time_ns": t, "error": e} for t, e in pl.failures]
        path.write_text(json.dumps({"plans": rows, "failures": fails}, indent=2, sort_keys=True) + "\n")
        return {"plans": path}

    def skipped() -> dict[str, int]:
        out = dict(cm_node.skipped)
        out.update(cm_node.costmap.skipped)
        for k, v in pl.skipped.items():
            out[k] = out.get(k, 0) + v
        return out

    return Pipeline(
        name="planner",
        nodes=[cm_node, pl],
        inputs=inputs,
        optional_inputs=optional,
        outputs=["/global_costmap/costmap", "/global_costmap/published_footprint", "/plan", "/navlog/events"],
        write_artifacts=write_artifacts,
        skipped=skipped,
    )
