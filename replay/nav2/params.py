"""Nav2 parameter files as ROS 2 users write them, read into typed, validated configuration.

A file holds ``node: ros__parameters: {...}`` blocks (costmaps one level deeper:
``global_costmap: global_costmap: ros__parameters:``), with plugin sections named by lists such as
``plugins``, ``planner_plugins``, ``controller_plugins``, ``observation_sources`` or ``polygons``.

``load_nav2_params(path)`` never stops at the first problem: it reads everything it can into frozen
dataclasses (defaults as in Nav2 for whatever is missing or wrong) and collects every ``Problem``
with its YAML path and line: misspelled keys with a did-you-mean, unknown plugins, wrong types,
out-of-range values, parameters Nav2 renamed, and -- as notes -- what navlog reads but does not
implement. ``Nav2Params.require_valid()`` turns the errors into one ``ConfigError`` for code that
needs a working configuration; ``navlog check-config`` prints them all.

This module reads the file and hands each node's block to that node's reader, which sits beside the
node's parameters; each plugin section is read by its registered plugin's parameter class:

- global_costmap / local_costmap: ``costmap.costmap_2d.read_costmap`` (layers: ``costmap.registry``;
  static, obstacle, voxel as 2-D obstacle, inflation);
- planner_server: ``planners.server.read_planner_server`` (NavFn, Smac 2D: ``planners.registry``);
- controller_server: ``controllers.server.read_controller_server`` (Regulated Pure Pursuit, MPPI main
  parameters, goal and progress checkers: ``controllers.registry``);
- velocity_smoother: ``velocity_smoother.read_velocity_smoother``;
- collision_monitor: ``collision_monitor.read_collision_monitor``;
- a node beside Nav2's that a caller implements (the mapping pipeline's ``slam_toolbox``): the reader the
  caller gives (``parse_nav2_params``'s ``readers``), with its result in ``Nav2Params.others``;
- amcl: ``amcl.read_amcl``;
- bt_navigator, waypoint_follower: ``navigator.read_bt_navigator``, ``navigator.read_waypoint_follower``
  (navlog runs the default trees' behaviour, not tree XML: bt_navigator is also listed as not implemented);
- behavior_server: ``behaviors.read_behavior_server``.

Read and listed as not implemented: map_server, smoother_server, recoveries_server, route_server,
docking_server and the rest in ``READ_ONLY_NODES``.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml

from navlog.errors import ConfigError
from navlog.replay.config import bounded_compose, parse_yaml, read_yaml_text, suggest
from navlog.replay.nav2.amcl import AmclParams, read_amcl
from navlog.replay.nav2.behaviors import BehaviorServerParams, read_behavior_server
from navlog.replay.nav2.collision_monitor import CollisionMonitorParams, read_collision_monitor
from navlog.replay.nav2.controllers.server import ControllerServerParams, read_controller_server
from navlog.replay.nav2.costmap.costmap_2d import read_costmap
from navlog.replay.nav2.costmap.grid import CostmapParams
from navlog.replay.nav2.navigator import (
    BtNavigatorParams,
    WaypointFollowerParams,
    read_bt_navigator,
    read_waypoint_follower,
)
from navlog.replay.nav2.overrides import apply_nav2_overrides
from navlog.replay.nav2.planners.server import PlannerServerParams, read_planner_server
from navlog.replay.nav2.schema import DISTROS, ERROR, NOTE, WARNING, Problem, SectionReader
from navlog.replay.nav2.velocity_smoother import VelocitySmootherParams, read_velocity_smoother

IMPLEMENTED_NODES = (
    "global_costmap",
    "local_costmap",
    "planner_server",
    "controller_server",
    "velocity_smoother",
    "collision_monitor",
    "amcl",
    "bt_navigator",
    "behavior_server",
    "waypoint_follower",
)
READ_ONLY_NODES = (
    "map_server",
    "map_saver",
    "smoother_server",
    "recoveries_server",
    "route_server",
    "docking_server",
    "loopback_simulator",
    "robot_state_publisher",
    "lifecycle_manager",
    "lifecycle_manager_navigation",
    "lifecycle_manager_localization",
    "slam_toolbox",
    "collision_detector",
    "opennav_docking",
    "amcl_map_client",
    "amcl_rclcpp_node",
    "bt_navigator_rclcpp_node",
    "controller_server_rclcpp_node",
    "planner_server_rclcpp_node",
    "bt_navigator_navigate_to_pose_rclcpp_node",
    "bt_navigator_navigate_through_poses_rclcpp_node",
    "local_costmap_client",
    "local_costmap_rclcpp_node",
    "global_costmap_client",
    "global_costmap_rclcpp_node",
    "route_server_rclcpp_node",
    "/**",
)

# a reader of one node's ros__parameters: (reader, the mapping, its key path) -> what it makes of them
NodeReader = Callable[[SectionReader, dict, tuple], Any]
# node -> the reader of its ros__parameters (the costmaps, one level deeper, are read apart)
NODE_READERS: dict[str, NodeReader] = {
    "planner_server": read_planner_server,
    "controller_server": read_controller_server,
    "velocity_smoother": read_velocity_smoother,
    "collision_monitor": read_collision_monitor,
    "amcl": read_amcl,
    "bt_navigator": read_bt_navigator,
    "behavior_server": read_behavior_server,
    "waypoint_follower": read_waypoint_follower,
}
# the sections navlog's pipelines need, by the section that needs them: the planner plans on the global
# costmap; the controller follows on the local costmap; a navigation stack (bt_navigator or a
# controller) runs planner and controller, each on its costmap. Nav2's defaults for a missing one are
# never what the file's author meant (a default costmap has no layers of the robot's sensors).
REQUIRED_SECTIONS: dict[str, tuple[str, ...]] = {
    "planner_server": ("global_costmap",),
    "controller_server": ("local_costmap", "planner_server", "global_costmap"),
    "bt_navigator": ("planner_server", "global_costmap", "controller_server", "local_costmap"),
}
# keys of a map_server map file (NAME.yaml beside NAME.pgm), which is not a parameter file
MAP_FILE_KEYS = ("image", "resolution", "origin", "occupied_thresh", "free_thresh", "negate", "mode")
# read, and run as navlog's fixed navigator: the behaviour-tree XML itself is not run (listed in not_implemented)
PARTIAL_NODES = ("bt_navigator",)


def _line_map(text: str) -> dict[tuple, int]:
    """YAML key path -> 1-based line of the key."""
    lines: dict[tuple, int] = {}
    try:
        root = bounded_compose(text)
    except yaml.YAMLError:
        return lines

    def walk(node, path):
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                p = path + (k.value,)
                lines.setdefault(p, k.start_mark.line + 1)
                walk(v, p)

    walk(root, ())
    return lines


@dataclass(frozen=True)
class Nav2Params:
    """Everything read from one Nav2 parameter file."""

    source: str
    raw: dict
    global_costmap: CostmapParams | None = None
    local_costmap: CostmapParams | None = None
    planner_server: PlannerServerParams | None = None
    controller_server: ControllerServerParams | None = None
    velocity_smoother: VelocitySmootherParams | None = None
    collision_monitor: CollisionMonitorParams | None = None
    amcl: AmclParams | None = None
    bt_navigator: BtNavigatorParams | None = None
    behavior_server: BehaviorServerParams | None = None
    waypoint_follower: WaypointFollowerParams | None = None
    not_implemented: tuple[str, ...] = ()  # node blocks read but not implemented
    # node -> what the caller's reader of that node made of its block (``parse_nav2_params``'s ``readers``)
    others: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    # the nodes of the file a caller's reader was given, whether or not their block could be read
    foreign: tuple[str, ...] = ()
    problems: tuple[Problem, ...] = ()

    @property
    def errors(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == ERROR]

    @property
    def warnings(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == WARNING]

    def _tools(self, problems: Sequence[Problem]) -> list[str]:
        """Whose parameters the problems are in, each named once: Nav2's, or a node given to a caller's reader."""
        nodes = (p.path.split(".", 1)[0] for p in problems)
        return list(dict.fromkeys(node if node in self.foreign else "Nav2" for node in nodes))

    def require_valid(self, prefixes: Sequence[str] = ()) -> Nav2Params:
        """Raise one ConfigError listing every error (under ``prefixes`` if given)."""
        errors = [p for p in self.errors if not prefixes or any(p.path.startswith(x) for x in prefixes)]
        if errors:
            lines = "\n  ".join(p.format(self.source) for p in errors)
            raise ConfigError(
                f"{self.source}: {len(errors)} error(s) in the {' and '.join(self._tools(errors))} "
                "parameters "
                f"(run `navlog check-config {self.source}`):\n  {lines}"
            )
        return self


def load_nav2_params(
    path: str | Path,
    overrides: Sequence[str] = (),
    *,
    distro: str = "jazzy",
    readers: Mapping[str, NodeReader] | None = None,
) -> Nav2Params:
    """Read a Nav2 parameter file (YAML syntax errors raise ConfigError with the line), checked as a
    file for Nav2 ``distro`` (``DISTROS``); ``readers`` as for ``parse_nav2_params``."""
    path = Path(path)
    parsed, lines = _parsed(read_yaml_text(path), str(path))
    doc, lines = copy.deepcopy(parsed), dict(lines)  # the kept parse is never handed out
    _refuse_other_files(doc, str(path))
    missing = _missing_sections(doc, lines)  # of the file as written, before any override
    if overrides:
        doc = apply_nav2_overrides(doc if isinstance(doc, dict) else {}, overrides, source=str(path))
    params = parse_nav2_params(doc, source=str(path), lines=lines, distro=distro, readers=readers)
    return dataclasses.replace(params, problems=params.problems + missing) if missing else params


@lru_cache(maxsize=8)
def _parsed(text: str, source: str) -> tuple[Any, dict[tuple, int]]:
    """The document of a parameter file's text and its lines (``_line_map``), kept for the next reading
    of the same text: a navigation run reads one file for its servers, its AMCL and its safety filters."""
    return parse_yaml(text, source), _line_map(text)


def _has_ros_parameters(node: Any) -> bool:
    return isinstance(node, dict) and any(k == "ros__parameters" or _has_ros_parameters(v) for k, v in node.items())


def _refuse_other_files(doc: Any, source: str) -> None:
    """A ConfigError for a YAML file that is not a Nav2 parameter file: no ``ros__parameters`` anywhere
    and no Nav2 node at its top (a map_server map file is named as one)."""
    if not isinstance(doc, dict) or not doc or _has_ros_parameters(doc):
        return
    keys = [str(k) for k in doc]
    if any(k in IMPLEMENTED_NODES or k in READ_ONLY_NODES for k in keys):
        return  # a Nav2 file with its ros__parameters missing: reported key by key
    map_keys = [k for k in keys if k in MAP_FILE_KEYS]
    if len(map_keys) >= 2:
        raise ConfigError(
            f"{source}: not a Nav2 parameter file: it is a map_server map file ({', '.join(map_keys)}); "
            "pass a Nav2 parameter file (node: ros__parameters: ...), and the map where a map is expected"
        )
    raise ConfigError(
        f"{source}: not a Nav2 parameter file: no 'ros__parameters' anywhere and no Nav2 node at its top "
        f"(keys: {', '.join(keys[:5])}{', ...' if len(keys) > 5 else ''}); expected node: ros__parameters: ..."
    )


def _missing_sections(doc: Any, lines: dict) -> tuple[Problem, ...]:
    """An error for each section the file's servers need but it lacks (``REQUIRED_SECTIONS``)."""
    if not isinstance(doc, dict):
        return ()
    r = SectionReader(lines)
    reported: set[str] = set()
    for node, needs in REQUIRED_SECTIONS.items():
        for need in needs:
            if node in doc and need not in doc and need not in reported:
                reported.add(need)
                r.add(
                    ERROR,
                    (need,),
                    f"missing section '{need}': '{node}' needs it and Nav2's defaults would be used in its "
                    f"place; add the '{need}' section",
                )
    return tuple(r.problems)


