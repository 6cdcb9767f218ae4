"""The collision monitor node: /cmd_vel_smoothed -> /cmd_vel, Nav2's ``collision_monitor`` on the executor.

``CollisionMonitorNode(params)`` subscribes to the input command (Twist or TwistStamped), to each
enabled source's topic (``scan``: LaserScan, ``pointcloud``: PointCloud2, ``range``: Range), to
/tf and /tf_static, and, for polygons without ``points`` when no ``footprint`` is given, to their
footprint (approach) or polygon topic (PolygonStamped). Each command gets one decision of
``navlog.replay.nav2.collision_monitor.CollisionMonitor`` at the command's arrival time, and the
node publishes:

- the command it lets through on ``output_topic`` (a Twist; a TwistStamped carrying the input's
  header when ``enable_stamped_cmd_vel``), except zeros once ``stop_pub_timeout`` has passed;
- its state on ``/navlog/events`` (``navlog_msgs/Event``) whenever the polygon in charge changes:
  ``collision_monitor_<action>`` when an action starts and ``collision_monitor_<action>_end`` when
  it ends, with the polygon's name as detail and Nav2's action code as value;
- for each enabled polygon with ``visualize: true``, after every decision as Nav2's
  ``publishPolygons`` does, its current shape as ``geometry_msgs/PolygonStamped`` in
  ``base_frame_id`` on ``polygon_pub_topic`` (default: the polygon's name, a relative topic: the
  polygon ``FootprintApproach`` goes out on ``/FootprintApproach``; ``~/x`` is
  ``/collision_monitor/x``); a circle as Nav2 draws it, 16 vertices; a shape not known yet (no
  footprint, no velocity sub-polygon matched) has no vertices;
- for each such approach polygon, navlog's view of its prediction on
  ``/navlog/collision_monitor/<polygon>/collision_footprint``: the shape at the pose where the
  simulation met ``min_points`` points (the current pose when they are inside already), or no
  vertices when it predicts no collision within ``time_before_collision``.

Each source's points are its latest message's, in ``base_frame_id`` at the command's time: with
``base_shift_correction`` through ``odom_frame_id`` (sensor at its stamp -> odom -> base now),
otherwise the latest transform. Where Nav2 would wait up to ``transform_tolerance`` for a
transform, a replay cannot: the node uses the newest time within that tolerance at which the
transform exists. A message's points in its own frame, and its transform into ``odom_frame_id``
at its stamp, are computed once and kept while the TF received since leaves them unchanged
(``TFBuffer.holds``); a command's transform out of ``odom_frame_id`` is looked up once for all
sources. A scan or range whose points all lie beyond the monitor's ``points_reach`` for the command
(``planar_points_beyond``: a bound from their least distance to the sensor, kept per message) is
not transformed: it gives no points, which decide as its points would. With
``base_shift_correction`` that bound is computed from the same transforms as floats
(``TFBuffer.lookup_pose``), so such a command builds no matrix, and a scan's points are computed
only for a command that needs them. A source with no message
yet, older than its ``source_timeout``, without a transform or with a range reading out of bounds
is unusable: Nav2's "invalid source" stop; each such case is counted in ``skipped_counts()``.
``summary()`` gives commands acted on per polygon, the minimum predicted time to collision and the
time spent stopped.
"""

from __future__ import annotations

import functools
import math
from collections import Counter
from collections.abc import Sequence
from typing import Any

import numpy as np

from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.geometry import rigid_inverse
from navlog.replay.nav2.collision_monitor import (
    ACTION_CODES,
    NO_POINTS,
    Circle,
    CollisionMonitor,
    CollisionMonitorParams,
    CollisionSourceParams,
    Decision,
    Polygon,
    Velocity,
    cloud_points,
    planar_block_beyond,
    planar_points_beyond,
    project_state,
    range_points,
    scan_nearest,
    scan_points,
    source_fresh,
    to_base,
)
from navlog.replay.pointcloud import xyz
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import Pose, TFBuffer, TransformError, relative_pose
from navlog.replay.scan_geometry import scan_fault

