"""The collision monitor's shapes and kinematics (Nav2 Jazzy ``polygon.cpp``, ``circle.cpp``,
``velocity_polygon.cpp``, ``kinematics.cpp``).

Everything is in the robot's base frame, metres, radians and m/s: points are ``(N, 2)`` arrays.
A shape counts the points inside it; it acts when the count reaches ``min_points``:

- ``Polygon``: Nav2's ray casting (edge ``i -> j`` is crossed when ``(y <= y_i) == (y > y_j)`` and
  the crossing is strictly right of the point): half-open in y, strict in x, so a point on the right
  edge of a square is outside and one on its left edge inside;
- ``Circle``: strictly inside, ``x^2 + y^2 < r^2``;
- ``VelocityPolygon``: the first sub-polygon whose velocity ranges hold the command becomes the
  shape; with no match it keeps the previous one (none before the first match).

``collision_time`` simulates the shape moving with a constant command (``project_state``, steps of
``simulation_time_step`` up to ``time_before_collision``) and returns the loop time of the step
that collides: 0 when the points are already inside, -1 when no step collides. As in Nav2 the time
is the step's start, one step before the pose that touched.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from navlog.replay.nav2.collision_monitor.params import CollisionPolygonParams, VelocitySubPolygonParams


class Velocity(NamedTuple):
    """A planar command: vx, vy (m/s) and wz (rad/s)."""

    vx: float
    vy: float
    wz: float

    def scaled(self, ratio: float) -> Velocity:
        return Velocity(self.vx * ratio, self.vy * ratio, self.wz * ratio)

    def magnitude2(self) -> float:
        """``vx^2 + vy^2 + wz^2``: how Nav2 orders velocities (linear and angular units mixed)."""
        return self.vx * self.vx + self.vy * self.vy + self.wz * self.wz

    def is_zero(self) -> bool:
        return self.vx == 0.0 and self.vy == 0.0 and self.wz == 0.0


ZERO = Velocity(0.0, 0.0, 0.0)
NO_POINTS = np.zeros((0, 2))  # no (N, 2) points: shared, read-only
NO_POINTS.flags.writeable = False


def project_state(
    dt: float, pose: tuple[float, float, float], vel: Velocity
) -> tuple[tuple[float, float, float], Velocity]:
    """One step of constant-velocity motion: the pose moves by ``vel * dt``, then (vx, vy) turns by ``wz * dt``."""
    theta = vel.wz * dt
    c, s = math.cos(theta), math.sin(theta)
    x, y, yaw = pose
    new_pose = (x + vel.vx * dt, y + vel.vy * dt, yaw + theta)
    return new_pose, Velocity(vel.vx * c - vel.vy * s, vel.vx * s + vel.vy * c, vel.wz)


def transform_points(pose: tuple[float, float, float], points: np.ndarray) -> np.ndarray:
    """Points into the frame of a robot at ``pose``: ``R(yaw)^T (p - (x, y))``."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = points[:, 0] - x, points[:, 1] - y
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy])


class PolygonEdges(NamedTuple):
    """A polygon's bounding box and edges ``i -> j`` (from the last vertex to the first, then on) as
    ``points_in_polygon`` casts rays against them; computed once per vertex array."""

    lo: np.ndarray  # (2,) x, y minimum
    hi: np.ndarray  # (2,) x, y maximum
    xi: np.ndarray
    yi: np.ndarray
    yj: np.ndarray
    dx: np.ndarray  # xj - xi
    dy: np.ndarray  # yj - yi, 1 where the edge is horizontal (never crossed)


def polygon_edges(vertices: np.ndarray) -> PolygonEdges:
    """The bounding box and edge table of an (N, 2) polygon."""
    xj, yj = vertices[:, 0], vertices[:, 1]
    xi, yi = np.roll(xj, 1), np.roll(yj, 1)
    return PolygonEdges(
        vertices.min(axis=0), vertices.max(axis=0), xi, yi, yj, xj - xi, np.where(yj != yi, yj - yi, 1.0)
    )


def points_in_polygon(vertices: np.ndarray | PolygonEdges, points: np.ndarray) -> np.ndarray:
    """Boolean mask of the points inside a polygon, with Nav2's ray-casting edge rules (all edges at once).

    Points outside the bounding box ``xmin <= x < xmax, ymin <= y <= ymax`` are outside under those
    rules (no edge is crossed, or every crossing is, an even number), so only the others are cast.
    ``vertices`` is an (N, 2) array or its ``polygon_edges``."""
    e = vertices if isinstance(vertices, PolygonEdges) else polygon_edges(vertices)
    inside = np.zeros(len(points), dtype=bool)
    lo, hi = e.lo, e.hi
    px_all, py_all = points[:, 0], points[:, 1]
    candidates = np.flatnonzero((px_all >= lo[0]) & (px_all < hi[0]) & (py_all >= lo[1]) & (py_all <= hi[1]))
    if not len(candidates):
        return inside
    px, py = px_all[candidates, None], py_all[candidates, None]
    crosses = (py <= e.yi) == (py > e.yj)  # never true when yi == yj
    x_inter = e.xi + (py - e.yi) * e.dx / e.dy
    inside[candidates] = (np.count_nonzero(crosses & (x_inter > px), axis=1) % 2).astype(bool)
    return inside


