"""Nav2's collision monitor (``nav2_collision_monitor``): its parameters, read and checked; not run yet.

The monitor stops, slows or limits the robot's commands (/cmd_vel_smoothed -> /cmd_vel) when
obstacles from its sources enter its polygons; its implementation will sit in this module.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

from navlog.replay.config import suggest
from navlog.replay.nav2.costmap.footprint import parse_footprint
from navlog.replay.nav2.schema import ERROR, WARNING, SectionReader, param


@dataclass(frozen=True)
class CollisionPolygonParams:
    """One polygon (or circle) of the collision monitor and the action it triggers."""

    type: str = param("polygon", choices=("polygon", "circle", "velocity_polygon"))
    points: str = ""
    radius: float = param(0.0, ge=0.0)
    footprint_topic: str = ""
    action_type: str = param("stop", choices=("stop", "slowdown", "limit", "approach", "none"))
    min_points: int = param(4, ge=1)
    slowdown_ratio: float = param(0.5, ge=0.0, le=1.0)
    linear_limit: float = param(0.5, ge=0.0)
    angular_limit: float = param(0.5, ge=0.0)
    time_before_collision: float = param(2.0, gt=0.0)
    simulation_time_step: float = param(0.1, gt=0.0)
    visualize: bool = False
    polygon_pub_topic: str = ""
    polygon_sub_topic: str = ""
    enabled: bool = True
    sources_names: tuple[str, ...] = ()
    READ_ONLY: ClassVar[tuple[str, ...]] = ("visualize", "polygon_pub_topic", "polygon_sub_topic", "max_points")

    def point_list(self) -> list[tuple[float, float]]:
        """The polygon's points ([] when it has none); ValueError when malformed."""
        return parse_footprint(self.points) if self.points else []


@dataclass(frozen=True)
class CollisionSourceParams:
    """One observation source of the collision monitor."""

    type: str = param("scan", choices=("scan", "pointcloud", "range", "polygon", "costmap"))
    topic: str = ""
    min_height: float = 0.05
    max_height: float = 0.5
    enabled: bool = True
    source_timeout: float = param(-1.0)
    transport_type: str = "raw"
    use_global_height: bool = False
    obstacles_angle: float = param(math.pi / 180.0, ge=0.0)
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
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "state_topic",
        "use_realtime_priority",
        "enable_stamped_cmd_vel",
        "use_sim_time",
    )


def read_collision_monitor(r: SectionReader, params: dict, path: tuple) -> CollisionMonitorParams:
    """The node's parameters with each listed polygon and source; sections listed nowhere are warned about."""
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    polygons: dict[str, CollisionPolygonParams] = {}
    sources: dict[str, CollisionSourceParams] = {}
    poly_names = params.get("polygons", [])
    src_names = params.get("observation_sources", [])
    if isinstance(src_names, str):
        src_names = src_names.split()
    for names, cls, store, kind in (
        (poly_names, CollisionPolygonParams, polygons, "polygon"),
        (src_names, CollisionSourceParams, sources, "observation source"),
    ):
        if not isinstance(names, list):
            continue
        for name in names:
            sec = params.get(name)
            if not isinstance(sec, dict):
                r.add(
                    ERROR,
                    path + ("polygons" if kind == "polygon" else "observation_sources",),
                    f"{kind} '{name}' is listed but has no '{name}:' section{suggest(str(name), sections)}",
                )
                continue
            obj = r.read(cls, sec, path + (name,))
            if cls is CollisionPolygonParams:
                if obj.points:
                    try:
                        obj.point_list()
                    except ValueError as exc:
                        r.add(ERROR, path + (name, "points"), str(exc))
                if obj.type == "polygon" and not obj.points and not obj.footprint_topic:
                    r.add(ERROR, path + (name,), "a polygon needs 'points' or 'footprint_topic'")
                if obj.type == "circle" and obj.radius <= 0.0:
                    r.add(ERROR, path + (name, "radius"), "a circle needs a radius > 0")
            store[name] = obj
    listed = set(poly_names if isinstance(poly_names, list) else []) | set(
        src_names if isinstance(src_names, list) else []
    )
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
        extra={
            "polygon_params": polygons,
            "source_params": sources,
            "observation_sources": tuple(src_names) if isinstance(src_names, list) else (),
        },
    )