RANGE = "sensor_msgs/msg/Range"
POLYGON_STAMPED = "geometry_msgs/msg/PolygonStamped"
EVENTS_TOPIC = "/navlog/events"
SOURCE_TYPES = {"scan": m.LASER_SCAN, "pointcloud": m.POINT_CLOUD2, "range": RANGE}
COLLISION_FOOTPRINT_TOPIC = "/navlog/collision_monitor/{polygon}/collision_footprint"
CIRCLE_EDGES = 16  # Nav2's Circle::getPolygon
_LATER = object()  # a scan's points, not computed until a command needs them


def _absolute(topic: str) -> str:
    return topic if topic.startswith("/") else "/" + topic


def polygon_pub_topic(node_name: str, polygon: str, topic: str) -> str:
    """Where Nav2 publishes a polygon: ``topic`` (default the polygon's name) resolved as a ROS 2 name
    of a node named ``node_name`` in the root namespace (``~/x`` is private to the node)."""
    topic = topic or polygon
    return f"/{node_name}/{topic[2:]}" if topic.startswith("~/") else _absolute(topic)


def circle_outline(radius: float) -> np.ndarray:
    """A circle as Nav2 publishes it: vertices from angle 0 in steps of 2*pi/16 while the angle is under 2*pi."""
    step = 2.0 * math.pi / CIRCLE_EDGES
    angles = []
    a = 0.0
    while a < 2.0 * math.pi:  # accumulated as Nav2 does, so the vertex count is Nav2's
        angles.append(a)
        a += step
    return radius * np.column_stack([np.cos(angles), np.sin(angles)])


def shape_outline(shape: Any) -> np.ndarray:
    """A shape's current vertices, (N, 2) in the base frame; (0, 2) while it is not known."""
    if isinstance(shape, Circle):
        return circle_outline(shape.params.radius) if shape.is_set() else np.zeros((0, 2))
    vertices = shape.vertices if isinstance(shape, Polygon) else None
    return np.zeros((0, 2)) if vertices is None else vertices


def collision_pose(shape: Any, cmd: Velocity, ttc: float, inside_now: bool) -> tuple[float, float, float]:
    """The base-frame pose (x, y, yaw) at which an approach shape met its points: the step of Nav2's
    simulation whose loop time is ``ttc`` (stepped as ``Shape.collision_time`` steps), or the current
    pose when the points are ``inside_now``."""
    pose = (0.0, 0.0, 0.0)
    if inside_now:
        return pose
    dt, horizon = shape.params.simulation_time_step, shape.params.time_before_collision
    vel, t = cmd, 0.0
    while t <= horizon:
        pose, vel = project_state(dt, pose, vel)
        if t == ttc:
            break
        t += dt
    return pose


def polygon_stamped(ns: int, frame: str, xy: np.ndarray) -> Any:
    """A ``geometry_msgs/PolygonStamped`` of (N, 2) vertices (float32, z = 0)."""
    p32 = m.msg_class("geometry_msgs/msg/Point32")
    points = [p32(x=m.f32(x), y=m.f32(y), z=0.0) for x, y in np.asarray(xy, dtype=np.float64).reshape(-1, 2)]
    polygon = m.msg_class("geometry_msgs/msg/Polygon")(points=points)
    return m.msg_class(POLYGON_STAMPED)(header=m.header(ns, frame), polygon=polygon)


