"""Navigation runs: what a ``navigate`` scenario adds to a recording.

- ``MapServerNode`` publishes the world's obstacles, grown by the scenario's ``map_margin``, on /map
  at t = 0 (latched), as map_server serves the Go2 setup's fixed map;
- ``navigation_pipeline`` builds the navigation pipeline (``navlog.replay.pipelines.navigation``)
  from the scenario's Nav2 file and goals, the run's seed, and any ``--set`` overrides: the same
  pipeline ``navlog replay --pipeline navigation`` runs on the log afterwards.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from navlog.recorder.robot import CMD_VEL_TOPIC, DEFAULT_ODOMETRY
from navlog.recorder.scenarios import ScenarioSpec, scenario_map
from navlog.recorder.world import World, occupancy
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.pipeline import Pipeline

MAP_TOPIC = "/map"
ONCE_NS = 10**18  # the period of a timer that fires once


class MapServerNode(Node):
    """Publishes one OccupancyGrid on /map at t = 0 (the topic is latched in the recorded QoS)."""

    name = "map_server"

    def __init__(self, grid: Any, topic: str = MAP_TOPIC) -> None:
        super().__init__()
        self.grid, self.topic = grid, topic

    def setup(self) -> None:
        self.create_timer(ONCE_NS, self._publish, start_ns=0)

    def _publish(self, t_ns: int) -> None:
        from navlog.replay import messages

        self.publish(self.topic, messages.OCCUPANCY_GRID, self.grid.to_msg(t_ns))


def world_map_node(scenario: ScenarioSpec, world: World) -> MapServerNode | None:
    """The map server of a navigate scenario with ``map: world`` (the world's obstacles grown by
    ``map_margin``) or ``map: FILE`` (that map_server map), else None."""
    if scenario.kind != "navigate" or scenario.map == "none":
        return None
    path = scenario_map(scenario)
    if path is not None:
        from navlog.replay.io.map_server import load_map

        return MapServerNode(load_map(path))
    return MapServerNode(occupancy(world, margin=scenario.map_margin))


def navigation_pipeline(
    scenario: ScenarioSpec,
    seed: int,
    nav2_params: str | Path | None = None,
    overrides: Sequence[str] = (),
    command_topic: str = CMD_VEL_TOPIC,
    odometry: tuple[str, str] | None = None,
) -> Pipeline:
    """The navigation pipeline of a navigate scenario (``nav2_params`` replaces the scenario's file); its
    commands go to ``command_topic``, the topic the robot drives on (a description file's drive plugin may
    name another than /cmd_vel, e.g. under a namespace); it reads the robot's ``odometry`` (topic, frame:
    ``navlog.replay.pipelines.navigation.with_odometry``), as a replay of the log does."""
    from navlog.replay.pipelines import pipeline_spec
    from navlog.replay.session import pipeline_params

    sets = [
        f"nav2_params={nav2_params or scenario.nav2_params}",
        f"goals={scenario.goals}",
        f"mode={scenario.navigation}",
        f"seed={seed}",
        *([f"output_topic={command_topic}"] if command_topic != CMD_VEL_TOPIC else []),
        *overrides,
    ]
    params = pipeline_params("navigation", None, overrides=sets)
    if odometry is not None:
        from navlog.replay.pipelines.navigation import with_odometry

        params = with_odometry(params, *odometry)
    return pipeline_spec("navigation").build(params, set())


def amcl_node(scenario: ScenarioSpec, world: World, seed: int, odometry: tuple[str, str] | None = None) -> Node:
    """Nav2's AMCL, live: the ``amcl`` block of the scenario's Nav2 file (Nav2's defaults without one) on the
    frame of the robot's ``odometry`` (when the file's ``odom_frame_id`` is Nav2's default ``odom``), the
    scenario's map file as its map (``map: FILE``; else the world's obstacles), the filter started at the scenario's start pose, its random numbers
    from the run's seed (the localization pipeline's stream: a replay with the same seed draws the same)."""
    from dataclasses import replace

    import numpy as np

    from navlog.replay.nav2 import default_nav2_params, load_nav2_params
    from navlog.replay.nav2.amcl import AmclParams
    from navlog.replay.nodes.amcl import AmclNode
    from navlog.replay.pipelines.safety import nav2_file

    nav2 = load_nav2_params(nav2_file(scenario.nav2_params)) if scenario.nav2_params else default_nav2_params()
    params = nav2.require_valid(["amcl"]).amcl or AmclParams()
    x, y, yaw = scenario.start
    params = replace(params, set_initial_pose=True, initial_pose_x=x, initial_pose_y=y, initial_pose_yaw=yaw)
    if odometry is not None and params.odom_frame_id == DEFAULT_ODOMETRY[1]:
        params = replace(params, odom_frame_id=odometry[1])
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    path = scenario_map(scenario)
    if path is not None:
        from navlog.replay.io.map_server import load_map

        return AmclNode(params, load_map(path), rng)
    return AmclNode(params, occupancy(world, margin=0.0), rng)


class AmclErrorNode(Node):
    """AMCL's error against the ground truth: after the run, every pose AMCL estimated (``AmclNode.trajectory``,
    one per scan it processed) against the true pose at the same stamp (interpolated between the two
    ground-truth messages around it)."""

    name = "amcl_error"

    def __init__(self, amcl: Any, ground_truth_topic: str) -> None:
        super().__init__()
        self.amcl, self.topic = amcl, ground_truth_topic
        self.truth: list[tuple[int, float, float, float]] = []

    def setup(self) -> None:
        self.subscribe(self.topic, self._on_truth)

    def _on_truth(self, msg: Any, t_ns: int) -> None:
        from navlog.replay.geometry import yaw_from_quat

        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        self.truth.append((stamp, p.x, p.y, yaw_from_quat((q.x, q.y, q.z, q.w))))

    def report(self) -> dict[str, float]:
        """poses; position error mean, RMS, max, final (m); yaw error mean and max (degrees)."""
        import numpy as np

        from navlog.replay.geometry import wrap_angles

        est = [(t, m[0, 3], m[1, 3], math.atan2(m[1, 0], m[0, 0])) for t, m in self.amcl.trajectory]
        if not est or len(self.truth) < 2:
            return {"poses": 0}
        truth = np.array(self.truth)
        e = np.array(est)
        e = e[(e[:, 0] >= truth[0, 0]) & (e[:, 0] <= truth[-1, 0])]
        x = np.interp(e[:, 0], truth[:, 0], truth[:, 1])
        y = np.interp(e[:, 0], truth[:, 0], truth[:, 2])
        yaw = np.interp(e[:, 0], truth[:, 0], np.unwrap(truth[:, 3]))
        d = np.hypot(e[:, 1] - x, e[:, 2] - y)
        dyaw = np.degrees(np.abs(wrap_angles(e[:, 3] - yaw)))
        return {
            "poses": len(d),
            "mean_m": float(d.mean()),
            "rms_m": float(np.sqrt(np.mean(d**2))),
            "max_m": float(d.max()),
            "final_m": float(d[-1]),
            "yaw_mean_deg": float(dyaw.mean()),
            "yaw_max_deg": float(dyaw.max()),
        }