def default_nav2_params(overrides: Sequence[str] = ()) -> Nav2Params:
    """Nav2's defaults (no file) with ``overrides`` applied; its source reads ``<defaults>``."""
    return parse_nav2_params(apply_nav2_overrides({}, overrides) if overrides else {}, source="<defaults>")


def parse_nav2_text(text: str, source: str = "<string>") -> Nav2Params:
    """Read a Nav2 parameter file's text (YAML syntax errors raise ConfigError with the line)."""
    doc = parse_yaml(text, source)
    return parse_nav2_params(doc, source=source, lines=_line_map(text))


def _ros_params(r: SectionReader, node_block: Any, path: tuple) -> dict | None:
    """The ``ros__parameters`` mapping of a node block, or None (reported) when there is none."""
    if not isinstance(node_block, dict):
        r.add(ERROR, path, f"expected a mapping with 'ros__parameters', got {node_block!r}")
        return None
    if "ros__parameters" not in node_block:
        others = [k for k in node_block if isinstance(k, str)]
        close = [k for k in others if suggest(k, ["ros__parameters"])]
        if close:
            r.add(
                ERROR,
                path + (close[0],),
                f"'{close[0]}' should be 'ros__parameters' (two underscores): ROS 2 ignores the whole block",
            )
        else:
            r.add(ERROR, path, "no 'ros__parameters' mapping: ROS 2 would not read these parameters")
        return None
    params = node_block["ros__parameters"]
    if params is None:
        return {}
    if not isinstance(params, dict):
        r.add(ERROR, path + ("ros__parameters",), f"expected a mapping, got {params!r}")
        return None
    return params


