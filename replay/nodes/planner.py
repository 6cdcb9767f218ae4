"""Costmap and planner nodes: Nav2's global costmap and planner server on the executor.

``CostmapNode`` subscribes to /map (static layer), the obstacle layers' source topics (LaserScan or
PointCloud2), /tf and /tf_static; it updates at ``update_frequency`` and publishes
/global_costmap/costmap (OccupancyGrid, Nav2's value mapping) and /global_costmap/published_footprint.
``PlannerNode`` holds the goals (from /goal_pose or a goal list), plans from the robot pose (TF
global_frame <- robot_base_frame) every ``replan_period_s`` and publishes /plan (nav_msgs/Path).
When the log has robot TF (``wait_for_robot_tf``), planning waits for the transform, as scans do;
legs that never get a robot pose (the log ends first) are planned at the end as a chain from
``start``. Without any robot TF (a log with only a map), it plans the goal list as such a chain at
once. Either way each leg planned without a robot pose carries a note and is counted.
``costmap_msg``, ``footprint_msg`` and ``path_msg`` build the messages they publish.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from navlog.replay import messages as m
from navlog.replay.nav2.costmap import (
    Costmap2D,
    CostmapGrid,
    CostmapParams,
    Observation,
    ObservationSourceParams,
    occupancy_values,
    scan_points,
    scan_points_inf_valid,
    transform_footprint,
)
from navlog.replay.nav2.planners import Planner, PlanningError, PlanResult, Pose2D
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.pointcloud import xyz
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TFBuffer, TransformError


def _count(d: dict[str, int], key: str) -> None:
    d[key] = d.get(key, 0) + 1


class CostmapNode(Node):
    def __init__(
        self,
        params: CostmapParams,
        name: str = "global_costmap",
        static_map: OccupancyMap | None = None,
        map_topic: str = "/map",
        publish_period_s: float | None = None,
    ) -> None:
        """``publish_period_s``: publish the costmap at most that often (Nav2's 1 / publish_frequency);
        None publishes it at every update."""
        super().__init__()
        self.name = name
        self.params = params
        self.costmap = Costmap2D(params, name)
        self.publish_period_ns = None if publish_period_s is None else int(round(publish_period_s * 1e9))
        self.last_publish_ns: int | None = None
        self.last_map: OccupancyMap | None = None
        self.tf = TFBuffer()
        self.static_map = static_map
        self.map_topic = map_topic
        self.pending: dict[str, tuple[int, Any, ObservationSourceParams]] = {}  # source -> (stamp, msg, params)
        self.updates = 0
        self.robot: Pose2D | None = None
        self.source_topics: dict[str, list[tuple[str, ObservationSourceParams]]] = {}
        for layer in self.costmap.layers:
            for sname, sp in layer.observation_sources().items():
                topic = sp.topic if sp.topic.startswith("/") else "/" + sp.topic
                self.source_topics.setdefault(topic, []).append((sname, sp))

    @property
    def topics(self) -> list[str]:
        return sorted(self.source_topics)

    def setup(self) -> None:
        self.subscribe("/tf", lambda msg, t: self.tf.add_message(msg, static=False), (m.TF_MESSAGE,), light=True)
        self.subscribe("/tf_static", lambda msg, t: self.tf.add_message(msg, static=True), (m.TF_MESSAGE,), light=True)
        if self.costmap.static_layers:
            if self.static_map is not None:
                self.costmap.set_static_map(self.static_map)
            else:
                self.subscribe(self.map_topic, self._on_map, (m.OCCUPANCY_GRID,))
        for topic, sources in self.source_topics.items():
            types = tuple(
                sorted({m.LASER_SCAN if sp.data_type == "LaserScan" else m.POINT_CLOUD2 for _, sp in sources})
            )
            self.subscribe(topic, functools.partial(self._on_source, topic), types)
        period = int(round(1e9 / self.params.update_frequency))
        self.create_timer(period, self._update)

    def _on_map(self, msg: Any, t: int) -> None:
        self.last_map = OccupancyMap.from_msg(msg)
        self.costmap.set_static_map(self.last_map)

    def clear_entirely(self) -> None:
        """Nav2's ClearEntireCostmap: every layer forgets what it holds (a rolling window keeps its place);
        the costmap is then updated at once at the last robot pose -- in Nav2 the planner and controller
        wait for that update (the layers are not current until it)."""
        old = self.costmap
        self.costmap = Costmap2D(self.params, self.name)
        occ = self.static_map if self.static_map is not None else self.last_map
        if occ is not None and self.costmap.static_layers:
            self.costmap.set_static_map(occ)
        if self.params.rolling_window:
            self.costmap.update_origin(old.origin_x, old.origin_y)
        self.pending = {}
        if self.robot is not None:
            self.costmap.update(*self.robot)

    def _on_source(self, topic: str, msg: Any, t: int) -> None:
        for sname, sp in self.source_topics[topic]:
            self.pending[sname] = (m.to_ns(msg.header.stamp), msg, sp)

    def robot_pose(self, t: int) -> Pose2D | None:
        p = self.params
        try:
            T = self.tf.lookup(p.global_frame, p.robot_base_frame, t)
        except TransformError:
            try:  # latest available
                T = self.tf.lookup(p.global_frame, p.robot_base_frame, None)  # type: ignore[arg-type]
            except (TransformError, TypeError):
                return None
        return float(T[0, 3]), float(T[1, 3]), math.atan2(T[1, 0], T[0, 0])

    def _observation(self, sname: str, stamp: int, msg: Any, sp: ObservationSourceParams) -> Observation | None:
        frame = sp.sensor_frame or msg.header.frame_id
        try:
            T = self.tf.lookup(self.params.global_frame, frame, stamp)
        except TransformError:
            _count(self.skipped, f"{sname}: no transform {self.params.global_frame} <- {frame}")
            return None
        if hasattr(msg, "ranges"):
            pts = scan_points_inf_valid(msg) if sp.inf_is_valid else scan_points(msg)
        else:
            pts = xyz(msg)
        world = pts @ T[:3, :3].T + T[:3, 3]
        return Observation(origin=T[:3, 3].copy(), points=world, source=sname)

    def _update(self, t: int) -> None:
        if (
            self.costmap.static_layers
            and self.static_map is None
            and not any(layer.has_map for layer in self.costmap.static_layers)
        ):
            if not self.costmap.obstacle_layers:
                return
        robot = self.robot_pose(t)
        if robot is None:
            if self.costmap.params.rolling_window or self.costmap.obstacle_layers:
                _count(
                    self.skipped,
                    f"costmap update: no transform {self.params.global_frame} <- {self.params.robot_base_frame}",
                )
                if not self.costmap.static_layers:
                    return
            robot = (0.0, 0.0, 0.0) if self.robot is None else self.robot
            if self.costmap.params.rolling_window:
                return
        self.robot = robot
        for sname in sorted(self.pending):
            stamp, msg, sp = self.pending[sname]
            obs = self._observation(sname, stamp, msg, sp)
            if obs is not None:
                self.costmap.add_observation(obs)
        self.pending = {}
        self.costmap.update(*robot)
        self.updates += 1
        period = self.publish_period_ns
        # Nav2 publishes once more than a period has passed since the last publication
        if period is None or self.last_publish_ns is None or t - self.last_publish_ns > period:
            self.last_publish_ns = t
            self.publish(f"/{self.name}/costmap", m.OCCUPANCY_GRID, costmap_msg(self.costmap, t))
        self.publish(
            f"/{self.name}/published_footprint",
            "geometry_msgs/msg/PolygonStamped",
            footprint_msg(self.costmap, t, *robot),
        )


def costmap_msg(cm: CostmapGrid, ns: int, frame_id: str | None = None) -> Any:
    """nav_msgs/OccupancyGrid of a costmap with Nav2's value mapping (frame: the costmap's global frame)."""
    occ = OccupancyMap(
        data=occupancy_values(cm.costs),
        resolution=cm.resolution,
        origin=(cm.origin_x, cm.origin_y, 0.0),
        frame_id=frame_id or cm.params.global_frame,
    )
    return occ.to_msg(ns)


def footprint_msg(cm: CostmapGrid, ns: int, x: float, y: float, yaw: float) -> Any:
    """geometry_msgs/PolygonStamped of a costmap's padded footprint at a pose (global frame)."""
    poly = transform_footprint(cm.footprint, x, y, yaw)
    Point32 = m.msg_class("geometry_msgs/msg/Point32")
    Polygon = m.msg_class("geometry_msgs/msg/Polygon")
    return m.msg_class("geometry_msgs/msg/PolygonStamped")(
        header=m.header(ns, cm.params.global_frame),
        polygon=Polygon(points=[Point32(x=float(px), y=float(py), z=0.0) for px, py in poly]),
    )