class Shape:
    """A collision-monitor zone: its parameters, its current vertices (or radius) and its sources."""

    def __init__(self, name: str, params: CollisionPolygonParams, sources: Sequence[str]) -> None:
        self.name = name
        self.params = params
        self.sources = tuple(params.sources_names) or tuple(sources)
        self._steps: tuple[bytes, tuple] | None = None  # the last command's simulation

    @property
    def action_type(self) -> str:
        return self.params.action_type

    @property
    def min_points(self) -> int:
        return self.params.min_points

    def is_set(self) -> bool:
        """False while the shape is unknown (no footprint yet, no velocity polygon matched yet)."""
        return True

    def update(self, cmd: Velocity) -> None:
        """Refresh the shape for a command (velocity polygons choose their sub-polygon)."""

    def inside(self, points: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def reach(self) -> float:
        """The farthest any point of the shape is from the base origin (m)."""
        raise NotImplementedError

    def max_reach(self) -> float:
        """The farthest any point of the shape can be from the base origin whatever the command (m)."""
        return self.reach()

    def _travel(self, cmd: Velocity) -> float:
        """A bound on how far the approach simulation moves the shape for ``cmd``: |v| * dt * steps (m)."""
        dt, horizon = self.params.simulation_time_step, self.params.time_before_collision
        return math.hypot(cmd.vx, cmd.vy) * dt * (int(horizon / dt) + 2)

    def decision_reach(self, cmd: Velocity) -> float:
        """How far from the base origin a point can be and still count in this shape's decision on ``cmd``
        (m): its ``max_reach``, plus for approach how far the simulation moves it (as
        ``collision_time`` bounds it). A point farther away is outside the shape and never counted."""
        if self.action_type == "approach":
            return self.max_reach() + self._travel(cmd) + 1e-9
        return self.max_reach()

    def gather(self, source_points: dict[str, np.ndarray]) -> np.ndarray:
        """This shape's sources' points, in the shape's source order."""
        parts = [source_points[s] for s in self.sources if s in source_points and len(source_points[s])]
        if len(parts) == 1:
            return parts[0]  # one source: its points as they are (read, never written)
        return np.concatenate(parts) if parts else NO_POINTS

    def count_inside(self, points: np.ndarray) -> int:
        return int(np.count_nonzero(self.inside(points))) if len(points) else 0

    def _simulated_steps(self, cmd: Velocity) -> tuple[list[float], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Every step of Nav2's simulation loop for ``cmd``: the loop times and the poses' x, y, cos(yaw)
        and sin(yaw) as (steps, 1) columns, stepped with ``project_state``; kept for a repeated command."""
        dt, horizon = self.params.simulation_time_step, self.params.time_before_collision
        key = np.array([cmd.vx, cmd.vy, cmd.wz, dt, horizon]).tobytes()  # bit for bit (-0.0 is not 0.0)
        if self._steps is not None and self._steps[0] == key:
            return self._steps[1]
        times, xs, ys, cs, ss = [], [], [], [], []
        pose, vel = (0.0, 0.0, 0.0), cmd
        t = 0.0
        while t <= horizon:
            pose, vel = project_state(dt, pose, vel)
            times.append(t)
            xs.append(pose[0])
            ys.append(pose[1])
            cs.append(math.cos(pose[2]))
            ss.append(math.sin(pose[2]))
            t += dt
        steps = (times, np.array(xs)[:, None], np.array(ys)[:, None], np.array(cs)[:, None], np.array(ss)[:, None])
        self._steps = (key, steps)
        return steps

    def collision_time(self, points: np.ndarray, cmd: Velocity) -> float:
        """Seconds before the shape, moving with ``cmd``, holds ``min_points`` points (0: already; -1: never)."""
        # only points the moving shape can reach matter: |pose| <= |v| * dt * steps, shape within reach()
        # (the points inside it now among them: the shape lies within reach() of the origin)
        if len(points):
            reach = self.reach() + self._travel(cmd) + 1e-9
            points = points[np.hypot(points[:, 0], points[:, 1]) <= reach]
        if self.count_inside(points) >= self.min_points:
            return 0.0
        if len(points) < self.min_points:
            return -1.0
        times, x, y, c, s = self._simulated_steps(cmd)
        if not times:
            return -1.0
        dx = points[None, :, 0] - x
        dy = points[None, :, 1] - y
        moved = np.stack([c * dx + s * dy, -s * dx + c * dy], axis=-1).reshape(-1, 2)  # as transform_points
        counts = np.count_nonzero(self.inside(moved).reshape(len(times), -1), axis=1)
        hits = np.flatnonzero(counts >= self.min_points)
        return times[int(hits[0])] if len(hits) else -1.0


class Polygon(Shape):
    """A polygon zone from ``points``, or from the robot footprint (approach polygons) set later."""

    def __init__(
        self,
        name: str,
        params: CollisionPolygonParams,
        sources: Sequence[str],
        vertices: Sequence[tuple[float, float]] | np.ndarray | None = None,
    ) -> None:
        super().__init__(name, params, sources)
        self.vertices: np.ndarray | None = None
        self._edge_cache: tuple[np.ndarray, PolygonEdges, float] | None = None  # (vertices, edges, reach)
        pts = params.point_list() if params.type == "polygon" else []
        if pts:
            self.set_vertices(pts)
        elif vertices is not None:
            self.set_vertices(vertices)

    def set_vertices(self, vertices: Sequence[tuple[float, float]] | np.ndarray) -> None:
        """A new shape (a footprint or a published polygon: at least 3 vertices)."""
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
        if len(v) < 3:
            raise ValueError(f"polygon '{self.name}': a shape needs at least 3 vertices, got {len(v)}")
        self.vertices = v

    def is_set(self) -> bool:
        return self.vertices is not None

    def _edges(self) -> tuple[PolygonEdges, float]:
        """The current vertices' edge table and reach, computed once per vertex array."""
        v = self.vertices
        assert v is not None
        if self._edge_cache is None or self._edge_cache[0] is not v:
            self._edge_cache = (v, polygon_edges(v), float(np.hypot(v[:, 0], v[:, 1]).max()))
        return self._edge_cache[1], self._edge_cache[2]

    def reach(self) -> float:
        return 0.0 if self.vertices is None else self._edges()[1]

    def inside(self, points: np.ndarray) -> np.ndarray:
        if self.vertices is None:
            return np.zeros(len(points), dtype=bool)
        return points_in_polygon(self._edges()[0], points)


class Circle(Shape):
    """A circular zone of ``radius`` around the base frame's origin (not set while the radius is 0)."""

    def is_set(self) -> bool:
        return self.params.radius > 0.0

    def reach(self) -> float:
        return self.params.radius

    def inside(self, points: np.ndarray) -> np.ndarray:
        r = self.params.radius
        return points[:, 0] ** 2 + points[:, 1] ** 2 < r * r


def in_velocity_range(cmd: Velocity, sub: VelocitySubPolygonParams, holonomic: bool) -> bool:
    """Whether a command selects a sub-polygon: linear (speed magnitude when holonomic), angular and,
    when holonomic, the direction window (which may wrap through pi)."""
    linear = math.hypot(cmd.vx, cmd.vy) if holonomic else cmd.vx
    ok = sub.linear_min <= linear <= sub.linear_max and sub.theta_min <= cmd.wz <= sub.theta_max
    if holonomic:
        direction = math.atan2(cmd.vy, cmd.vx)
        start, end = sub.direction_start_angle, sub.direction_end_angle
        ok = ok and (start <= direction <= end if start <= end else (direction >= start or direction <= end))
    return ok


class VelocityPolygon(Polygon):
    """A polygon whose shape follows the command: the first sub-polygon whose ranges hold it."""

    def __init__(self, name: str, params: CollisionPolygonParams, sources: Sequence[str]) -> None:
        super().__init__(name, params, sources)
        self.subs = [
            (
                sub_name,
                params.velocity_polygon_params[sub_name],
                np.asarray(params.velocity_polygon_params[sub_name].point_list()),
            )
            for sub_name in params.velocity_polygons
            if sub_name in params.velocity_polygon_params
        ]
        self.current = ""  # the sub-polygon in use ("" before the first match)
        self.unmatched = 0  # commands no sub-polygon covered (the previous shape was kept)
        # the farthest vertex of any sub-polygon (inf for a sub-polygon that is no (N, 2) array: no bound)
        self._subs_reach = max(
            (
                float(np.hypot(v[:, 0], v[:, 1]).max()) if v.ndim == 2 and v.shape[1] == 2 and len(v) else math.inf
                for _, _, v in self.subs
            ),
            default=0.0,
        )

    def max_reach(self) -> float:
        """The farthest vertex of the current shape and of every sub-polygon it may switch to."""
        return max(self.reach(), self._subs_reach)

    def update(self, cmd: Velocity) -> None:
        for sub_name, sub, vertices in self.subs:
            if in_velocity_range(cmd, sub, self.params.holonomic):
                self.vertices, self.current = vertices, sub_name
                return
        self.unmatched += 1


def make_shape(
    name: str,
    params: CollisionPolygonParams,
    sources: Sequence[str],
    footprint: Sequence[tuple[float, float]] | None = None,
) -> Shape:
    """The shape a polygon's parameters describe; ``footprint`` (base frame) for polygons without points."""
    if params.type == "circle":
        return Circle(name, params, sources)
    if params.type == "velocity_polygon":
        return VelocityPolygon(name, params, sources)
    return Polygon(name, params, sources, None if params.points else footprint)