def parse_nav2_params(
    doc: Any,
    source: str = "<string>",
    lines: dict | None = None,
    *,
    distro: str = "jazzy",
    readers: Mapping[str, NodeReader] | None = None,
) -> Nav2Params:
    """Read a parsed Nav2 parameter document (``lines``: YAML key path -> line, for the problems), as a
    file for Nav2 ``distro``.

    ``readers`` reads the ``ros__parameters`` of nodes beside Nav2's that a caller implements (the mapping
    pipeline's ``slam_toolbox``), with the same reader and reports; what each returns is in ``others``.
    """
    if distro not in DISTROS:
        raise ConfigError(f"Nav2 distro {distro!r}: choose one of {', '.join(DISTROS)}{suggest(distro, DISTROS)}")
    r = SectionReader(lines or {})
    r.distro = distro
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise ConfigError(f"{source}: a Nav2 parameter file is a mapping of node names, got {type(doc).__name__}")
    out: dict[str, Any] = {}
    others: dict[str, Any] = {}
    foreign: list[str] = []
    read_only: list[str] = []
    for node, block in doc.items():
        node = str(node)
        path = (node,)
        if readers and node in readers:
            foreign.append(node)
            params = _ros_params(r, block, path)
            if params is not None:
                r.tool = node
                others[node] = readers[node](r, params, path + ("ros__parameters",))
                r.tool = SectionReader.tool
        elif node in ("global_costmap", "local_costmap"):
            if isinstance(block, dict) and "ros__parameters" in block:
                params = _ros_params(r, block, path)
                cpath: tuple[str, ...] = path + ("ros__parameters",)
            else:
                inner = block.get(node) if isinstance(block, dict) else None
                if isinstance(block, dict):
                    for other in block:
                        if (
                            other != node
                            and other not in READ_ONLY_NODES
                            and not str(other).endswith(("_client", "_rclcpp_node"))
                        ):
                            r.unknown_key(str(other), path + (other,), [node], is_section=True)
                if inner is None:
                    r.add(
                        ERROR,
                        path,
                        f"expected '{node}: {node}: ros__parameters:' (the costmap node lives in the "
                        f"'{node}' namespace)",
                    )
                    continue
                params = _ros_params(r, inner, path + (node,))
                cpath = path + (node, "ros__parameters")
            if params is not None:
                out[node] = read_costmap(r, params, cpath)
        elif node in NODE_READERS:
            params = _ros_params(r, block, path)
            if params is not None:
                out[node] = NODE_READERS[node](r, params, path + ("ros__parameters",))
            if node in PARTIAL_NODES:
                read_only.append(node)
        elif node in READ_ONLY_NODES or node.endswith(("_rclcpp_node", "_client")):
            read_only.append(node)
            r.add(NOTE, path, "read, not implemented by navlog (parameters not checked)")
        else:
            hint = suggest(node, IMPLEMENTED_NODES + READ_ONLY_NODES)
            if hint:
                r.add(ERROR, path, f"unknown node '{node}'{hint}; Nav2 would never read this block")
            else:
                read_only.append(node)
                r.add(WARNING, path, f"node '{node}' is not a Nav2 node navlog knows (parameters not checked)")
    return Nav2Params(
        source=source,
        raw=doc,
        not_implemented=tuple(read_only),
        problems=tuple(r.problems),
        others=others,
        foreign=tuple(foreign),
        **out,
    )
