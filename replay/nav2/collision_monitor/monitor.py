"""One collision-monitor decision per incoming command (Nav2 Jazzy ``CollisionMonitor::process``).

``CollisionMonitor(params, footprint=...)`` holds the shapes in ``polygons`` order. ``process(cmd,
now_ns, points)`` takes the command and each source's base-frame points (``None`` for a source
whose data could not be used: none yet, older than its ``source_timeout``, or no transform) and:

1. starts from "no action" with the command as it came;
2. goes through the enabled sources in ``observation_sources`` order: the first unusable one with
   ``source_timeout != 0`` sets STOP with the polygon name "invalid source";
3. goes through the enabled polygons in ``polygons`` order, stopping at the first STOP; each
   refreshes its shape for the command (velocity polygons), then
   - stop, slowdown, limit act when ``min_points`` or more of their sources' points are inside:
     stop zeroes the command; slowdown scales it by ``slowdown_ratio``; limit scales it by
     ``min(1, linear_limit / |v|, angular_limit / |wz|)`` (curvature kept);
   - approach predicts the time to collision ``t`` (``Shape.collision_time``) and, when ``t >= 0``,
     scales the command by ``t / time_before_collision``;
   a slowdown, limit or approach replaces the action so far only when its velocity is smaller by
   ``vx^2 + vy^2 + wz^2``; each scales the incoming command, never the previous result;
4. reports a change when the polygon name differs from the previous decision's;
5. publishes a zero command until ``stop_pub_timeout`` has passed since the output first became
   zero, then nothing until a non-zero command.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import NamedTuple

import numpy as np

from navlog.replay.nav2.collision_monitor.params import CollisionMonitorParams
from navlog.replay.nav2.collision_monitor.polygons import ZERO, Polygon, Shape, Velocity, make_shape

NONE, STOP, SLOWDOWN, LIMIT, APPROACH = "none", "stop", "slowdown", "limit", "approach"
# Nav2's CollisionMonitorState action codes
ACTION_CODES = {NONE: 0, STOP: 1, SLOWDOWN: 2, APPROACH: 3, LIMIT: 4}
INVALID_SOURCE = "invalid source"


class Action(NamedTuple):
    """What the monitor does to a command: the action, the velocity it lets through, the polygon that chose it
    (immutable; a named tuple, made for every command at a tuple's cost)."""

    action_type: str
    velocity: Velocity
    polygon: str = ""


class Decision(NamedTuple):
    """One command's outcome: the action, whether a command is published, and what led to it (immutable)."""

    action: Action
    previous: Action
    publish: bool  # False once stop_pub_timeout has passed with a zero output
    collision_times: Mapping[str, float] = MappingProxyType({})  # approach polygon -> t (s), -1 none
    invalid_source: str = ""  # the source that caused an "invalid source" stop
    counts: Mapping[str, int] = MappingProxyType({})  # polygon -> points inside (stop/slowdown/limit)

    @property
    def changed(self) -> bool:
        """The polygon in charge changed (Nav2 reports the state then)."""
        return self.action.polygon != self.previous.polygon


def limit_ratio(cmd: Velocity, linear_limit: float, angular_limit: float) -> float:
    """The scale that brings ``|(vx, vy)|`` under ``linear_limit`` and ``|wz|`` under ``angular_limit``."""
    ratio = 1.0
    linear = float(np.hypot(cmd.vx, cmd.vy))
    if linear != 0.0:
        ratio = min(max(linear_limit / linear, 0.0), 1.0)
    if cmd.wz != 0.0:
        ratio = min(ratio, min(max(angular_limit / abs(cmd.wz), 0.0), 1.0))
    return ratio


class CollisionMonitor:
    """Nav2's collision monitor as a function of commands and points (see the module docstring)."""

    def __init__(self, params: CollisionMonitorParams, footprint: Sequence[tuple[float, float]] | None = None) -> None:
        self.params = params
        self.shapes: list[Shape] = [
            make_shape(name, params.polygon_params[name], params.observation_sources, footprint)
            for name in params.polygons
            if name in params.polygon_params
        ]
        self.previous = Action(NONE, Velocity(-1.0, -1.0, -1.0))  # Nav2's initial "previous" action
        self.stop_stamp_ns = 0
        # the enabled sources in order, each with whether its loss stops the robot (source_timeout != 0)
        self._sources = [
            (name, params.source_timeout_of(name) != 0.0)
            for name in params.observation_sources
            if name in params.source_params and params.source_params[name].enabled
        ]
        self._stop_pub_timeout_ns = round(params.stop_pub_timeout * 1e9)

    def footprint_shapes(self) -> list[Polygon]:
        """The polygons without ``points`` whose shape comes from a topic (footprint or polygon_sub_topic)."""
        return [s for s in self.shapes if type(s) is Polygon and not s.params.points]

    def points_reach(self, cmd: Velocity) -> float:
        """How far from the base origin a point can be and still count in the decision on ``cmd`` (m): the
        largest ``Shape.decision_reach`` of the enabled shapes. Points all farther away decide as no
        points do, so a caller may leave them out."""
        return max([s.decision_reach(cmd) for s in self.shapes if s.params.enabled], default=0.0)

    def process(self, cmd: Velocity, now_ns: int, points: Mapping[str, np.ndarray | None]) -> Decision:
        """One decision for command ``cmd`` at ``now_ns`` given each source's (N, 2) points or None."""
        action = Action(NONE, cmd)
        usable: dict[str, np.ndarray] = {}
        invalid = ""
        for name, stops in self._sources:
            pts = points.get(name)
            if pts is None:
                if stops:
                    action, invalid = Action(STOP, ZERO, INVALID_SOURCE), name
                    break
                continue
            usable[name] = pts
        times: dict[str, float] = {}
        counts: dict[str, int] = {}
        for shape in self.shapes:
            if not shape.params.enabled:
                continue
            if action.action_type == STOP:
                break
            shape.update(cmd)
            if not shape.is_set():
                continue
            gathered = shape.gather(usable)
            kind = shape.action_type
            if kind == APPROACH:
                t = shape.collision_time(gathered, cmd)
                times[shape.name] = t
                if t >= 0.0:
                    safe = cmd.scaled(t / shape.params.time_before_collision)
                    if safe.magnitude2() < action.velocity.magnitude2():
                        action = Action(APPROACH, safe, shape.name)
            elif kind in (STOP, SLOWDOWN, LIMIT):
                n = shape.count_inside(gathered)
                counts[shape.name] = n
                if n < shape.min_points:
                    continue
                if kind == STOP:
                    action = Action(STOP, ZERO, shape.name)
                    continue
                if kind == SLOWDOWN:
                    safe = cmd.scaled(shape.params.slowdown_ratio)
                else:
                    safe = cmd.scaled(limit_ratio(cmd, shape.params.linear_limit, shape.params.angular_limit))
                if safe.magnitude2() < action.velocity.magnitude2():
                    action = Action(kind, safe, shape.name)
        publish = True
        if action.velocity.is_zero():
            if not self.previous.velocity.is_zero():
                self.stop_stamp_ns = now_ns
            elif now_ns - self.stop_stamp_ns > self._stop_pub_timeout_ns:
                publish = False
        decision = Decision(action, self.previous, publish, times, invalid, counts)
        self.previous = action
        return decision
