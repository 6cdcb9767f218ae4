"""The 2D occupancy mapper node: /scan + a pose source -> /map (nav_msgs/OccupancyGrid).

Pose sources (where the laser's pose at each scan's stamp comes from):
- ``ground_truth``: an Odometry topic giving the true base pose (``/odom/ground_truth``);
- ``odom``: the robot's own Odometry topic (``/odom``), which drifts;
- ``lidar_mapper``: the 3D mapper's ``/Odometry``;
- ``tf``: the TF tree from a fixed frame (``map``, else ``odom``) to the laser frame, as a real
  robot's bag provides it.
The chain from the pose's child frame to the laser frame always comes from /tf and /tf_static.
Readings with no return (``inf``, ``>= range_max``), too close, or NaN mark and clear nothing
(see ``navlog.replay.mapping.occupancy``) and are counted per kind among the skipped inputs.
A scan without a pose or transform at its stamp is skipped and counted; so are scans inserted
before the robot has moved ``minimum_travel_distance`` or turned ``minimum_travel_heading`` since
the last inserted one (slam_toolbox's throttle; 0 inserts every scan).

The scans go into the grid in a child process once it has started (``GridWorker``; on a machine with
one CPU, or with ``grid_process=False``, in this one): the node's thread goes on with the next messages
meanwhile. A scan's outcome (taken, or refused as far off) is collected with the next /map, in order,
and the trajectory and skip counts follow it; ``grid`` is the grid of every scan so far. When no node
reads /map, the node does not wait for the child's map either: it takes the map's place in the output
order (``Node.defer``) and fills it when the map has come: it looks at every scan, and waits for it
at the next /map at the latest, so what the other nodes publish meanwhile is held for a scan period
or so, not for a whole publish period.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from navlog.replay import messages
from navlog.replay.config import param
from navlog.replay.geometry import yaw_from_matrix
from navlog.replay.limits import MAX_PERIOD_S, MAX_TRANSFORM_TOLERANCE_S, MIN_MAP_PERIOD_S
from navlog.replay.mapping.occupancy import OccupancyGrid2D, OccupancyParams
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.runtime.cpus import usable_cpus
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TFBuffer, TransformError, WaitingForTransforms
from navlog.replay.scan_geometry import ScanAngles
from navlog.replay.workers.grid import GridWorker

PoseSource = Literal["ground_truth", "odom", "lidar_mapper", "tf"]


@dataclass(frozen=True)
class OccupancyMapperParams:
    pose_source: PoseSource = "ground_truth"
    scan_topic: str = "/scan"
    pose_topic: str = ""  # default by source: /odom/ground_truth, /odom, /Odometry
    map_topic: str = "/map"
    map_frame: str = "map"
    tf_fixed_frame: str = ""  # for pose_source tf: "" = map if the tree has it, else odom
    base_frame: str = "base_link"  # for pose_source tf: the robot frame whose path is the trajectory
    frame_prefix: str = ""  # stripped from every frame name (e.g. "simple_robot/")
    publish_period: float = param(
        2.0, ge=MIN_MAP_PERIOD_S, le=MAX_PERIOD_S
    )  # s between /map messages (and one at the end)
    transform_timeout: float = param(
        1.0, ge=0.0, le=MAX_TRANSFORM_TOLERANCE_S
    )  # s a scan waits for its pose (poses may arrive after the scan)
    minimum_travel_distance: float = param(0.1, ge=0.0)
    minimum_travel_heading: float = param(0.1, ge=0.0)
    grid: OccupancyParams = field(default_factory=OccupancyParams)


DEFAULT_POSE_TOPICS = {"ground_truth": "/odom/ground_truth", "odom": "/odom", "lidar_mapper": "/Odometry", "tf": ""}


class OccupancyMapperNode(Node):
    name = "occupancy_mapper"

    def __init__(self, params: OccupancyMapperParams, *, grid_process: bool | None = None) -> None:
        """``grid_process``: insert scans in a child process (None: when this process may use two CPUs)."""
        super().__init__()
        self.p = params
        self._grid_process = usable_cpus() > 1 if grid_process is None else grid_process
        self._updates = GridWorker(params.grid, spawn=False)  # started with the run (``setup``)
        self._final: OccupancyGrid2D | None = None  # the grid after ``finish``
        self._pending: list[tuple[int, np.ndarray]] = []  # (stamp, robot pose) of scans sent, outcome not known
        self.tf = TFBuffer(frame_prefix=params.frame_prefix, skipped=self.skipped)
        self.poses = TFBuffer(frame_prefix=params.frame_prefix, skipped=self.skipped, topic=self.pose_topic)
        self.trajectory: list[tuple[int, np.ndarray]] = []  # (stamp, robot pose in map) of inserted scans
        self._pose_child: str | None = None
        self._last_pose: np.ndarray | None = None
        self._angles = ScanAngles()
        self._waiting = WaitingForTransforms(int(params.transform_timeout * 1e9))  # scans waiting for their pose
        self._defer_maps: bool | None = None  # /map filled in later (no node reads it); decided at the first

    @property
    def pose_topic(self) -> str:
        """The topic the poses come from ("" for a pose source with none: tf, or a node's own such as slam)."""
        return self.p.pose_topic or DEFAULT_POSE_TOPICS.get(self.p.pose_source, "")

    def input_topics(self) -> list[str]:
        topics = [self.p.scan_topic, "/tf", "/tf_static"]
        if self.p.pose_source != "tf":
            topics.append(self.pose_topic)
        return topics

    @property
    def grid(self) -> OccupancyGrid2D:
        """The grid of every scan inserted so far."""
        return self._final if self._final is not None else self._updates.snapshot()

    def setup(self) -> None:
        if self._grid_process:
            self._updates = GridWorker(self.p.grid)
        self.subscribe("/tf", lambda m, t: self.tf.add_message(m), (messages.TF_MESSAGE,), light=True)
        self.subscribe(
            "/tf_static", lambda m, t: self.tf.add_message(m, static=True), (messages.TF_MESSAGE,), light=True
        )
        if self.p.pose_source != "tf":
            self.subscribe(self.pose_topic, self._on_pose, (messages.ODOMETRY,))
        self.subscribe(self.p.scan_topic, self._on_scan, (messages.LASER_SCAN,))
        self.create_timer(int(self.p.publish_period * 1e9), self._publish)

    def _on_pose(self, msg, t_ns: int) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        child = msg.child_frame_id
        self._pose_child = self.poses.name(child)
        self.poses.add(
            "__pose_origin__", child, messages.to_ns(msg.header.stamp), (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)
        )
        self._drain(t_ns)

    def _poses(self, frame: str, stamp: int) -> tuple[np.ndarray, np.ndarray]:
        """(robot pose, sensor pose) in the map frame at ``stamp``."""
        if self.p.pose_source == "tf":
            fixed = self.p.tf_fixed_frame or ("map" if "map" in self.tf.frames() else "odom")
            sensor = self.tf.lookup(fixed, frame, stamp)
            base = self.tf.lookup(fixed, self.p.base_frame, stamp) if self.p.base_frame in self.tf.frames() else sensor
            return base, sensor
        if self._pose_child is None:
            raise TransformError(f"no pose on {self.pose_topic} yet")
        base = self.poses.lookup("__pose_origin__", self._pose_child, stamp)
        return base, base @ self.tf.lookup(
            self._pose_child, frame, None if self.tf.static_between(frame, self._pose_child) else stamp
        )

    def _on_scan(self, msg, t_ns: int) -> None:
        self._updates.poll()  # a /map the child has sent since: into its place (what waits behind it goes out)
        self._waiting.push(msg)
        self._drain(t_ns)

    def _drain(self, t_ns: int, final: bool = False) -> None:
        """Insert waiting scans whose pose is known; give up on those older than the timeout, or whose
        stamp the poses have passed without covering it."""
        self._waiting.drain(
            lambda msg, stamp: self._poses(msg.header.frame_id, stamp),
            lambda msg, stamp, poses: self._insert(msg, stamp, *poses),
            self._no_pose,
            final=final,
            hopeless=lambda stamp: self._pose_passed(stamp) is False,
        )

    def _no_pose(self, msg: Any, stamp: int) -> None:
        self.skipped[f"{self.p.scan_topic}: no pose or transform at the scan's stamp"] += 1

    def _pose_passed(self, stamp: int) -> bool | None:
        """False when poses newer than ``stamp`` exist but none cover it (it will never be known)."""
        if self.p.pose_source == "tf" or self._pose_child is None:
            return None
        span = self.poses.time_range(self._pose_child)
        if span is None:
            return None
        return None if span[1] < stamp else (span[0] <= stamp)

    def _insert(self, msg, stamp: int, base: np.ndarray, pose: np.ndarray) -> None:
        angles = self._angles(msg)
        if angles is None:
            self.skipped[f"{self.p.scan_topic}: {self._angles.fault}"] += 1
            return
        if not np.all(np.isfinite(pose)):
            self.skipped[f"{self.p.scan_topic}: pose not finite at the scan's stamp"] += 1
            return
        if self._last_pose is not None and self.p.minimum_travel_distance > 0:
            with np.errstate(over="ignore"):  # a pose far off (finite, but beyond 1e154 m) moved infinitely far
                moved = np.linalg.norm(pose[:2, 3] - self._last_pose[:2, 3])
            turned = abs(yaw_from_matrix(pose) - yaw_from_matrix(self._last_pose))
            turned = min(turned, 2 * math.pi - turned)
            if moved < self.p.minimum_travel_distance and turned < self.p.minimum_travel_heading:
                self.skipped["scans within minimum travel (not inserted)"] += 1
                return
        self._last_pose = pose
        self._updates.insert_scan(pose, angles, np.asarray(msg.ranges), float(msg.range_min), float(msg.range_max))
        self._pending.append((stamp, base))

    def _settle(self) -> None:
        """The scans whose outcome has come (every scan's after a map or the final grid): into the
        trajectory if the grid took them, else counted."""
        outcomes = self._updates.outcomes(wait=False)
        for entry, taken in zip(self._pending[: len(outcomes)], outcomes, strict=True):
            if taken:
                self.trajectory.append(entry)
            else:
                self.skipped[
                    f"{self.p.scan_topic}: pose or ranges too far off (the map would exceed its cell budget)"
                ] += 1
        del self._pending[: len(outcomes)]

    def _publish(self, t_ns: int) -> None:
        """/map of every scan so far: at once, or, when no node reads /map and the grid is in the child,
        in its place once the child has sent it (the module docstring)."""
        if self._defer_maps is None:
            self._defer_maps = not self.executor.read_by_nodes([self.p.map_topic])
        later = self._defer_maps and self._updates.in_child
        if later:
            # the maps asked for before, into their places: waited for now if the child has not sent them
            # yet (it may be busy, e.g. loading its compiled kernel), so that what the other nodes publish
            # meanwhile is held behind one map at most
            self._updates.poll(at_most=0)
        place = self.defer() if later else None
        publish = self.publish if place is None else place.publish

        def fill(grid_map: OccupancyMap | None) -> None:
            self._settle()  # the outcomes of the scans before this map came with it
            if grid_map is not None:
                publish(self.p.map_topic, messages.OCCUPANCY_GRID, grid_map.to_msg(t_ns))
            if place is not None:
                place.close()

        if later:
            self._updates.request_map(self.p.map_frame, fill)
        else:
            fill(self._updates.to_map(self.p.map_frame))

    def finish(self) -> None:
        self._drain(self.now(), final=True)
        self._publish(self.now())
        self._final = self._updates.snapshot()  # (every map asked for is filled in first)
        self._settle()
        self._updates.close()

    def skipped_counts(self) -> dict[str, int]:
        st = self.grid.stats
        out = dict(self.skipped)
        if st.nan:
            out[f"{self.p.scan_topic}: NaN ranges (skipped)"] = st.nan
        if st.no_return and not self.p.grid.no_return_ray_length:
            out[
                f"{self.p.scan_topic}: ranges with no return (inf or >= range_max; not used: "
                "set occupancy.grid.no_return_ray_length to clear along them)"
            ] = st.no_return
        if st.too_close:
            out[f"{self.p.scan_topic}: ranges too close (-inf or <= range_min; not used)"] = st.too_close
        return out