def path_msg(plan: PlanResult | None, t: int, frame: str, xyyaw: np.ndarray | None = None) -> Any:
    """nav_msgs/Path of a plan's poses (or of ``xyyaw``, (N, 3) x, y, yaw) stamped ``t`` in ``frame``."""
    PoseStamped = m.msg_class(m.POSE_STAMPED)
    rows = xyyaw if xyyaw is not None else plan.poses if plan is not None else np.zeros((0, 3))
    poses = [
        PoseStamped(header=m.header(t, frame), pose=m.pose((x, y, 0.0), m.quat_from_yaw(yaw))) for x, y, yaw in rows
    ]
    return m.msg_class(m.PATH)(header=m.header(t, frame), poses=poses)


class PlannerNode(Node):
    name = "planner_server"

    def __init__(
        self,
        costmap_node: CostmapNode,
        planner: Planner,
        goals: list[Pose2D] | None = None,
        goal_frame: str = "map",
        replan_period_s: float = 1.0,
        goal_tolerance: float = 0.25,
        start: Pose2D = (0.0, 0.0, 0.0),
        goal_topic: str = "/goal_pose",
        wait_for_robot_tf: bool = False,
    ) -> None:
        super().__init__()
        self.cm_node = costmap_node
        self.planner = planner
        self.goals = list(goals or [])
        self.goal_frame = goal_frame
        self.period = int(round(replan_period_s * 1e9))
        self.goal_tolerance = goal_tolerance
        self.start = start
        self.goal_topic = goal_topic
        self.index = 0
        self.plans: list[tuple[int, PlanResult]] = []
        self.failures: list[tuple[int, str]] = []
        self.chained = False
        self.wait_for_robot_tf = wait_for_robot_tf
        self.had_robot_pose = False

    def setup(self) -> None:
        self.subscribe(self.goal_topic, self._on_goal, (m.POSE_STAMPED,))
        self.create_timer(self.period, self._tick)

    def _on_goal(self, msg: Any, t: int) -> None:
        q = msg.pose.orientation
        yaw = m.yaw_from_quat((q.x, q.y, q.z, q.w))
        self.goals = [(float(msg.pose.position.x), float(msg.pose.position.y), yaw)]
        self.goal_frame = msg.header.frame_id or self.cm_node.params.global_frame
        self.index = 0
        self._tick(t)

    def _goal_in_global(self, goal: Pose2D, t: int) -> Pose2D | None:
        frame = self.goal_frame.lstrip("/")
        gframe = self.cm_node.params.global_frame
        if frame == gframe:
            return goal
        try:
            T = self.cm_node.tf.lookup(gframe, frame, t)
        except TransformError:
            _count(self.skipped, f"goal in frame '{frame}': no transform to '{gframe}'")
            self.failures.append((t, f"goal in frame '{frame}' has no transform to '{gframe}'"))
            return None
        x, y = T[0, 0] * goal[0] + T[0, 1] * goal[1] + T[0, 3], T[1, 0] * goal[0] + T[1, 1] * goal[1] + T[1, 3]
        return x, y, goal[2] + math.atan2(T[1, 0], T[0, 0])

    def _plan(self, start: Pose2D, goal: Pose2D, t: int, note: str = "") -> None:
        try:
            plan = self.planner.plan(self.cm_node.costmap, start, goal)
        except PlanningError as exc:
            _count(self.skipped, "planning failed")
            self.failures.append((t, f"{note}: {exc}" if note else str(exc)))
            self.publish("/navlog/events", m.EVENT_TYPE, m.event(t, "plan_failed", self.name, str(exc)))
            return
        if note:
            plan.notes.append(note)
        self.plans.append((t, plan))
        self.publish("/plan", m.PATH, path_msg(plan, t, self.cm_node.params.global_frame))

    def _plan_chain(self, t: int) -> None:
        """Plan the goals not yet planned as a chain of legs from ``start``, each leg noted and counted."""
        self.chained = True
        p = self.cm_node.params
        prev = self.start
        for leg_goal in self.goals[self.index :]:
            g = self._goal_in_global(leg_goal, t)
            if g is None:
                return
            _count(self.skipped, f"legs planned without a robot pose ({p.global_frame} <- {p.robot_base_frame})")
            note = (
                f"no robot pose ({p.global_frame} <- {p.robot_base_frame}): leg planned from "
                f"({prev[0]:.2f}, {prev[1]:.2f})"
            )
            self._plan(prev, g, t, note)
            prev = g
        self.index = len(self.goals)

    def finish(self) -> None:
        # the log ended before the robot TF came: plan what is left from `start`, and say so
        if self.wait_for_robot_tf and not self.had_robot_pose and not self.chained and self.index < len(self.goals):
            if self.cm_node.updates:
                self._plan_chain(self.now())

    def _tick(self, t: int) -> None:
        if self.index >= len(self.goals) or self.cm_node.updates == 0:
            return
        robot = self.cm_node.robot_pose(t)
        if robot is None:
            if self.chained or self.had_robot_pose:
                return
            if self.wait_for_robot_tf:
                return  # the transform may still come (as scans wait for theirs)
            self._plan_chain(t)  # no robot TF in the log at all
            return
        self.had_robot_pose = True
        goal = self._goal_in_global(self.goals[self.index], t)
        if goal is None:
            return
        if math.hypot(robot[0] - goal[0], robot[1] - goal[1]) <= self.goal_tolerance:
            self.publish("/navlog/events", m.EVENT_TYPE, m.event(t, "goal_reached", self.name, "", self.index))
            self.index += 1
            if self.index >= len(self.goals):
                return
            goal = self._goal_in_global(self.goals[self.index], t)
            if goal is None:
                return
        self._plan(robot, goal, t)


def plan_lengths(plans: list[tuple[int, PlanResult]]) -> np.ndarray:
    return np.array([p.length for _, p in plans])
