"""The collision monitor's parameters (Nav2 Jazzy): the node's, each polygon's and each source's, read and checked.

``read_collision_monitor`` reads the ``collision_monitor`` block with every polygon listed in
``polygons`` and every source listed in ``observation_sources``. Beyond types and ranges it reports
what Nav2 Jazzy refuses or silently ignores:

- a ``points`` string with fewer than 4 vertices (Jazzy's parser refuses ``size <= 3``);
- the deprecated ``max_points: N``, read as ``min_points: N + 1`` (Jazzy acts on ``>= min_points``
  points; Humble, which has only ``max_points``, acts on ``> max_points``: the same threshold); the
  note says which of the two was read;
- ``min_height`` / ``max_height`` on a ``scan`` source (only point clouds have heights);
- a ``costmap`` source (Nav2 Kilted and later only);
- a velocity polygon's sub-polygons (``velocity_polygons``) and their required velocity ranges.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

from navlog.replay.config import suggest
from navlog.replay.limits import MAX_SIM_TIME_S, MAX_SIMULATION_STEPS, budget
from navlog.replay.nav2.costmap.footprint import parse_footprint
from navlog.replay.nav2.schema import ERROR, NOTE, WARNING, SectionReader, param

ACTION_TYPES = ("stop", "slowdown", "limit", "approach", "none")
SOURCE_TYPES = ("scan", "pointcloud", "range", "polygon")
DEFAULT_FOOTPRINT_TOPIC = "local_costmap/published_footprint"
MIN_POLYGON_POINTS = 4  # a `points` string needs this many vertices (Jazzy polygon.cpp: size <= 3 is an error)


def parse_polygon_points(text: str) -> list[tuple[float, float]]:
    """A collision-monitor ``points`` string as vertices; ValueError when malformed or under 4 vertices."""
    try:
        pts = parse_footprint(text)
    except ValueError:
        pts = []
    if len(pts) < MIN_POLYGON_POINTS:
        raise ValueError(
            f"points {text!r}: Nav2's collision monitor needs at least {MIN_POLYGON_POINTS} vertices "
            "[[x, y], [x, y], [x, y], [x, y], ...] (for a triangle, repeat a vertex)"
        )
    return pts


@dataclass(frozen=True)
class VelocitySubPolygonParams:
    """One sub-polygon of a velocity polygon: its shape and the command ranges that select it."""

    points: str = ""
    linear_min: float = 0.0
    linear_max: float = 0.0
    theta_min: float = 0.0
    theta_max: float = 0.0
    direction_start_angle: float = -math.pi
    direction_end_angle: float = math.pi
    REQUIRED: ClassVar[tuple[str, ...]] = ("points", "linear_min", "linear_max", "theta_min", "theta_max")

    def point_list(self) -> list[tuple[float, float]]:
        return parse_polygon_points(self.points)


@dataclass(frozen=True)
class CollisionPolygonParams:
    """One polygon, circle or velocity polygon of the collision monitor and the action it triggers."""

    type: str = param("polygon", choices=("polygon", "circle", "velocity_polygon"))
    points: str = ""
    radius: float = param(0.0, ge=0.0)
    footprint_topic: str = DEFAULT_FOOTPRINT_TOPIC
    action_type: str = param("stop", choices=ACTION_TYPES)
    min_points: int = param(4, ge=1)
    slowdown_ratio: float = param(0.5, ge=0.0, le=1.0)
    linear_limit: float = param(0.5, ge=0.0)
    angular_limit: float = param(0.5, ge=0.0)
    time_before_collision: float = param(2.0, gt=0.0, le=MAX_SIM_TIME_S)
    simulation_time_step: float = param(0.1, gt=0.0)
    visualize: bool = False
    polygon_pub_topic: str = ""
    polygon_sub_topic: str = ""
    enabled: bool = True
    sources_names: tuple[str, ...] = ()
    holonomic: bool = False
    velocity_polygons: tuple[str, ...] = ()
    velocity_polygon_params: dict[str, VelocitySubPolygonParams] = field(default_factory=dict)
    # max_points is read by read_collision_monitor (as min_points + 1); listed so that --set knows it
    READ_ONLY: ClassVar[tuple[str, ...]] = ("polygon_sub_topic", "max_points")

    def __post_init__(self) -> None:
        steps = self.time_before_collision / self.simulation_time_step
        what = f"time_before_collision / simulation_time_step ({self.time_before_collision} s / {self.simulation_time_step} s)"
        budget("simulation_time_step", what, steps, MAX_SIMULATION_STEPS, " steps")

    def point_list(self) -> list[tuple[float, float]]:
        """The polygon's points ([] when it has none); ValueError when malformed or under 4 vertices."""
        return parse_polygon_points(self.points) if self.points else []


