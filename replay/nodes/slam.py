"""The 2D SLAM node: /scan + odometry TF -> /map, map -> odom, the pose graph and the trajectory
(slam_toolbox's role; the algorithm is ``navlog.replay.mapping.slam2d``).

Reads the scan topic, /tf (odom -> base: the robot's own, drifting odometry) and /tf_static (the
laser's mount). Transforms into the odom frame found in the log (a perfect localiser's map -> odom,
in navlog's logs recorded without ``--localization none``) are dropped and counted: this node
publishes that transform itself, and the log's would hand it the answer. Scans wait for their
odometry (``WaitingForTransforms``) up to ``transform_timeout`` of scan stamps, then are skipped
and counted.

Per scan: the odometry pose of ``base_frame`` at the scan's stamp and the laser's pose in it go to
``Slam2D.add_scan``; map -> odom is published on /tf, stamped with the scan, and for a scan that became a
keyframe the robot's pose in the map frame on ``pose_topic`` (slam_toolbox's ``pose``), with the covariance
of its step times ``position_covariance_scale`` and ``yaw_covariance_scale``. Every
``map_update_interval`` of sim time (and at the end) ``/map`` is the occupancy grid of the keyframes'
scans at their optimised poses. ``trajectory`` holds, at the end, the pose of ``trajectory_frame``
in the map frame at every scan, from the final keyframe poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from navlog.replay import messages
from navlog.replay.geometry import planar_matrix, quat_from_yaw, yaw_from_matrix
from navlog.replay.io import json_text
from navlog.replay.io.tum import write_poses
from navlog.replay.mapping.occupancy import MAX_COORDINATE, OccupancyParams
from navlog.replay.mapping.slam2d import LaserScan2D, Slam2D, SlamParams
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TFBuffer, TransformError, WaitingForTransforms
from navlog.replay.scan_geometry import ScanAngles

UNPLACED_LISTED = 5  # stretches placed by odometry alone named one by one in the skipped inputs


@dataclass(frozen=True)
class SlamNodeParams:
    scan_topic: str = "/scan"
    map_topic: str = "/map"
    pose_topic: str = "/pose"  # the robot's pose at every keyframe, with its covariance
    map_frame: str = "map"
    trajectory_frame: str = "base_link"  # whose map pose the trajectory holds ("" = the base frame)
    frame_prefix: str = ""  # stripped from every frame name (e.g. "simple_robot/")
    transform_timeout: float = 1.0  # s a scan waits for its odometry
    slam: SlamParams = field(default_factory=SlamParams)
    grid: OccupancyParams = field(default_factory=OccupancyParams)  # the map's update rules (resolution: slam's)


class SlamNode(Node):
    """slam_toolbox on the executor (see the module docstring)."""

    name = "slam"

    def __init__(self, params: SlamNodeParams) -> None:
        super().__init__()
        self.p = params
        self.slam = Slam2D(params.slam, replace(params.grid, resolution=params.slam.resolution))
        self.tf = TFBuffer(frame_prefix=params.frame_prefix, skipped=self.skipped)
        self.odom = self.tf.name(params.slam.odom_frame)
        self.tf_published = 0
        self._log_odom_parents = 0
        self._waiting = WaitingForTransforms(int(params.transform_timeout * 1e9))
        self._angles = ScanAngles()
        self._to_trajectory_frame: list[np.ndarray] = []  # per scan: base <- trajectory frame
        self._base: str | None = None

    # ------------------------------------------------------------ wiring
    def input_topics(self) -> list[str]:
        return [self.p.scan_topic, "/tf", "/tf_static"]

    def setup(self) -> None:
        self.subscribe("/tf", lambda m, t: self._on_tf(m, False), (messages.TF_MESSAGE,), light=True)
        self.subscribe("/tf_static", lambda m, t: self._on_tf(m, True), (messages.TF_MESSAGE,), light=True)
        self.subscribe(self.p.scan_topic, self._on_scan, (messages.LASER_SCAN,))
        self.create_timer(int(self.p.slam.map_update_interval * 1e9), self._publish_map)

    def _on_tf(self, msg: Any, static: bool) -> None:
        self._log_odom_parents += self.tf.add_message_skipping(msg, static, self.odom)
        self._drain()

    def _on_scan(self, msg: Any, t_ns: int) -> None:
        self._waiting.push(msg)
        self._drain()

    def _drain(self, final: bool = False) -> None:
        self._waiting.drain(
            self._transforms, lambda msg, stamp, tfs: self._process(msg, stamp, *tfs), self._no_odometry, final=final
        )

    @property
    def base(self) -> str:
        """``base_frame``, or base_link when no such frame hangs below the odometry frame (decided once
        either does: a /tf_static under base_link may come before the odometry's base_footprint)."""
        if self._base is None:
            want = self.tf.name(self.p.slam.base_frame)
            for candidate in (want, self.tf.name("base_link")):
                if candidate != self.odom and self.tf.connected(self.odom, candidate):
                    self._base = candidate
                    return candidate
            return want
        return self._base

    def _transforms(self, msg: Any, stamp: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(odom <- base at the scan's stamp, base <- laser, base <- trajectory frame)."""
        base = self.base
        odom_base = self.tf.lookup(self.odom, base, stamp)
        laser = self.tf.name(msg.header.frame_id)
        mount = self.tf.lookup(base, laser, None if self.tf.static_between(laser, base) else stamp)
        traj = self.tf.name(self.p.trajectory_frame) if self.p.trajectory_frame else base
        try:
            to_traj = self.tf.lookup(base, traj, None if self.tf.static_between(traj, base) else stamp)
        except TransformError:
            to_traj = np.eye(4)
        return odom_base, mount, to_traj

    def _no_odometry(self, msg: Any, stamp: int) -> None:
        self.skipped[
            f"{self.p.scan_topic}: no odometry ({self.odom} -> base) or laser transform at the scan's stamp"
        ] += 1

    # ------------------------------------------------------------ SLAM
    def _process(self, msg: Any, stamp: int, odom_base: np.ndarray, mount: np.ndarray, to_traj: np.ndarray) -> None:
        angles = self._angles(msg)
        if angles is None:
            self.skipped[f"{self.p.scan_topic}: {self._angles.fault}"] += 1
            return
        if not np.all(np.isfinite(odom_base)):
            self.skipped[f"{self.p.scan_topic}: odometry not finite at the scan's stamp"] += 1
            return
        if np.abs(odom_base[:2, 3]).max() > MAX_COORDINATE:  # the matcher's window would span it: no memory holds that
            self.skipped[f"{self.p.scan_topic}: odometry farther than {MAX_COORDINATE:g} m at the scan's stamp"] += 1
            return
        reach = self.p.slam.max_laser_range
        if not np.all(np.isfinite(mount)) or float(np.hypot(mount[0, 3], mount[1, 3])) > reach:
            self.skipped[
                f"{self.p.scan_topic}: laser mount ({msg.header.frame_id} in the base frame) not finite or farther than"
                f" slam.max_laser_range ({reach:g} m) from the base: check /tf_static"
            ] += 1
            return
        scan = LaserScan2D(
            angles, np.asarray(msg.ranges, dtype=np.float64), float(msg.range_min), float(msg.range_max), mount
        )
        odom = (float(odom_base[0, 3]), float(odom_base[1, 3]), yaw_from_matrix(odom_base))
        keyframes = len(self.slam.keyframes)
        pose = self.slam.add_scan(stamp, odom, scan)
        if pose is not None:
            self._to_trajectory_frame.append(to_traj)
        self._publish_tf(stamp)
        if pose is not None and len(self.slam.keyframes) > keyframes:
            self._publish_pose(stamp, pose, self.slam.keyframes[-1].covariance)

    def _publish_pose(self, stamp: int, pose: np.ndarray, cov: np.ndarray) -> None:
        scale = np.array([self.p.slam.position_covariance_scale] * 2 + [self.p.slam.yaw_covariance_scale])
        msg = messages.planar_pose_with_covariance(stamp, self.p.map_frame, pose, cov * np.sqrt(np.outer(scale, scale)))
        self.publish(self.p.pose_topic, messages.POSE_WITH_COVARIANCE_STAMPED, msg)

    def _publish_tf(self, stamp: int) -> None:
        m = self.slam.map_to_odom
        ts = messages.transform_stamped(
            stamp, self.p.map_frame, self.p.slam.odom_frame, (m[0, 3], m[1, 3], 0.0), quat_from_yaw(yaw_from_matrix(m))
        )
        self.publish("/tf", messages.TF_MESSAGE, messages.tf_message([ts]))
        self.tf_published += 1

    def _publish_map(self, t_ns: int, final: bool = False) -> None:
        if not self.slam.keyframes:
            return
        grid = self.slam.grid(final)
        if grid.logodds.size:
            self.publish(self.p.map_topic, messages.OCCUPANCY_GRID, grid.to_map(self.p.map_frame).to_msg(t_ns))

    def finish(self) -> None:
        self._drain(final=True)
        self._publish_map(self.now(), final=True)

    # ------------------------------------------------------------ results
    @property
    def grid(self):
        """The final occupancy grid (keyframe scans at their optimised poses)."""
        return self.slam.grid()

    @property
    def trajectory(self) -> list[tuple[int, np.ndarray]]:
        """(stamp, 4x4 map pose of the trajectory frame) at every scan, from the final keyframe poses."""
        stamps, poses = self.slam.trajectory()
        return [
            (t, planar_matrix(*pose) @ to_traj)
            for t, pose, to_traj in zip(stamps, poses.tolist(), self._to_trajectory_frame, strict=True)
        ]

    def pose_graph(self) -> dict[str, Any]:
        """The pose graph as plain data: keyframes (stamp, optimised pose), edges, and what SLAM did."""
        poses = self.slam.graph.poses()
        c = self.slam.counts
        return {
            "frame_id": self.p.map_frame,
            "counts": {
                "scans": c.scans,
                "keyframes": c.keyframes,
                "matched": c.matched,
                "matched_between": c.matched_between,
                "odometry_only": c.odometry_only,
                "loop_attempts": c.loop_attempts,
                "loops": c.loops,
                "loops_ambiguous": c.loops_ambiguous,
                "loops_inconsistent": c.loops_inconsistent,
                "global_searches": c.global_searches,
                "loops_global": c.loops_global,
                "loops_buffer": c.loops_buffer,
                "optimizations": self.slam.graph.optimizations,
                "odometry_jumps": len(c.odometry_jumps),
                "reversals_missed": len(c.reversals_missed),
                "reversals_inferred": len(c.reversals_inferred),
            },
            "odometry_jumps": [
                {"stamp_ns": t, "distance": d, "turn": a, "response": r} for t, d, a, r in c.odometry_jumps
            ],
            "reversals_missed": [
                {"stamp_ns": t, "odometry_forward": f, "scans_back": b} for t, f, b in c.reversals_missed
            ],
            "reversals_inferred": [
                {"stamp_ns": t, "read": "backwards" if d < 0 else "forwards"} for t, d in c.reversals_inferred
            ],
            "unplaced": [
                {"first": a, "last": b, "first_stamp_ns": ta, "last_stamp_ns": tb} for a, b, ta, tb in c.unplaced
            ],
            "nodes": [
                {"id": k.index, "stamp_ns": k.stamp, "x": p[0], "y": p[1], "yaw": p[2]}
                for k, p in zip(self.slam.keyframes, poses.tolist(), strict=True)
            ],
            "edges": [
                {
                    "source": e.source,
                    "target": e.target,
                    "kind": e.kind,
                    "x": e.relative[0],
                    "y": e.relative[1],
                    "yaw": e.relative[2],
                    "response": e.response,
                    **({"closed_by": e.closed_by} if e.kind == "loop" else {}),
                }
                for e in self.slam.graph.edges
            ],
        }

    def summary(self) -> str:
        """What the SLAM did, in one line: keyframes, how they were placed, loop closures and optimisations."""
        c = self.slam.counts
        refused = f"{c.loops_ambiguous} ambiguous, {c.loops_inconsistent} taken back"
        line = (
            f"{c.keyframes} keyframes of {c.scans} scans ({c.matched} matched, {c.odometry_only} by odometry alone);"
            f" {c.loops} loops closed in {c.loop_attempts + c.global_searches} searches ({refused},"
            f" {c.loops_global} global, {c.loops_buffer} by the running buffer); {self.slam.graph.optimizations}"
            " optimisations"
        )
        if c.odometry_jumps:
            line += f"; {len(c.odometry_jumps)} odometry jumps placed by the wider search"
        if c.unplaced:
            line += f"; {len(c.unplaced)} stretches not placed"
        if c.reversals_missed:
            line += f"; {len(c.reversals_missed)} steps back the odometry measured forward"
        backwards = sum(1 for _, d in c.reversals_inferred if d < 0)
        if backwards:
            line += f"; the odometry read backwards {backwards} times where the scans said the robot drove back"
        return line

    def skipped_counts(self) -> dict[str, int]:
        """Skipped inputs by reason."""
        out = dict(self.skipped)
        from_log = self._log_odom_parents - self.tf_published  # its own come back to it on /tf
        if from_log > 0:
            out[f"/tf: transforms into '{self.odom}' from the log (ignored: SLAM publishes its own)"] = from_log
        c = self.slam.counts
        if c.odometry_jumps:
            far = max(d for _, d, _, _ in c.odometry_jumps)
            turn = math.degrees(max(abs(a) for _, _, a, _ in c.odometry_jumps))
            out[
                f"{self.p.scan_topic}: odometry jumped (scan matched up to {far:.2f} m and {turn:.0f} deg from its"
                " prediction by the wider search; see pose_graph.json odometry_jumps)"
            ] = len(c.odometry_jumps)
        if c.reversals_missed:
            back = -min(b for _, _, b in c.reversals_missed)
            out[
                f"{self.p.scan_topic}: steps the odometry measured forward and the scans back (up to {back:.2f} m;"
                " does the odometry report driving backwards? see pose_graph.json reversals_missed)"
            ] = len(c.reversals_missed)
        for a, b, ta, tb in c.unplaced[:UNPLACED_LISTED]:
            out[
                f"{self.p.scan_topic}: keyframes {a}-{b} (stamps {ta / 1e9:.3f}-{tb / 1e9:.3f} s) placed by odometry"
                " alone: their scans matched nothing before them"
            ] = b - a + 1
        rest = c.unplaced[UNPLACED_LISTED:]
        if rest:
            out[
                f"{self.p.scan_topic}: keyframes placed by odometry alone in {len(rest)} more stretches"
                " (see pose_graph.json unplaced)"
            ] = sum(b - a + 1 for a, b, _, _ in rest)
        if c.off_map:
            out[f"{self.p.scan_topic}: keyframes left out of the map (pose or readings too far off for a grid)"] = len(
                c.off_map
            )
        if self.slam.counts.empty_scans:
            out[f"{self.p.scan_topic}: scans with no valid reading (not used)"] = self.slam.counts.empty_scans
        return out


def slam_node_params(slam: SlamParams, occupancy: Any) -> SlamNodeParams:
    """The node's parameters from the mapping pipeline's: topics, frames and grid rules of the occupancy
    mapper (``OccupancyMapperParams``), slam_toolbox's parameters for the rest."""
    return SlamNodeParams(
        scan_topic=occupancy.scan_topic,
        map_topic=occupancy.map_topic,
        map_frame=occupancy.map_frame,
        trajectory_frame=occupancy.base_frame,
        frame_prefix=occupancy.frame_prefix,
        transform_timeout=occupancy.transform_timeout,
        slam=slam,
        grid=occupancy.grid,
    )


def slam_artifacts(node: SlamNode, out: Path) -> dict[str, Path]:
    """trajectory.tum (the final poses at every scan) and pose_graph.json (keyframes and edges) in ``out``."""
    traj = node.trajectory
    graph = out / "pose_graph.json"
    graph.write_text(json_text.dumps(node.pose_graph(), indent=1, sort_keys=True) + "\n")
    return {
        "trajectory_tum": write_poses(out / "trajectory.tum", [t for t, _ in traj], [p for _, p in traj]),
        "pose_graph": graph,
    }
