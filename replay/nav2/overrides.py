"""Overrides of a Nav2 parameter document: ``--set KEY=VALUE`` with the key as a full or a short path.

``global_costmap.inflation_layer.inflation_radius`` finds
``global_costmap.global_costmap.ros__parameters.inflation_layer.inflation_radius``: a short key's
parts appear in order in the full path, its last part being the parameter. A key naming no
parameter, or more than one, is an error with a did-you-mean. A parameter the file does not have
may be added to an existing section if navlog knows its name.

A pipeline that runs Nav2 nodes takes these overrides through its own parameters (``--set
controller_server.FollowPath.desired_linear_vel=0.4`` fills the mapping ``controller_server`` of its
``Params``, ``--set nav2.FollowPath.desired_linear_vel=0.4`` the mapping ``nav2``); ``nav2_override_items``
turns such mappings back into ``KEY=VALUE`` items for ``apply_nav2_overrides``.
"""

from __future__ import annotations

import copy
import dataclasses
import json
from collections.abc import Mapping, Sequence
from typing import Any

from navlog.errors import ConfigError
from navlog.replay.config import parse_yaml, suggest
from navlog.replay.nav2.collision_monitor import CollisionMonitorParams, CollisionPolygonParams, CollisionSourceParams
from navlog.replay.nav2.controllers.checkers import GoalCheckerParams, ProgressCheckerParams
from navlog.replay.nav2.controllers.mppi import MPPIParams
from navlog.replay.nav2.controllers.regulated_pure_pursuit import RegulatedPurePursuitParams
from navlog.replay.nav2.controllers.server import ControllerServerParams
from navlog.replay.nav2.costmap.grid import CostmapParams
from navlog.replay.nav2.costmap.inflation_layer import InflationLayerParams
from navlog.replay.nav2.costmap.observation import ObservationSourceParams
from navlog.replay.nav2.costmap.obstacle_layer import ObstacleLayerParams
from navlog.replay.nav2.costmap.static_layer import StaticLayerParams
from navlog.replay.nav2.planners.navfn import NavfnParams
from navlog.replay.nav2.planners.server import PlannerServerParams
from navlog.replay.nav2.planners.smac2d import Smac2DParams
from navlog.replay.nav2.velocity_smoother import VelocitySmootherParams


def _leaf_paths(doc: Any, prefix: tuple = ()) -> list[tuple]:
    out = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            p = prefix + (str(k),)
            out.append(p)
            out.extend(_leaf_paths(v, p))
    return out


def _is_subsequence(short: list[str], full: tuple) -> bool:
    it = iter(full)
    return all(any(part == f for f in it) for part in short)


def resolve_key(doc: dict, key: str) -> tuple:
    """The full key path for ``key``: a full Nav2 path, or a shorter unambiguous form.

    ``global_costmap.inflation_layer.inflation_radius`` finds
    ``global_costmap.global_costmap.ros__parameters.inflation_layer.inflation_radius``; the short form's
    parts must appear in order in the full path, the last part being the parameter itself.
    """
    parts = key.split(".")
    paths = _leaf_paths(doc)
    if tuple(parts) in paths:
        return tuple(parts)
    candidates = [p for p in paths if p[-1] == parts[-1] and _is_subsequence(parts, p) and p[0] == parts[0]]
    if not candidates:
        candidates = [p for p in paths if p[-1] == parts[-1] and _is_subsequence(parts, p)]
    if len(candidates) == 1:
        return candidates[0]
    if len(candidates) > 1:
        shown = ", ".join(".".join(c) for c in candidates[:6])
        raise ConfigError(
            f"--set {key}: ambiguous, it matches {len(candidates)} parameters: {shown}; give more of the path"
        )
    # a new parameter in an existing section
    sections = [p for p in paths if _is_subsequence(parts[:-1], p) and p[-1] == parts[-2]] if len(parts) > 1 else []
    sections = [s for s in sections if isinstance(_get(doc, s), dict)]
    if len(sections) == 1 and parts[-1] in _known_names():
        return sections[0] + (parts[-1],)
    names = sorted({p[-1] for p in paths} | _known_names())
    raise ConfigError(
        f"--set {key}: no such parameter{suggest(parts[-1], names)}"
        + (f"; sections matching: {', '.join('.'.join(s) for s in sections[:6])}" if sections else "")
    )


