"""The planner pipeline: regenerate the global costmap and /plan from a log's map or scans, TF and goals.

Nav2 parameters come from a Nav2 file (``nav2_params``; the defaults of Nav2 when empty) with
overrides in Nav2 key paths: ``--set global_costmap.global_costmap.ros__parameters.inflation_layer.
inflation_radius=0.5`` or the shorter ``--set global_costmap.inflation_layer.inflation_radius=0.5``
(any ordered subset of the path that names one parameter); ``--set nav2.KEY=VALUE`` takes any key of
the file (``nav2.GridBased.tolerance=0.2``), as in every pipeline that runs Nav2 nodes. Goals: /goal_pose from the log, or a goals
YAML (``goals``: a name in config/goals/ or a path), planned in turn from the robot pose.

Outputs: /global_costmap/costmap, /global_costmap/published_footprint, /plan and plan events in
replay.mcap; plans.json (length, cost, goal of every plan) as an artifact.

One plan without a log: ``plan_on_map(map, start, goal, nav2_params=..., planner=...)`` builds the
global costmap on a map and plans once (what ``navlog plan`` runs); ``write_plan_mcap`` and
``write_plan_png`` save the result.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.config import find_config, known_configs, load_yaml, param, suggest
from navlog.replay.io import json_text
from navlog.replay.io.atomic import write_file
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.io.map_server import load_map
from navlog.replay.limits import MAX_GOAL_TOLERANCE_M, MAX_PERIOD_S, MIN_PERIOD_S, check_finite_pose
from navlog.replay.nav2 import Nav2Params, default_nav2_params, load_nav2_params
from navlog.replay.nav2.costmap import Costmap2D, default_costmap_params
from navlog.replay.nav2.costmap.grid import DEFAULT_LAYER_PLUGINS
from navlog.replay.nav2.overrides import apply_nav2_overrides, nav2_override_items
from navlog.replay.nav2.params import parse_nav2_params
from navlog.replay.nav2.planners import PLANNER_NAMES, PLANNERS, PlanningError, PlanResult, Pose2D, make_planner
from navlog.replay.nav2.planners.base import costmap_cell
from navlog.replay.nodes.costmap import CostmapNode, costmap_msg
from navlog.replay.nodes.planner import PlannerNode, path_cdr
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.pipelines import PipelineSpec, existing_file, register
from navlog.replay.runtime.executor import Envelope
from navlog.replay.runtime.pipeline import Pipeline


@dataclass(frozen=True)
class Params:
    nav2_params: str = ""  # a Nav2 parameter file; empty: Nav2's defaults
    planner: Literal["navfn", "smac2d"] = "navfn"
    planner_id: str = ""  # the planner_plugins entry to use; empty: the first of its type
    navfn_potential: Literal["exact", "python"] = "exact"
    map: str = ""  # a map_server YAML used as the static layer instead of the log's /map
    goals: str = ""  # a goals YAML (name in config/goals/ or a path); empty: /goal_pose from the log
    goal_frame: str = "map"
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)  # first leg's start when there is no robot pose
    replan_period_s: float = param(1.0, ge=MIN_PERIOD_S, le=MAX_PERIOD_S)  # s between two plans of one leg
    # the goal counts as reached within this distance (SimpleGoalChecker)
    goal_tolerance: float = param(0.25, ge=0.0, le=MAX_GOAL_TOLERANCE_M)
    # Nav2 overrides, as nested mappings under the node names (filled by --set NODE.a.b=value)
    global_costmap: dict[str, Any] = field(default_factory=dict)  # --set global_costmap.KEY=VALUE (KEY full or short)
    planner_server: dict[str, Any] = field(default_factory=dict)  # --set planner_server.KEY=VALUE
    nav2: dict[str, Any] = field(default_factory=dict)  # any Nav2 key, full or short: --set nav2.KEY=VALUE

    def __post_init__(self) -> None:
        check_finite_pose(self.start, "start")


def nav2_overrides(params: Params) -> list[str]:
    """The Nav2 overrides of ``--set global_costmap.KEY``, ``planner_server.KEY`` and ``nav2.KEY``."""
    blocks = {"global_costmap": params.global_costmap, "planner_server": params.planner_server, "nav2": params.nav2}
    return nav2_override_items(blocks)


def load_goals(spec: str) -> tuple[list[tuple[float, float, float]], str]:
    """Goals (x, y, yaw) and their frame from a goals YAML: name in config/goals/ or a path."""
    named, frame = load_named_goals(spec)
    return [pose for _, pose in named], frame


def load_named_goals(spec: str) -> tuple[list[tuple[str, tuple[float, float, float]]], str]:
    """Goals as (name, (x, y, yaw)) and their frame from a goals YAML (unnamed goals: 'goal N')."""
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
            pose = (float(g["x"]), float(g["y"]), float(g.get("yaw", 0.0)))
        except (TypeError, KeyError, ValueError):
            raise ConfigError(f"{path}: goals[{i}]: expected x, y and yaw numbers, got {g!r}") from None
        if not all(math.isfinite(v) for v in pose):
            raise ConfigError(f"{path}: goals[{i}]: x, y and yaw must be finite numbers, got {g!r}")
        goals.append((str(g.get("name", f"goal {i + 1}")), pose))
    return goals, str(doc.get("frame_id", "map"))


def default_planning_document(planner: str = "navfn") -> dict[str, Any]:
    """Nav2's defaults for planning as a parameter document, so that ``--set`` keys resolve without a file.

    The planner server lists one planner, ``GridBased`` (Nav2's name), of type ``planner`` with its
    default values written out (``tolerance``, ``use_astar``, ...); the global costmap lists Nav2's
    default layers, each with its plugin type (their parameters may be added by name).
    """
    plugin = PLANNER_NAMES[planner]
    entry = PLANNERS[plugin]
    assert entry is not None
    values = {k: v for k, v in vars(entry.params()).items() if isinstance(v, (bool, int, float, str)) and k != "plugin"}
    layers = {name: {"plugin": plugin_type} for name, plugin_type in DEFAULT_LAYER_PLUGINS.items()}
    return {
        "planner_server": {
            "ros__parameters": {"planner_plugins": ["GridBased"], "GridBased": {"plugin": plugin, **values}}
        },
        "global_costmap": {"global_costmap": {"ros__parameters": {"plugins": list(layers), **layers}}},
    }


def planning_nav2_params(
    nav2_params: str | Path | None, overrides: Sequence[str] = (), planner: str = "navfn"
) -> Nav2Params:
    """The Nav2 parameters planning runs with: a file (none: Nav2's defaults) with ``overrides`` applied.

    Without a file, overrides apply to ``default_planning_document(planner)``: ``tolerance=0.0``,
    ``GridBased.use_astar=true`` or ``global_costmap.inflation_layer.inflation_radius=0.3`` work as
    they do on a file. Errors in the global costmap or the planner server are raised at once as one
    ConfigError.
    """
    if nav2_params:
        nav2 = load_nav2_params(nav2_params, overrides)
    elif overrides:
        doc = apply_nav2_overrides(default_planning_document(planner), overrides)
        nav2 = parse_nav2_params(doc, source="<defaults>")
    else:
        nav2 = default_nav2_params()
    return nav2.require_valid(("global_costmap", "planner_server"))


def nav2_config(params: Params) -> Nav2Params:
    """The Nav2 parameters the pipeline runs with (file + overrides), errors raised at once."""
    return planning_nav2_params(params.nav2_params, nav2_overrides(params), params.planner)


def build(params: Params, log_topics: set[str]) -> Pipeline:
    nav2 = nav2_config(params)
    cparams = nav2.global_costmap or default_costmap_params()
    static_map = load_map(params.map) if params.map else None
    cm_node = CostmapNode(cparams, "global_costmap", static_map=static_map)
    planner = make_planner(nav2.planner_server, params.planner, params.planner_id, params.navfn_potential)
    goals, frame = load_goals(params.goals) if params.goals else ([], params.goal_frame)
    pl = PlannerNode(
        cm_node,
        planner,
        goals,
        goal_frame=frame,
        replan_period_s=params.replan_period_s,
        goal_tolerance=params.goal_tolerance,
        start=params.start,
        wait_for_robot_tf="/tf" in log_topics,
    )
    inputs: list[str] = []
    optional = ["/tf", "/tf_static"]
    if cm_node.costmap.static_layers and static_map is None:
        inputs.append("/map")
    optional += [t for t in cm_node.topics if t not in inputs]
    if not params.goals:
        inputs.append("/goal_pose")

    return PlannerRun(cm_node, pl, inputs, optional)


class PlannerRun(Pipeline):
    """The global costmap and the planner of one run; plans.json written after it."""

    def __init__(self, cm_node: CostmapNode, pl: PlannerNode, inputs: list[str], optional: list[str]) -> None:
        outputs = ["/global_costmap/costmap", "/global_costmap/published_footprint", "/plan", "/navlog/events"]
        super().__init__("planner", [cm_node, pl], inputs, optional, outputs)
        self.cm_node, self.pl = cm_node, pl

    def write_artifacts(self, out: Path) -> dict[str, Path]:
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
            for t, p in self.pl.plans
        ]
        fails = [{"time_ns": t, "error": e} for t, e in self.pl.failures]
        path.write_text(json_text.dumps({"plans": rows, "failures": fails}, indent=2, sort_keys=True) + "\n")
        return {"plans": path}

    def skipped(self) -> dict[str, int]:
        out = dict(self.cm_node.skipped)
        out.update(self.cm_node.costmap.skipped)
        for k, v in self.pl.skipped.items():
            out[k] = out.get(k, 0) + v
        return out

    def nothing_produced(self) -> str | None:
        return None if self.pl.plans or self.pl.failures else "no plan: no goal was planned for"


class OnMapToGoals(PipelineSpec):
    """A pipeline whose parameters name a static map (``map``) and a goals file (``goals``): the
    planner's, and the navigation stack's."""

    @classmethod
    def static_map(cls, params: Any) -> Path | None:
        return existing_file(params.map)

    @classmethod
    def goal_count(cls, params: Any) -> int | None:
        return len(load_goals(params.goals)[0]) if params.goals else None


@register
class Planner(OnMapToGoals):
    """Nav2's global costmap and planner server on the log's map or scans, TF and goals."""

    name = "planner"
    params_class = Params
    params_file_key = "nav2_params"  # `navlog replay --pipeline planner --params nav2_params.yaml`
    facts = PipelineSpec.facts | {"plans", "goals", "min_clearance", "all_goals_reached", "no_plan_failures"}
    summary_facts = ("plans",)
    world_map_key = "map"  # a CI case's world map is its static layer

    @classmethod
    def build(cls, params: Params, log_topics: set[str]) -> Pipeline:
        return build(params, log_topics)


# ---------------------------------------------------------------- one plan on a map


@dataclass
class MapPlan:
    """One plan on a map: the global costmap it was planned on, and the plan."""

    costmap: Costmap2D
    plan: PlanResult
    start: Pose2D | None = None  # the pose asked for (the plan may end elsewhere, within the tolerance)
    goal: Pose2D | None = None


def plan_on_map(
    map: str | Path | OccupancyMap,
    start: Pose2D,
    goal: Pose2D,
    *,
    nav2_params: str | Path | None = None,
    planner: Literal["navfn", "smac2d"] = "navfn",
    planner_id: str = "",
    potential: Literal["exact", "python"] = "exact",
    overrides: Sequence[str] = (),
) -> MapPlan:
    """Build the global costmap on a map (a map_server YAML or an OccupancyMap) and plan once.

    ``nav2_params``: a Nav2 parameter file (none: Nav2's defaults) with ``overrides`` (``KEY=VALUE``,
    full or short key paths); its global costmap needs a static layer. The costmap is updated once at
    ``start``; ``planner`` / ``planner_id`` pick the planner as the planner pipeline does. Poses are
    (x, y, yaw) in the map's frame. Raises ConfigError for the parameters or the map, PlanningError
    when there is no plan (messages prefixed with the map's path when it was given one).
    """
    nav2 = planning_nav2_params(nav2_params, overrides, planner)
    where = "" if isinstance(map, OccupancyMap) else f"{map}: "
    occ = map if isinstance(map, OccupancyMap) else load_map(map)
    cm = Costmap2D(nav2.global_costmap or default_costmap_params())
    if not cm.static_layers:
        raise ConfigError(f"{nav2_params}: the global costmap has no static layer, so the map cannot be used")
    cm.set_static_map(occ)
    if not cm.params.rolling_window:  # the costmap is the map's: the update at the start needs the start on it
        try:
            costmap_cell(cm, "start", start)
        except PlanningError as exc:
            raise PlanningError(f"{where}{exc}") from None
    cm.update(start[0], start[1], start[2])
    if (occ.data == -1).all():
        raise ConfigError(f"{where}the map is unknown everywhere")
    chosen = make_planner(nav2.planner_server, planner, planner_id, potential)
    try:
        plan = chosen.plan(cm, start, goal)
    except PlanningError as exc:
        raise PlanningError(f"{where}{exc}") from None
    return MapPlan(cm, plan, start, goal)


def write_plan_mcap(path: str | Path, result: MapPlan) -> None:
    """The costmap (/global_costmap/costmap) and the plan (/plan) at time 0 in an MCAP (overwritten)."""
    cm = result.costmap
    with McapLogWriter(path, force=True) as w:
        w.write(Envelope("/global_costmap/costmap", m.OCCUPANCY_GRID, 0, costmap_msg(cm, 0)))
        w.write(Envelope("/plan", m.PATH, 0, path_cdr(result.plan, 0, cm.params.global_frame)))


PLAN_RGB = (220, 30, 30)  # vermillion-red cells of the plan
START_RGB = (0, 158, 115)  # Okabe-Ito bluish green: the start
GOAL_RGB = (0, 114, 178)  # Okabe-Ito blue: the goal
MARK_RADIUS_M = 0.15  # the start and goal discs, at least 2 cells


def write_plan_png(path: str | Path, result: MapPlan) -> None:
    """The costmap in grey (free white, lethal black, unknown blue-grey) with the plan's cells in red, the
    start as a green disc and the goal as a blue one (the poses asked for, else the plan's ends), each with
    a tick along its heading."""
    from PIL import Image

    cm, plan = result.costmap, result.plan
    img = np.stack([255 - (cm.costs.astype(np.int32) * 255 // 255)] * 3, axis=-1).astype(np.uint8)
    img[cm.costs == 255] = (120, 120, 160)
    mx, my = cm.world_to_cell(plan.poses[:, 0], plan.poses[:, 1])
    ok = (mx >= 0) & (mx < cm.size_x) & (my >= 0) & (my < cm.size_y)
    img[my[ok], mx[ok]] = PLAN_RGB
    start = result.start if result.start is not None else tuple(plan.poses[0, :3])
    goal = result.goal if result.goal is not None else tuple(plan.poses[-1, :3])
    radius = max(2.0, MARK_RADIUS_M / cm.resolution)  # cells
    ys, xs = np.mgrid[0 : cm.size_y, 0 : cm.size_x]
    for (x, y, yaw), rgb in ((start, START_RGB), (goal, GOAL_RGB)):
        cx, cy = cm.world_to_cell(np.array([x]), np.array([y]))
        disc = (xs - cx[0]) ** 2 + (ys - cy[0]) ** 2 <= radius**2
        steps = np.arange(0.0, 2.0 * radius + 1.0, 0.5)  # the heading tick, twice the disc's radius long
        tx = np.round(cx[0] + steps * math.cos(yaw)).astype(np.int64)
        ty = np.round(cy[0] + steps * math.sin(yaw)).astype(np.int64)
        inside = (tx >= 0) & (tx < cm.size_x) & (ty >= 0) & (ty < cm.size_y)
        img[disc] = rgb
        img[ty[inside], tx[inside]] = rgb
    png = io.BytesIO()
    Image.fromarray(img[::-1]).save(png, format="PNG")
    write_file(Path(path), png.getvalue())