@dataclass(frozen=True)
class CollisionSourceParams:
    """One observation source of the collision monitor (heights and min_range: point clouds only)."""

    type: str = param("scan", choices=SOURCE_TYPES)
    topic: str = "scan"
    min_height: float = 0.05
    max_height: float = 0.5
    min_range: float = param(0.0, ge=0.0)
    enabled: bool = True
    source_timeout: float = param(-1.0)  # < 0: the node's source_timeout
    transport_type: str = "raw"
    use_global_height: bool = False
    obstacles_angle: float = param(math.pi / 180.0, gt=0.0)
    sampling_distance: float = param(0.1, gt=0.0)
    READ_ONLY: ClassVar[tuple[str, ...]] = ("transport_type", "use_global_height")


@dataclass(frozen=True)
class CollisionMonitorParams:
    """``collision_monitor`` node parameters with its polygons' and sources'."""

    base_frame_id: str = "base_footprint"
    odom_frame_id: str = "odom"
    cmd_vel_in_topic: str = "cmd_vel_smoothed"
    cmd_vel_out_topic: str = "cmd_vel"
    state_topic: str = ""
    transform_tolerance: float = param(0.1, ge=0.0)
    source_timeout: float = param(2.0, ge=0.0)
    base_shift_correction: bool = True
    stop_pub_timeout: float = param(1.0, ge=0.0)
    polygons: tuple[str, ...] = ()
    observation_sources: tuple[str, ...] = ()
    use_realtime_priority: bool = False
    enable_stamped_cmd_vel: bool = False
    use_sim_time: bool = False
    polygon_params: dict[str, CollisionPolygonParams] = field(default_factory=dict)
    source_params: dict[str, CollisionSourceParams] = field(default_factory=dict)
    # the state goes out as navlog events (navlog_msgs/Event), not on state_topic
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "state_topic",
        "use_realtime_priority",
        "use_sim_time",
        "enabled",  # Nav2 after Jazzy: the monitor switched off at start (navlog's pipelines switch it by --set)
    )

    def source_timeout_of(self, source: str) -> float:
        """A source's own source_timeout, or the node's (seconds; 0 disables the staleness check)."""
        own = self.source_params[source].source_timeout
        return own if own >= 0.0 else self.source_timeout


def _names(value: object) -> list[str]:
    if isinstance(value, str):
        return value.split()
    return [str(v) for v in value] if isinstance(value, list) else []


def _check_points(r: SectionReader, text: str, path: tuple) -> None:
    try:
        parse_polygon_points(text)
    except ValueError as exc:
        r.add(ERROR, path, str(exc))


def _min_points_from_max(r: SectionReader, sec: dict, path: tuple) -> int | None:
    """The min_points a deprecated max_points sets (None without one), saying which threshold was read."""
    if "max_points" not in sec:
        return None
    value = sec["max_points"]
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        r.add(ERROR, path + ("max_points",), f"expected an integer >= 0, got {value!r} (ignored)")
        return None
    also = f"; it overrides min_points {sec['min_points']}" if "min_points" in sec else ""
    if r.distro == "humble":  # Humble's own parameter (it has no min_points)
        r.add(NOTE, path + ("max_points",), f"max_points {value} (Humble): acts on more than {value} points")
    else:
        r.add(
            WARNING if also else NOTE,
            path + ("max_points",),
            f"deprecated max_points {value} read as min_points {value + 1}: acts on >= {value + 1} points "
            f"(Humble's 'more than {value}'){also}",
        )
    return value + 1


def _read_sub_polygons(
    r: SectionReader, sec: dict, path: tuple, names: list[str]
) -> dict[str, VelocitySubPolygonParams]:
    subs: dict[str, VelocitySubPolygonParams] = {}
    if not names:
        r.add(ERROR, path, "a velocity_polygon needs 'velocity_polygons': the names of its sub-polygons")
    for name in names:
        sub = sec.get(name)
        if not isinstance(sub, dict):
            others = [k for k, v in sec.items() if isinstance(v, dict)]
            r.add(
                ERROR,
                path + ("velocity_polygons",),
                f"sub-polygon '{name}' is listed but has no '{name}:' section{suggest(name, others)}",
            )
            continue
        missing = [k for k in VelocitySubPolygonParams.REQUIRED if k not in sub]
        if missing:
            r.add(ERROR, path + (name,), f"missing {', '.join(missing)}: Nav2 refuses a sub-polygon without them")
        obj = r.read(VelocitySubPolygonParams, sub, path + (name,))
        if obj.points:
            _check_points(r, obj.points, path + (name, "points"))
        subs[name] = obj
    return subs


