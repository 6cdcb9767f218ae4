"""A safety-filter log with known geometry: a robot driven through Nav2's velocity smoother and
collision monitor (the KiBot parameters) at a box that steps away, then at a wall.

The robot (a diff drive integrating /cmd_vel every 50 ms from the origin of ``odom``, heading +x)
is asked for 0.45 m/s on /cmd_vel_nav with a slow weave (``wz = 0.15 sin(2 pi t / 4)``). A box
(x from BOX_X, |y| <= 1) stands in its way until BOX_GONE_S, a wall stands at WALL_X. Its 360-beam
scan in ``laser`` (0.1 m ahead of ``base_link``) sees both. The collision monitor has KiBot's
FootprintApproach (time_before_collision 1.2 s on the robot_radius 0.34 footprint) and, before it,
a stop polygon ``PolygonStop`` (0.5 m ahead of base_link); both with ``visualize: true``.

Expected: the approach slows the robot before the box, the stop polygon then stops it, the stop
ends when the box is gone, and the approach brings it to rest before the wall.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from navlog.replay import messages as m
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.collision_monitor import CollisionPolygonParams
from navlog.replay.nav2.costmap import robot_footprint
from navlog.replay.nodes import CollisionMonitorNode, VelocitySmootherNode
from navlog.replay.runtime.executor import Executor, Node
from tests.replay.pipelines.test_mapping_replay import scan_msg

KIBOT = Path(__file__).resolve().parents[2] / "replay" / "nav2" / "data" / "kibot_nav2_fragments.yaml"
MS = 1_000_000
BOX_X, BOX_GONE_S, WALL_X = 2.0, 6.0, 4.5  # odom frame
LASER_X = 0.1
STOP_POINTS = "[[0.5, 0.3], [0.5, -0.3], [-0.4, -0.3], [-0.4, 0.3]]"  # 4 vertices, Nav2's minimum


def wall_ranges(x: float, y: float, yaw: float, box: bool, beams: int = 360) -> np.ndarray:
    """Ranges of a 360-degree laser at (x, y, yaw) + LASER_X ahead to the box face and the wall (inf: nothing)."""
    lx, ly = x + LASER_X * math.cos(yaw), y + LASER_X * math.sin(yaw)
    a = yaw - math.pi + (2 * math.pi / beams) * np.arange(beams)
    c, s = np.cos(a), np.sin(a)
    r = np.full(beams, np.inf)
    faces = [(WALL_X, 1e9)] + ([(BOX_X, 1.0)] if box else [])
    with np.errstate(divide="ignore", invalid="ignore"):
        for fx, half in faces:
            d = np.where(c > 1e-9, (fx - lx) / c, np.inf)
            hit_y = ly + d * s
            r = np.where((d > 0) & (np.abs(hit_y) <= half), np.minimum(r, d), r)
    return np.where(r <= 6.0, r, np.inf).astype(np.float32)


class SafetyWorld(Node):
    """The robot, its controller's commands and its laser (see the module docstring)."""

    name = "safety_world"

    def __init__(self) -> None:
        super().__init__()
        self.pose = [0.0, 0.0, 0.0]
        self.cmd = (0.0, 0.0)

    def setup(self) -> None:
        self.subscribe("/cmd_vel", self._on_cmd)
        self.create_timer(50 * MS, self._tick, start_ns=0)

    def _on_cmd(self, msg, t: int) -> None:
        vx, _, wz = m.twist_values(msg)
        self.cmd = (vx, wz)

    def _tick(self, t: int) -> None:
        x, y, yaw = self.pose
        if t == 0:
            static = [
                m.transform_stamped(0, "map", "odom", (0.0, 0.0, 0.0), (0, 0, 0, 1)),
                m.transform_stamped(0, "base_link", "laser", (LASER_X, 0.0, 0.2), (0, 0, 0, 1)),
            ]
            self.publish("/tf_static", m.TF_MESSAGE, m.tf_message(static))
        else:
            vx, wz = self.cmd
            x, y, yaw = x + vx * 0.05 * math.cos(yaw), y + vx * 0.05 * math.sin(yaw), yaw + wz * 0.05
            self.pose = [x, y, yaw]
        q = m.quat_from_yaw(yaw)
        self.publish("/tf", m.TF_MESSAGE, m.tf_message([m.transform_stamped(t, "odom", "base_link", (x, y, 0.0), q)]))
        self.publish(
            "/odom", m.ODOMETRY, m.odometry(t, "odom", "base_link", (x, y, 0.0), q, (self.cmd[0], 0, 0), (0, 0, 0))
        )
        if t % (100 * MS) == 0:
            self.publish(
                "/scan", m.LASER_SCAN, scan_msg(t, wall_ranges(x, y, yaw, t < BOX_GONE_S * 1e9), rmin=0.12, rmax=6.0)
            )
        wz = 0.15 * math.sin(2 * math.pi * t / 4e9)
        self.publish("/cmd_vel_nav", m.TWIST, m.twist(0.45, 0.0, wz))


def safety_nodes() -> tuple[VelocitySmootherNode, CollisionMonitorNode]:
    """KiBot's smoother and collision monitor, with a stop polygon and ``visualize: true``."""
    p = load_nav2_params(KIBOT)
    cm = p.collision_monitor
    approach = dataclasses.replace(cm.polygon_params["FootprintApproach"], visualize=True)
    stop = CollisionPolygonParams(type="polygon", points=STOP_POINTS, action_type="stop", visualize=True)
    cm = dataclasses.replace(
        cm,
        polygons=("PolygonStop", "FootprintApproach"),
        polygon_params={"PolygonStop": stop, "FootprintApproach": approach},
    )
    return VelocitySmootherNode(p.velocity_smoother), CollisionMonitorNode(
        cm, footprint=robot_footprint(p.global_costmap)
    )


def write_safety_log(path: Path, seconds: float = 14.0) -> Path:
    """Run the world and the filters for ``seconds`` and record every message to ``path``."""
    smoother, monitor = safety_nodes()
    ex = Executor()
    ex.add_node(SafetyWorld(), source=True)
    ex.add_node(smoother)
    ex.add_node(monitor)
    with McapLogWriter(path, metadata={"navlog": {"world": "safety_box_wall", "robot": "kibot"}}) as writer:
        ex.add_sink(writer)
        ex.run(until_ns=int(seconds * 1e9))
        ex.finish()
    return path