def _known_names() -> set[str]:
    """Every parameter name navlog knows (to accept --set of a parameter the file does not have)."""
    names: set[str] = set()
    for cls in (
        StaticLayerParams,
        ObservationSourceParams,
        ObstacleLayerParams,
        InflationLayerParams,
        CostmapParams,
        NavfnParams,
        Smac2DParams,
        PlannerServerParams,
        GoalCheckerParams,
        ProgressCheckerParams,
        RegulatedPurePursuitParams,
        MPPIParams,
        ControllerServerParams,
        VelocitySmootherParams,
        CollisionPolygonParams,
        CollisionSourceParams,
        CollisionMonitorParams,
    ):
        names |= {f.name for f in dataclasses.fields(cls)} | set(getattr(cls, "READ_ONLY", ()))
    return names


def _get(doc: dict, path: tuple) -> Any:
    node: Any = doc
    for p in path:
        node = node[p]
    return node


def apply_nav2_overrides(doc: dict, overrides: Sequence[str], source: str = "") -> dict:
    """A copy of ``doc`` with each ``KEY=VALUE`` applied (KEY full or short, VALUE parsed as YAML)."""
    out = copy.deepcopy(doc)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(
                f"--set '{item}': expected KEY=VALUE, e.g. global_costmap.inflation_layer.inflation_radius=0.5"
            )
        key, raw = item.split("=", 1)
        try:
            value = parse_yaml(raw, f"--set '{item}'")
        except ConfigError as exc:
            raise ConfigError(f"--set '{item}': the value is not valid YAML ({exc})") from None
        path = resolve_key(out, key.strip())
        node = out
        for p in path[:-1]:
            node = node[p]
        node[path[-1]] = value
    return out


def _items(prefix: str, tree: Any) -> list[str]:
    if isinstance(tree, Mapping):
        return [item for k, v in tree.items() for item in _items(f"{prefix}.{k}" if prefix else str(k), v)]
    return [f"{prefix}={json.dumps(tree)}"]


def nav2_override_items(blocks: Mapping[str, Any]) -> list[str]:
    """``KEY=VALUE`` items from override mappings as a pipeline's parameters hold them: ``{"controller_server":
    {"FollowPath": {"desired_linear_vel": 0.4}}}`` gives ``controller_server.FollowPath.desired_linear_vel=0.4``.
    The mapping named ``nav2`` holds keys from the top of the Nav2 file (full or short), given without it."""
    out: list[str] = []
    for name, tree in blocks.items():
        out += _items("" if name == "nav2" else name, tree)
    return out


# the parameters through which a Nav2 node reads odometry, and those that name the odometry frame
ODOM_TOPIC_KEYS = frozenset({"odom_topic"})
FRAME_KEYS = frozenset({"global_frame", "local_frame", "odom_frame_id", "odom_frame", "fixed_frame"})
DEFAULT_ODOM_TOPIC, DEFAULT_ODOM_FRAME = "/odom", "odom"


def odometry_overrides(doc: Any, topic: str, frame: str) -> dict[str, str]:
    """The full-path keys and values that point a Nav2 document at a robot's odometry: every
    ``odom_topic`` becomes ``topic`` (unless it is ``/odom``), and every frame parameter naming the
    default odometry frame ``odom`` (the local costmap's ``global_frame``, AMCL's and the collision
    monitor's ``odom_frame_id``, the behaviours' ``local_frame``) becomes ``frame`` (unless it is ``odom``).
    Parameters the document does not hold keep navlog's default: with ``frame`` not ``odom``, AMCL's
    ``odom_frame_id`` is added to an ``amcl`` block that lacks it."""
    out: dict[str, str] = {}
    for path in _leaf_paths(doc):
        value = _get(doc, path)
        if isinstance(value, (dict, list)):
            continue
        key = ".".join(path)
        if path[-1] in ODOM_TOPIC_KEYS and topic != DEFAULT_ODOM_TOPIC and "/" + str(value).lstrip("/") != topic:
            out[key] = topic
        elif path[-1] in FRAME_KEYS and value == DEFAULT_ODOM_FRAME and frame != DEFAULT_ODOM_FRAME:
            out[key] = frame
    amcl = doc.get("amcl", {}).get("ros__parameters") if isinstance(doc, dict) else None
    if isinstance(amcl, dict) and "odom_frame_id" not in amcl and frame != DEFAULT_ODOM_FRAME:
        out["amcl.ros__parameters.odom_frame_id"] = frame
    return out