def _read_polygon(r: SectionReader, sec: dict, path: tuple, sources: list[str]) -> CollisionPolygonParams:
    sub_names = _names(sec.get("velocity_polygons")) if sec.get("type") == "velocity_polygon" else []
    extra: dict = {}
    min_points = _min_points_from_max(r, sec, path)
    if min_points is not None:
        extra["min_points"] = min_points
    if sub_names:
        extra["velocity_polygon_params"] = _read_sub_polygons(r, sec, path, sub_names)
    elif sec.get("type") == "velocity_polygon":
        _read_sub_polygons(r, sec, path, [])
    obj = r.read(CollisionPolygonParams, sec, path, sections=tuple(sub_names), extra=extra, skip=("max_points",))
    if obj.points:
        _check_points(r, obj.points, path + ("points",))
    if obj.type == "polygon" and not obj.points and obj.action_type != "approach" and not obj.polygon_sub_topic:
        r.add(ERROR, path, "a polygon needs 'points' (or 'polygon_sub_topic'; 'footprint_topic' is for approach)")
    if obj.type == "circle" and obj.radius <= 0.0 and not obj.polygon_sub_topic:
        r.add(ERROR, path + ("radius",), "a circle needs a radius > 0")
    for s in obj.sources_names:
        if s not in sources:
            r.add(ERROR, path + ("sources_names",), f"unknown source '{s}'{suggest(s, sources)}: Nav2 fails to start")
    return obj


def _read_source(r: SectionReader, sec: dict, path: tuple) -> CollisionSourceParams:
    if sec.get("type") == "costmap":
        r.add(ERROR, path + ("type",), "source type 'costmap' exists in Nav2 Kilted and later, not in Jazzy")
        sec = {k: v for k, v in sec.items() if k != "type"}
    obj = r.read(CollisionSourceParams, sec, path)
    if obj.type != "pointcloud":
        for key in ("min_height", "max_height", "min_range"):
            if key in sec:
                r.add(WARNING, path + (key,), f"a {obj.type} source has no {key}: Nav2 never reads it")
    return obj


def read_collision_monitor(r: SectionReader, params: dict, path: tuple) -> CollisionMonitorParams:
    """The node's parameters with each listed polygon and source; sections listed nowhere are warned about."""
    if params.get("enabled", True) is False:
        r.add(
            WARNING,
            path + ("enabled",),
            "enabled: false starts Nav2's collision monitor switched off (commands pass through); navlog runs it "
            "regardless: leave it out with --set collision_monitor=off",
        )
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    polygons: dict[str, CollisionPolygonParams] = {}
    sources: dict[str, CollisionSourceParams] = {}
    poly_names = params.get("polygons", [])
    src_names = _names(params.get("observation_sources", []))
    for names, key, kind in (
        (src_names, "observation_sources", "observation source"),
        (poly_names, "polygons", "polygon"),
    ):
        if not isinstance(names, list):
            continue
        for name in names:
            sec = params.get(name) if isinstance(name, str) else None
            if not isinstance(sec, dict):
                r.add(
                    ERROR,
                    path + (key,),
                    f"{kind} '{name}' is listed but has no '{name}:' section{suggest(str(name), sections)}",
                )
                continue
            if kind == "polygon":
                polygons[name] = _read_polygon(r, sec, path + (name,), src_names)
            else:
                sources[name] = _read_source(r, sec, path + (name,))
    listed = {n for names in (poly_names, src_names) if isinstance(names, list) for n in names if isinstance(n, str)}
    for s in sections:
        if s not in listed:
            r.add(
                WARNING,
                path + (s,),
                f"section '{s}' is in neither polygons nor observation_sources: ignored{suggest(s, sorted(listed))}",
            )
    return r.read(
        CollisionMonitorParams,
        params,
        path,
        sections=sections,
        extra={"polygon_params": polygons, "source_params": sources, "observation_sources": tuple(src_names)},
    )
