"""The costmap node: Nav2's global costmap on the executor.

``CostmapNode`` subscribes to /map (static layer), the obstacle layers' source topics (LaserScan or
PointCloud2), /tf and /tf_static; it updates at ``update_frequency`` and publishes
/global_costmap/costmap (OccupancyGrid, Nav2's value mapping) and /global_costmap/published_footprint.
``costmap_msg`` and ``footprint_msg`` build the messages it publishes.
"""

from __future__ import annotations

import functools
import math
from typing import Any, Literal

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
from navlog.replay.nav2.planners import Pose2D
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.pointcloud import xyz
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TFBuffer, TransformError
from navlog.replay.scan_geometry import scan_fault

FLOAT32_MAX = 3.4028234663852886e38  # the largest finite float32 (a footprint's Point32 coordinates)


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
        self.tolerance_ns = int(round(params.transform_tolerance * 1e9))
        self.last_publish_ns: int | None = None
        self.last_map: OccupancyMap | None = None
        self.tf = TFBuffer(skipped=self.skipped)
        self.static_map = static_map
        self.map_topic = map_topic
        self.pending: dict[str, tuple[int, Any, ObservationSourceParams]] = {}  # source -> (stamp, msg, params)
        self.waiting: set[str] = set()  # the sources whose pending message waits for its transform
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
        for sname in sorted(self.waiting):
            self._unplaced(sname)
        self.pending = {}
        if self.robot is not None:
            self.costmap.update(*self.robot)

    def _on_source(self, topic: str, msg: Any, t: int) -> None:
        for sname, sp in self.source_topics[topic]:
            self._unplaced(sname)  # a message that waited for its transform, replaced before it came
            self.pending[sname] = (m.to_ns(msg.header.stamp), msg, sp)

    def _unplaced(self, sname: str) -> None:
        """The source's pending message leaves unused (replaced, cleared, the log's end): when it was waiting for
        its transform and the transform has still not come, it is counted as skipped (one whose transform came
        is superseded, as any message a newer one replaces before an update)."""
        if sname in self.waiting:
            self.waiting.discard(sname)
            stamp, msg, sp = self.pending[sname]
            frame = sp.sensor_frame or msg.header.frame_id
            try:
                self.tf.lookup(self.params.global_frame, frame, stamp)
            except TransformError:
                self._no_transform(sname, frame)

    def _no_transform(self, sname: str, frame: str) -> None:
        """Count a message of source ``sname`` skipped: no transform from its ``frame`` at its stamp."""
        self.skipped[f"{sname}: no transform {self.params.global_frame} <- {frame}"] += 1

    def finish(self) -> None:
        for sname in sorted(self.waiting):  # still waiting when the log ends
            self._unplaced(sname)

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

    def _observation(
        self, sname: str, stamp: int, msg: Any, sp: ObservationSourceParams, t: int
    ) -> Observation | Literal[False] | None:
        """The source's message as an observation in the global frame; None when it is skipped (counted); False
        when its transform is not there yet (a sample after its stamp has not come) and ``t`` is within the
        costmap's ``transform_tolerance`` of its stamp: it waits for the next update, as Nav2's message filter
        holds a message until its transform comes."""
        frame = sp.sensor_frame or msg.header.frame_id
        try:
            T = self.tf.lookup(self.params.global_frame, frame, stamp)
        except TransformError:
            latest = self.tf.latest_common_time(self.params.global_frame, frame)
            if latest is not None and latest < stamp <= t and t - stamp <= self.tolerance_ns:
                return False
            self._no_transform(sname, frame)
            return None
        if hasattr(msg, "ranges"):
            fault = scan_fault(msg)
            if fault is not None:
                self.skipped[f"{sname}: {fault}"] += 1
                return None
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
        far = robot is not None and not max(abs(robot[0]), abs(robot[1])) <= FLOAT32_MAX
        if far:  # its footprint (float32 points) cannot be written
            self.skipped["costmap update: robot pose beyond float32's range (+-3.4e38 m) in the TF tree"] += 1
            robot = None
        if robot is None:
            if self.costmap.params.rolling_window or self.costmap.obstacle_layers:
                if not far:
                    self.skipped[
                        f"costmap update: no transform {self.params.global_frame} <- {self.params.robot_base_frame}"
                    ] += 1
                if not self.costmap.static_layers:
                    return
            robot = (0.0, 0.0, 0.0) if self.robot is None else self.robot
            if self.costmap.params.rolling_window:
                return
        self.robot = robot
        waiting = {}
        for sname in sorted(self.pending):
            stamp, msg, sp = self.pending[sname]
            obs = self._observation(sname, stamp, msg, sp, t)
            if obs is False:
                waiting[sname] = self.pending[sname]
            elif obs is not None:
                self.costmap.add_observation(obs)
        self.pending = waiting
        self.waiting = set(waiting)
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