class CollisionMonitorNode(Node):
    """Nav2's collision monitor on the executor (see the module docstring)."""

    name = "collision_monitor"

    def __init__(
        self,
        params: CollisionMonitorParams,
        *,
        input_topic: str = "/cmd_vel_smoothed",
        output_topic: str = "/cmd_vel",
        footprint: Sequence[tuple[float, float]] | None = None,
    ) -> None:
        """``footprint``: the robot footprint in the base frame for polygons without ``points`` (else
        they follow their footprint or polygon topic)."""
        super().__init__()
        for name in params.observation_sources:
            sp = params.source_params.get(name)
            if sp is not None and sp.enabled and sp.type not in SOURCE_TYPES:
                raise ConfigError(
                    f"collision_monitor source '{name}': type '{sp.type}' is not run by navlog "
                    f"(it runs {', '.join(SOURCE_TYPES)}); set '{name}.enabled: false' to replay without it"
                )
        self.params = params
        self.monitor = CollisionMonitor(params, footprint)
        self.input_topic = input_topic
        self.output_topic = output_topic
        self.tf = TFBuffer(skipped=self.skipped)
        # per source: (message, its sensor-frame points (_LATER: not computed yet), their least distance from
        # the sensor when planar) and (message, TF epoch, odom <- sensor at its stamp), as a matrix and a Pose
        self._sensor_points: dict[str, tuple[Any, Any, float | None]] = {}
        self._sensor_tf: dict[str, tuple[Any, int, np.ndarray]] = {}
        self._sensor_pose: dict[str, tuple[Any, int, Pose]] = {}
        self._latest_tf: dict[str, tuple[int, np.ndarray]] = {}  # frame -> (transforms added, base <- frame)
        self._base_now: tuple[int, int, np.ndarray | None] | None = None  # (now, added, base <- odom at now)
        self._pose_now: tuple[int, int, Pose | None] | None = None  # (now, added, odom <- base at now, floats)
        self._tolerance_ns = round(params.transform_tolerance * 1e9)
        self.sources: dict[str, CollisionSourceParams] = {
            n: params.source_params[n]
            for n in params.observation_sources
            if n in params.source_params and params.source_params[n].enabled
        }
        self.latest: dict[str, Any] = {}  # source -> its latest message
        self.shape_topics: dict[str, list[Polygon]] = {}
        if footprint is None:
            for shape in self.monitor.footprint_shapes():
                p = shape.params
                topic = p.footprint_topic if p.action_type == "approach" else p.polygon_sub_topic
                if topic:
                    self.shape_topics.setdefault(_absolute(topic), []).append(shape)
        # polygons with visualize: true -> the topic of their shape
        self.visualized: list[tuple[Polygon | Circle, str]] = [
            (shape, polygon_pub_topic(self.name, shape.name, shape.params.polygon_pub_topic))
            for shape in self.monitor.shapes
            if shape.params.visualize and isinstance(shape, Polygon | Circle)
        ]
        self.last_decision: Decision | None = None
        self._commands = 0
        self._published = 0
        self._actions: dict[str, Counter[str]] = {}
        self._min_ttc: float | None = None
        self._stopped_ns = 0
        self._stopped_since: int | None = None
        self._last_t = 0

    # ------------------------------------------------------------------ wiring
    def setup(self) -> None:
        self.subscribe("/tf", self._on_tf, (m.TF_MESSAGE,), light=True)
        self.subscribe("/tf_static", self._on_tf_static, (m.TF_MESSAGE,), light=True)
        topics: dict[str, list[str]] = {}
        for name, sp in self.sources.items():
            topics.setdefault(_absolute(sp.topic), []).append(name)
        for topic, names in topics.items():
            types = tuple(sorted({SOURCE_TYPES[self.sources[n].type] for n in names}))
            self.subscribe(topic, functools.partial(self._on_source, names), types)
        for topic in self.shape_topics:
            self.subscribe(topic, functools.partial(self._on_shape, topic), (POLYGON_STAMPED,))
        self.subscribe(self.input_topic, self._on_command, (m.TWIST, m.TWIST_STAMPED))

    def _on_tf(self, msg: Any, t: int) -> None:
        self.tf.add_message_skipping(msg, False, None)

    def _on_tf_static(self, msg: Any, t: int) -> None:
        self.tf.add_message_skipping(msg, True, None)

    def _on_source(self, names: list[str], msg: Any, t: int) -> None:
        for name in names:
            fault = scan_fault(msg) if self.sources[name].type == "scan" else None
            if fault is not None:  # the source keeps its last usable scan (until its source_timeout)
                self.skipped[f"{name}: {fault}"] += 1
                continue
            self.latest[name] = msg

    def _on_shape(self, topic: str, msg: Any, t: int) -> None:
        try:
            T = self._lookup_recent(self.params.base_frame_id, msg.header.frame_id, t)
        except TransformError:
            self.skipped[f"{topic}: no transform {self.params.base_frame_id} <- {msg.header.frame_id}"] += 1
            return
        pts = np.array([[p.x, p.y, p.z] for p in msg.polygon.points], dtype=np.float64).reshape(-1, 3)
        for shape in self.shape_topics[topic]:
            try:
                shape.set_vertices(to_base(pts, T)[:, :2])
            except ValueError:
                self.skipped[f"{topic}: polygon with fewer than 3 points (ignored)"] += 1

    # ------------------------------------------------------------------ transforms and points
    def _lookup_at(self, target: str, source: str, t: int, lookup: Any = None) -> tuple[Any, bool]:
        """The transform at ``t`` (and True), else at the newest time within ``transform_tolerance``
        before it (and False); ``lookup``: the buffer's lookup to use (default ``TFBuffer.lookup``).

        The usual case in a replay, a command newer than the last /tf sample, goes straight to that
        sample's time: the failed lookup at ``t`` would give nothing but its error."""
        if lookup is None:
            lookup = self.tf.lookup
        # the newest time every edge of the chain reaches: the transform is taken there when it is
        # before ``t`` within the tolerance
        latest = self.tf.latest_common_time(target, source)
        if latest is not None and t - self._tolerance_ns <= latest < t:
            return lookup(target, source, latest), False
        return lookup(target, source, t), True

    def _lookup_recent(self, target: str, source: str, t: int) -> np.ndarray:
        """The transform at ``t``, else at the newest time within ``transform_tolerance`` before it."""
        return self._lookup_at(target, source, t)[0]

    def _odom_to_base(self, now: int) -> np.ndarray:
        """base <- odom at ``now``: looked up once per decision, whichever sources need it."""
        added = self.tf.added
        if self._base_now is None or self._base_now[:2] != (now, added):
            try:  # odom <- base inverted: a rigid transform's inverse, without a general matrix inverse
                T: np.ndarray | None = rigid_inverse(
                    self._lookup_recent(self.params.odom_frame_id, self.params.base_frame_id, now)
                )
            except TransformError:
                T = None
            self._base_now = (now, added, T)
        if self._base_now[2] is None:
            raise TransformError(f"no transform {self.params.base_frame_id} <- {self.params.odom_frame_id}")
        return self._base_now[2]

    def _base_pose(self, now: int) -> Pose:
        """odom <- base at ``now`` as a ``Pose`` of floats (``TFBuffer.lookup_pose``): the transform
        ``_odom_to_base`` inverts, to rounding, and the same ``TransformError``."""
        added = self.tf.added
        if self._pose_now is None or self._pose_now[:2] != (now, added):
            p = self.params
            try:
                pose = self._lookup_at(p.odom_frame_id, p.base_frame_id, now, self.tf.lookup_pose)[0]
                self._pose_now = (now, added, pose)
            except TransformError:
                self._pose_now = (now, added, None)
        if self._pose_now[2] is None:
            raise TransformError(f"no transform {self.params.base_frame_id} <- {self.params.odom_frame_id}")
        return self._pose_now[2]

    def _beyond_now(self, name: str, msg: Any, frame: str, stamp: int, now: int, nearest: float, reach: float) -> bool:
        """``planar_points_beyond`` of the transform ``_to_base`` gives with ``base_shift_correction``, from
        the same transforms as ``Pose``s of floats: base <- odom at ``now`` after odom <- sensor at the
        stamp. Its 2x2 block and shift are those of the matrices to rounding (the test's margin is far
        wider), and it raises ``TransformError`` exactly when ``_to_base`` does."""
        base = self._base_pose(now)
        tx, ty, _, x, y, z, w = relative_pose(base, self._sensor_to_odom(name, msg, frame, stamp, pose=True))
        block = (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z))
        return planar_block_beyond((*block, tx, ty), nearest, reach)

    def _sensor_to_odom(self, name: str, msg: Any, frame: str, stamp: int, pose: bool = False) -> Any:
        """odom <- sensor at the message's stamp (a matrix, or with ``pose`` a ``Pose`` of floats), kept
        per message while the TF history gives it unchanged (a transform found only at an earlier time
        within the tolerance is looked up again)."""
        kept = self._sensor_pose if pose else self._sensor_tf
        hit = kept.get(name)
        if hit is not None and hit[0] is msg and self.tf.holds(hit[1], stamp):
            return hit[2]
        epoch = self.tf.epoch
        T, exact = self._lookup_at(self.params.odom_frame_id, frame, stamp, self.tf.lookup_pose if pose else None)
        if exact:
            kept[name] = (msg, epoch, T)
        return T

    def _to_base(self, name: str, msg: Any, frame: str, stamp: int, now: int) -> np.ndarray:
        p = self.params
        if p.base_shift_correction:
            return self._odom_to_base(now) @ self._sensor_to_odom(name, msg, frame, stamp)
        added = self.tf.added
        hit = self._latest_tf.get(frame)
        if hit is None or hit[0] != added:
            hit = (added, self.tf.lookup(p.base_frame_id, frame, None))
            self._latest_tf[frame] = hit
        return hit[1]

    def _sensor_frame_points(self, name: str, msg: Any, points: bool = True) -> tuple[Any, float | None]:
        """A source message's points in its own frame (an (N, 3) array; a cloud's raw xyz; None for a
        range reading out of bounds) and, for a scan's or a range's points (z = 0), their least distance
        from the sensor (inf for none; None for a cloud), computed once per message. Without ``points``
        a scan's points may be ``_LATER``: its least range is read from the ranges alone."""
        hit = self._sensor_points.get(name)
        if hit is None or hit[0] is not msg:
            sp = self.sources[name]
            pts: Any = _LATER
            nearest: float | None = None
            if sp.type == "scan":
                nearest = scan_nearest(msg.ranges, msg.range_min, msg.range_max)
            elif sp.type == "range":
                pts = range_points(msg.range, msg.min_range, msg.max_range, msg.field_of_view, sp.obstacles_angle)
                if pts is not None:
                    nearest = float(np.hypot(pts[:, 0], pts[:, 1]).min()) if len(pts) else math.inf
            hit = self._sensor_points[name] = (msg, pts, nearest)
        if points and hit[1] is _LATER:
            sp = self.sources[name]
            if sp.type == "scan":
                pts = scan_points(msg.ranges, msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max)
            else:
                pts = xyz(msg)
            hit = self._sensor_points[name] = (msg, pts, hit[2])
        return hit[1], hit[2]

    def source_points(self, name: str, now: int, reach: float | None = None) -> np.ndarray | None:
        """A source's (N, 2) base-frame points at ``now``, or None (counted) when it cannot be used.

        With ``reach`` (the monitor's ``points_reach`` for the command), a scan or range whose points all
        lie farther than that from the base origin (``planar_points_beyond``) gives no points (0, 2),
        untransformed: no shape could count them, so the decision is the same. With
        ``base_shift_correction`` that test is made from floats (``_beyond_now``) before any matrix is
        built, and a scan's points are computed only when it fails."""
        sp = self.sources[name]
        msg = self.latest.get(name)
        if msg is None:
            self.skipped[f"{name}: no message on {_absolute(sp.topic)} yet"] += 1
            return None
        stamp = m.to_ns(msg.header.stamp)
        if not source_fresh(stamp, now, self.params.source_timeout_of(name)):
            self.skipped[f"{name}: data older than source_timeout {self.params.source_timeout_of(name)} s"] += 1
            return None
        frame = msg.header.frame_id
        planar = sp.type != "pointcloud"
        try:
            if reach is not None and planar and self.params.base_shift_correction:
                nearest = self._sensor_frame_points(name, msg, points=False)[1]
                if nearest is not None and self._beyond_now(name, msg, frame, stamp, now, nearest, reach):
                    return NO_POINTS
                reach = None  # tested: the points are transformed
            T = self._to_base(name, msg, frame, stamp, now)
        except TransformError:
            self.skipped[f"{name}: no transform {self.params.base_frame_id} <- {frame}"] += 1
            return None
        pts, nearest = self._sensor_frame_points(name, msg)
        if not planar:
            return cloud_points(pts, T, sp.min_height, sp.max_height, sp.min_range)
        if pts is None:
            self.skipped[f"{name}: range reading outside [min_range, max_range]"] += 1
            return None
        if reach is not None and nearest is not None and planar_points_beyond(T, nearest, reach):
            return NO_POINTS
        return to_base(pts, T)[:, :2]

    # ------------------------------------------------------------------ one command
    def _on_command(self, msg: Any, t: int) -> None:
        twist = msg.twist if hasattr(msg, "twist") else msg
        lin, ang = twist.linear, twist.angular
        if not all(map(math.isfinite, (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z))):
            self.skipped["command with NaN or infinity (ignored, as Nav2 does)"] += 1
            return
        for topic, shapes in self.shape_topics.items():
            for shape in shapes:
                if not shape.is_set():
                    self.skipped[f"{shape.name}: no shape on {topic} yet (the polygon cannot act)"] += 1
        cmd = Velocity(float(lin.x), float(lin.y), float(ang.z))  # m.twist_values, read above
        reach = self.monitor.points_reach(cmd)
        points = {name: self.source_points(name, t, reach) for name in self.sources}
        decision = self.monitor.process(cmd, t, points)
        self._record(decision, t)
        if decision.changed:
            self._publish_state(decision, t)
        if decision.publish:
            self._published += 1
            v = decision.action.velocity
            out = m.twist(v.vx, v.vy, v.wz)
            if self.params.enable_stamped_cmd_vel:
                # an unstamped input gives an empty header, as Nav2's TwistSubscriber does
                header = msg.header if hasattr(msg, "twist") else m.header(0, "")
                self.publish(self.output_topic, m.TWIST_STAMPED, m.msg_class(m.TWIST_STAMPED)(header, out))
            else:
                self.publish(self.output_topic, m.TWIST, out)
        if self.visualized:
            self._publish_polygons(decision, cmd, points, t)

    def _publish_polygons(self, d: Decision, cmd: Velocity, points: dict[str, np.ndarray | None], t: int) -> None:
        """Each visualized polygon's shape, and each approach polygon's predicted collision footprint."""
        frame = self.params.base_frame_id
        usable = {name: pts for name, pts in points.items() if pts is not None}
        for shape, topic in self.visualized:
            if not shape.params.enabled:
                continue
            outline = shape_outline(shape)
            self.publish(topic, POLYGON_STAMPED, polygon_stamped(t, frame, outline))
            if shape.action_type != "approach":
                continue
            ttc = d.collision_times.get(shape.name, -1.0)
            predicted = np.zeros((0, 2))
            if ttc >= 0.0 and len(outline):
                inside_now = ttc == 0.0 and shape.count_inside(shape.gather(usable)) >= shape.min_points
                x, y, yaw = collision_pose(shape, cmd, ttc, inside_now)
                c, s = math.cos(yaw), math.sin(yaw)
                predicted = outline @ np.array([[c, s], [-s, c]]) + (x, y)
            self.publish(
                COLLISION_FOOTPRINT_TOPIC.format(polygon=shape.name),
                POLYGON_STAMPED,
                polygon_stamped(t, frame, predicted),
            )

    def _publish_state(self, d: Decision, t: int) -> None:
        prev, now = d.previous, d.action
        if prev.polygon:
            kind = f"collision_monitor_{prev.action_type}_end"
            self.publish(
                EVENTS_TOPIC, m.EVENT_TYPE, m.event(t, kind, self.name, prev.polygon, ACTION_CODES[prev.action_type])
            )
        if now.polygon:
            kind = f"collision_monitor_{now.action_type}"
            self.publish(
                EVENTS_TOPIC, m.EVENT_TYPE, m.event(t, kind, self.name, now.polygon, ACTION_CODES[now.action_type])
            )

    def _record(self, d: Decision, t: int) -> None:
        self._commands += 1
        self._last_t = t
        a = d.action
        if a.polygon:
            self._actions.setdefault(a.polygon, Counter())[a.action_type] += 1
        for ttc in d.collision_times.values():
            if ttc >= 0.0 and (self._min_ttc is None or ttc < self._min_ttc):
                self._min_ttc = ttc
        held = bool(a.polygon) and a.velocity.is_zero()
        if held and self._stopped_since is None:
            self._stopped_since = t
        elif not held and self._stopped_since is not None:
            self._stopped_ns += t - self._stopped_since
            self._stopped_since = None
        self.last_decision = d

    # ------------------------------------------------------------------ reports
    def skipped_counts(self) -> dict[str, int]:
        """Why sources, shapes or commands could not be used, with how often (sorted by reason)."""
        return dict(sorted(self.skipped.items()))

    def summary(self) -> dict[str, Any]:
        """Plain data: commands seen and published, actions per polygon, minimum predicted time to
        collision (s, None when no approach polygon predicted one), time held at zero by an action (s)."""
        stopped = self._stopped_ns + (self._last_t - self._stopped_since if self._stopped_since is not None else 0)
        return {
            "commands": self._commands,
            "published": self._published,
            "not_published": self._commands - self._published,
            "actions": {poly: dict(sorted(c.items())) for poly, c in sorted(self._actions.items())},
            "min_time_to_collision_s": self._min_ttc,
            "stopped_s": stopped / 1e9,
            "skipped": self.skipped_counts(),
        }
