"""The AMCL node: /scan + odometry TF + a map -> /amcl_pose, /particle_cloud and map -> odom, Nav2's ``amcl``.

Reads the scan topic (``/`` + ``scan_topic``), /tf and /tf_static (odom -> base and the laser's
mount) and /initialpose (geometry_msgs/PoseWithCovarianceStamped in the map frame: the filter
restarts from that Gaussian). Transforms into the odom frame (``odom_frame_id``) are dropped and
counted: a recorded map -> odom (a perfect localiser's, or another AMCL's) must not reach the TF
tree this node corrects, and its own map -> odom comes back to it on /tf.

Per scan, as ``nav2_amcl`` does: the odom -> base pose at the scan's stamp; the first scan after an
initial pose updates the filter at once; later scans update it only once odometry moved more than
``update_min_d`` in x or in y, or turned more than ``update_min_a`` (motion model, then sensor
model); every ``resample_interval``-th update resamples. After an update it publishes
``/particle_cloud`` (geometry_msgs/PoseArray), ``/amcl_pose`` (the estimate with its covariance,
stamped with the scan) and map -> odom on /tf (stamped scan + ``transform_tolerance``, as Nav2
future-dates it); between updates it re-sends map -> odom with the new stamp. Scans wait for their
odometry up to ``transform_timeout`` of scan stamps, then are skipped and counted, as are scans
before any initial pose.

``trajectory`` holds, for every scan processed, the pose of ``trajectory_frame`` (default the base
frame) in the map frame: the current map -> odom times odom -> that frame at the scan's stamp.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navlog.replay import messages
from navlog.replay.geometry import planar_matrix, quat_from_yaw, remainder_angle, yaw_from_matrix, yaw_from_quat
from navlog.replay.io import pose_cdr
from navlog.replay.messages import POSE_WITH_COVARIANCE_STAMPED
from navlog.replay.nav2.amcl import AmclParams, LikelihoodField, ParticleFilter, Scan
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TFBuffer, TransformError, WaitingForTransforms
from navlog.replay.scan_geometry import NOT_FINITE, ScanAngles

POSE_ARRAY = messages.POSE_ARRAY
# Nav2's initial covariance when the pose comes from parameters: 0.5 m in x and y, pi/12 in yaw
DEFAULT_INITIAL_COV = np.diag([0.25, 0.25, (math.pi / 12.0) ** 2])


def _planar(m: np.ndarray) -> np.ndarray:
    """(x, y, yaw) of a 4x4 transform."""
    return np.array([m[0, 3], m[1, 3], yaw_from_matrix(m)])


def covariance_3x3(cov36) -> np.ndarray:
    """The (x, y, yaw) block of a ROS pose covariance."""
    c = np.asarray(cov36, dtype=np.float64).reshape(6, 6)
    return c[np.ix_([0, 1, 5], [0, 1, 5])]


class AmclNode(Node):
    """Nav2's AMCL on the executor (see the module docstring)."""

    name = "amcl"

    def __init__(
        self,
        params: AmclParams,
        occ_map: OccupancyMap,
        rng: np.random.Generator,
        *,
        trajectory_frame: str = "",
        transform_timeout: float = 1.0,
        tf_topic: str = "/tf",
        initial_pose_topic: str = "",
    ) -> None:
        super().__init__()
        self.p = params
        self.map = occ_map
        self.filter = ParticleFilter(params, LikelihoodField(occ_map, params.laser_likelihood_max_dist), rng)
        self.tf = TFBuffer(skipped=self.skipped)
        self._angles = ScanAngles()
        self.base = self.tf.name(params.base_frame_id)
        self.odom = self.tf.name(params.odom_frame_id)
        self.global_frame = params.global_frame_id
        self.trajectory_frame = self.tf.name(trajectory_frame) if trajectory_frame else self.base
        self.scan_topic = "/" + params.scan_topic.lstrip("/")
        self.tf_topic = tf_topic
        self.initial_pose_topic = initial_pose_topic
        self._waiting = WaitingForTransforms(int(transform_timeout * 1e9))  # scans waiting for odometry
        self.trajectory: list[tuple[int, np.ndarray]] = []
        self.updates = 0
        self.resamples = 0
        self.initialised_ns: int | None = None
        self._pf_odom: np.ndarray | None = None  # odometry pose at the last filter update; None: next scan forces one
        self._resample_count = 0
        self._map_to_odom: np.ndarray | None = None
        self._odom_parents = 0  # transforms into the odom frame received (ours included)
        self.tf_published = 0
        if params.set_initial_pose:
            self.set_initial_pose((params.initial_pose_x, params.initial_pose_y, params.initial_pose_yaw))

    # ------------------------------------------------------------ wiring
    def input_topics(self) -> list[str]:
        return [self.scan_topic, "/tf", "/tf_static", "/initialpose"] + (
            [self.initial_pose_topic] if self.initial_pose_topic else []
        )

    def setup(self) -> None:
        self.subscribe("/tf", lambda m, t: self._on_tf(m, False), (messages.TF_MESSAGE,), light=True)
        self.subscribe("/tf_static", lambda m, t: self._on_tf(m, True), (messages.TF_MESSAGE,), light=True)
        self.subscribe("/initialpose", self._on_initial_pose, (POSE_WITH_COVARIANCE_STAMPED,))
        self.subscribe(self.scan_topic, self._on_scan, (messages.LASER_SCAN,))
        if self.initial_pose_topic:
            self.subscribe(self.initial_pose_topic, self._on_pose_source, (messages.ODOMETRY,))

    # ------------------------------------------------------------ inputs
    def _on_tf(self, msg: Any, static: bool) -> None:
        self._odom_parents += self.tf.add_message_skipping(msg, static, self.odom)
        self._drain()

    def set_initial_pose(self, pose, cov: np.ndarray | None = None) -> None:
        """Restart the filter around (x, y, yaw) in the map frame (covariance 3x3; Nav2's default if None)."""
        self.filter.init_gaussian(pose, DEFAULT_INITIAL_COV if cov is None else cov)
        self._pf_odom = None
        self._resample_count = 0
        self.initialised_ns = self.now() if self._executor is not None else 0

    def _on_initial_pose(self, msg: Any, t_ns: int) -> None:
        frame = msg.header.frame_id.lstrip("/")
        if frame and frame != self.global_frame:
            self.skipped[f"/initialpose: frame '{frame}' is not the global frame '{self.global_frame}' (ignored)"] += 1
            return
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        values = (p.x, p.y, q.x, q.y, q.z, q.w)
        if not all(math.isfinite(v) for v in values):
            self.skipped["/initialpose: NaN or infinite pose (ignored)"] += 1
            return
        cov = covariance_3x3(msg.pose.covariance)
        if not np.all(np.isfinite(cov)) or np.any(np.linalg.eigvalsh(cov) < -1e-12):
            self.skipped["/initialpose: covariance not finite or not positive semi-definite (ignored)"] += 1
            return
        self.set_initial_pose((p.x, p.y, yaw_from_quat((q.x, q.y, q.z, q.w))), cov)

    def _on_pose_source(self, msg: Any, t_ns: int) -> None:
        """The first pose on ``initial_pose_topic`` (an Odometry in the map frame) starts the filter."""
        if self.initialised_ns is not None:
            return
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        self.set_initial_pose((p.x, p.y, yaw_from_quat((q.x, q.y, q.z, q.w))))

    def _on_scan(self, msg: Any, t_ns: int) -> None:
        if self.initialised_ns is None:
            self.skipped[f"{self.scan_topic}: no initial pose yet (publish /initialpose or set_initial_pose)"] += 1
            return
        self._waiting.push(msg)
        self._drain()

    def _drain(self, final: bool = False) -> None:
        """Process waiting scans whose odometry is known; drop those older than the timeout."""
        self._waiting.drain(
            self._transforms, lambda msg, stamp, tfs: self._process(msg, stamp, *tfs), self._no_odometry, final=final
        )

    def _transforms(self, msg: Any, stamp: int) -> tuple[np.ndarray, np.ndarray]:
        """(odom <- base at the scan's stamp, base <- laser)."""
        odom_base = self.tf.lookup(self.odom, self.base, stamp)
        frame = self.tf.name(msg.header.frame_id)
        return odom_base, self.tf.lookup(self.base, frame, None if self.tf.static_between(frame, self.base) else stamp)

    def _no_odometry(self, msg: Any, stamp: int) -> None:
        self.skipped[f"{self.scan_topic}: no odometry or laser transform at the scan's stamp"] += 1

    # ------------------------------------------------------------ the filter
    def _process(self, msg: Any, stamp: int, odom_base: np.ndarray, laser: np.ndarray) -> None:
        angles = self._angles(msg)
        if angles is None or not (math.isfinite(msg.range_min) and math.isfinite(msg.range_max)):
            self.skipped[f"{self.scan_topic}: {self._angles.fault or NOT_FINITE}"] += 1
            return
        pose = _planar(odom_base)
        update = self._pf_odom is None
        if self._pf_odom is not None:
            dx, dy = pose[0] - self._pf_odom[0], pose[1] - self._pf_odom[1]
            da = remainder_angle(pose[2] - self._pf_odom[2])
            update = abs(dx) > self.p.update_min_d or abs(dy) > self.p.update_min_d or abs(da) > self.p.update_min_a
            if update:
                self.filter.motion_update(self._pf_odom, pose)
        if update:
            scan = Scan(
                np.asarray(msg.ranges, dtype=np.float64),
                angles,
                float(msg.range_min),
                float(msg.range_max),
            )
            self.filter.sensor_update(scan, _planar(laser))
            self._pf_odom = pose
            self.updates += 1
            self._resample_count += 1
            if self._resample_count % self.p.resample_interval == 0:
                self.filter.resample()
                self.resamples += 1
            self._publish_estimate(stamp, odom_base)
        elif self._map_to_odom is not None and self.p.tf_broadcast:
            self._publish_tf(stamp)
        if self._map_to_odom is not None:
            try:
                robot = self.tf.lookup(self.odom, self.trajectory_frame, stamp)
            except TransformError:
                robot = odom_base
            self.trajectory.append((stamp, self._map_to_odom @ robot))

    def _publish_estimate(self, stamp: int, odom_base: np.ndarray) -> None:
        est = self.filter.estimate()
        x, y, yaw = (float(v) for v in est.pose)
        self._map_to_odom = planar_matrix(x, y, yaw) @ np.linalg.inv(planar_matrix(*_planar(odom_base)))
        self.publish_cdr(
            "/particle_cloud", POSE_ARRAY, pose_cdr.pose_array(stamp, self.global_frame, self.filter.poses)
        )
        self.publish(
            "/amcl_pose",
            POSE_WITH_COVARIANCE_STAMPED,
            messages.planar_pose_with_covariance(stamp, self.global_frame, (x, y, yaw), est.covariance),
        )
        if self.p.tf_broadcast:
            self._publish_tf(stamp)

    def _publish_tf(self, stamp: int) -> None:
        assert self._map_to_odom is not None
        m = self._map_to_odom
        ts = messages.transform_stamped(
            stamp + int(self.p.transform_tolerance * 1e9),
            self.global_frame,
            self.p.odom_frame_id,
            (m[0, 3], m[1, 3], 0.0),
            quat_from_yaw(yaw_from_matrix(m)),
        )
        self.publish(self.tf_topic, messages.TF_MESSAGE, messages.tf_message([ts]))
        self.tf_published += 1

    def finish(self) -> None:
        self._drain(final=True)

    def skipped_counts(self) -> dict[str, int]:
        """Skipped inputs by reason."""
        out = dict(self.skipped)
        own = self.tf_published if self.tf_topic == "/tf" else 0
        if self._odom_parents > own:
            out[f"/tf: transforms into '{self.odom}' from the log (ignored: AMCL publishes its own)"] = (
                self._odom_parents - own
            )
        return out
