"""The 3D LiDAR mapper node (the FAST-LIO role) around ``LidarOdometry`` (``navlog.replay.mapping``).

Subscribes the LiDAR cloud, the IMU (gyro for deskew and the initial guess), the wheel/leg odometry
(optional translation prior) and /tf_static (the LiDAR and IMU mounts). A cloud is registered once
the IMU (and odometry, when used) has reached the end of its sweep, or when the next cloud arrives,
whichever is first, so the same message order always gives the same result. Publishes `/Odometry`
(map -> base_link, stamped at the cloud's header stamp), `/cloud_registered` (the deskewed frame in
`map`, every ``cloud_every_n_frames`` frames) and the path of all poses (every
``path_every_n_frames`` frames and at the end). Inputs that cannot be used are counted by reason.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navlog.replay import messages
from navlog.replay.geometry import make_transform, matrix_to_quat, quat_from_rpy
from navlog.replay.mapping.lidar_odometry.deskew import GyroTrack, MotionPrior, PoseTrack
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.pointcloud import read_points, xyz_cloud
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TFBuffer, TransformError


@dataclass(frozen=True)
class LidarMapperParams:
    lidar_topic: str = "/livox/lidar"
    imu_topic: str = "/imu/data"
    odom_topic: str = "/odom"
    tf_static_topic: str = "/tf_static"
    odometry_topic: str = "/Odometry"
    cloud_topic: str = "/cloud_registered"
    path_topic: str = "/lidar_mapper/path"
    map_frame: str = "map"
    base_frame: str = "base_link"
    time_field: str = "time"  # per-point time in seconds after the header stamp
    use_imu: bool = True
    use_odom: bool = True
    cloud_every_n_frames: int = 5  # 0: never publish /cloud_registered
    path_every_n_frames: int = 50  # 0: only at the end
    initial_pose: tuple[float, float, float, float, float, float] = (
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    )  # x y z roll pitch yaw
    odometry: LidarOdometryParams = field(default_factory=LidarOdometryParams)

    def __post_init__(self) -> None:
        if self.cloud_every_n_frames < 0 or self.path_every_n_frames < 0:
            raise ValueError("cloud_every_n_frames and path_every_n_frames must not be negative")


@dataclass
class _Pending:
    stamp_ns: int
    end_ns: int
    points: np.ndarray
    times: np.ndarray | None
    extrinsic: np.ndarray


class LidarMapperNode(Node):
    name = "lidar_mapper"

    def __init__(self, params: LidarMapperParams = LidarMapperParams()) -> None:
        super().__init__()
        self.params = params
        x, y, z, roll, pitch, yaw = params.initial_pose
        initial = make_transform((x, y, z), quat_from_rpy(roll, pitch, yaw))
        from navlog.replay.mapping.lidar_odometry.odometry import LidarOdometry  # Open3D: loaded when the mapper runs

        self.odometry = LidarOdometry(params.odometry, np.eye(4), initial)
        self.tf = TFBuffer()
        self.gyro = GyroTrack()
        self.odom = PoseTrack()
        self.skipped: dict[str, int] = {}
        self.frames_in = 0
        self._pending: list[_Pending] = []
        self._odom_fix: dict[str, np.ndarray] = {}  # odom child frame -> base_link
        self._mounts: dict[str, np.ndarray | None] = {}  # frame -> base_link <- frame, until /tf_static changes
        self._path_items: list = []  # PoseStamped of the poses published so far (poses never change)

    # ------------------------------------------------------------ wiring
    def setup(self) -> None:
        p = self.params
        self.subscribe(p.tf_static_topic, self._on_tf_static, (messages.TF_MESSAGE,))
        self.subscribe(p.lidar_topic, self._on_cloud, (messages.POINT_CLOUD2,))
        if p.use_imu:
            self.subscribe(p.imu_topic, self._on_imu, (messages.IMU,))
        if p.use_odom:
            self.subscribe(p.odom_topic, self._on_odom, (messages.ODOMETRY,))

    def _skip(self, reason: str) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + 1

    def skipped_counts(self) -> dict[str, int]:
        """Skipped inputs of the node and of the odometry, by reason, sorted by name."""
        out = dict(self.skipped)
        for k, v in self.odometry.skipped.items():
            out[k] = out.get(k, 0) + v
        if self.gyro.out_of_order:
            out["imu_out_of_order"] = self.gyro.out_of_order
        if self.odom.out_of_order:
            out["odom_out_of_order"] = self.odom.out_of_order
        return dict(sorted(out.items()))

    # ------------------------------------------------------------ callbacks
    def _on_tf_static(self, msg: Any, t_ns: int) -> None:
        self.tf.add_message(msg, static=True)
        self._mounts.clear()

    def _mount(self, frame: str) -> np.ndarray | None:
        """base_link <- ``frame`` from the static transforms, identity for base_link itself (read-only)."""
        if frame in self._mounts:
            return self._mounts[frame]
        mount: np.ndarray | None
        if not frame or frame.lstrip("/") == self.params.base_frame:
            mount = np.eye(4)
        else:
            try:
                mount = self.tf.lookup(self.params.base_frame, frame, None)
            except TransformError:
                mount = None
        if mount is not None:
            mount.flags.writeable = False
        self._mounts[frame] = mount
        return mount

    def _on_imu(self, msg: Any, t_ns: int) -> None:
        mount = self._mount(msg.header.frame_id)
        if mount is None:
            self._skip("imu_missing_extrinsic")
            return
        w = np.array([msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z], dtype=np.float64)
        if not np.isfinite(w).all():
            self._skip("imu_not_finite")
            return
        self.gyro.add(messages.to_ns(msg.header.stamp), mount[:3, :3] @ w)
        self._drain(force=False)

    def _on_odom(self, msg: Any, t_ns: int) -> None:
        child = msg.child_frame_id.lstrip("/")
        fix = self._odom_fix.get(child)
        if fix is None:
            try:  # odom child (base_footprint) <- base_link, from the static mounts
                fix = (
                    self.tf.lookup(child, self.params.base_frame, None)
                    if child and child != self.params.base_frame
                    else np.eye(4)
                )
            except TransformError:
                # not static (a walking body moves over its footprint): only the relative motion is
                # used, and for planar motion a vertical offset commutes with it, so identity is close
                self._skip("odom_base_transform_assumed_identity")
                fix = np.eye(4)
            self._odom_fix[child] = fix
        pp, q = msg.pose.pose.position, msg.pose.pose.orientation
        quat = (q.x, q.y, q.z, q.w)
        if not np.isfinite(quat).all() or not np.isfinite((pp.x, pp.y, pp.z)).all():  # (SciPy refuses NaN)
            self._skip("odom_not_finite")
            return
        if np.linalg.norm(quat) <= 1e-12:  # a zero quaternion: no orientation to normalise
            self._skip("odom_orientation_zero")
            return
        pose = make_transform((pp.x, pp.y, pp.z), (q.x, q.y, q.z, q.w)) @ fix
        if not np.isfinite(pose).all():
            self._skip("odom_not_finite")
            return
        self.odom.add(messages.to_ns(msg.header.stamp), pose)
        self._drain(force=False)

    def _on_cloud(self, msg: Any, t_ns: int) -> None:
        self.frames_in += 1
        stamp_ns = messages.to_ns(msg.header.stamp)
        try:
            arr = read_points(msg)
        except (ValueError, KeyError, TypeError):
            self._skip("cloud_unreadable")
            return
        names = arr.dtype.names or ()
        if not all(n in names for n in ("x", "y", "z")):
            self._skip("cloud_without_xyz")
            return
        if len(arr) == 0:
            self._skip("cloud_empty")
            return
        mount = self._mount(msg.header.frame_id)
        if mount is None:
            self._skip("cloud_missing_extrinsic")
            return
        pts = np.stack([arr["x"], arr["y"], arr["z"]], axis=1).astype(np.float64)
        times = np.asarray(arr[self.params.time_field], dtype=np.float64) if self.params.time_field in names else None
        finite = np.isfinite(pts).all(axis=1)
        if times is not None:
            finite &= np.isfinite(times)
        if not finite.all():
            self.skipped["points_not_finite"] = self.skipped.get("points_not_finite", 0) + int((~finite).sum())
            pts = pts[finite]
            times = times[finite] if times is not None else None
        if len(pts) == 0:
            self._skip("cloud_no_finite_points")
            return
        end_ns = stamp_ns + (int(round(float(times.max()) * 1e9)) if times is not None else 0)
        self._pending.append(_Pending(stamp_ns, end_ns, pts, times, mount))
        self._drain(force=False)

    # ------------------------------------------------------------ processing
    def _ready(self, item: _Pending) -> bool:
        for track in (self.gyro, self.odom):
            if track.last_ns is not None and track.last_ns < item.end_ns:
                return False
        return True

    def _drain(self, force: bool) -> None:
        while self._pending and (force or len(self._pending) > 1 or self._ready(self._pending[0])):
            self._process(self._pending.pop(0))

    def _process(self, item: _Pending) -> None:
        p = self.params
        self.odometry.extrinsic = item.extrinsic
        prior = MotionPrior(self.gyro if p.use_imu else None, self.odom if p.use_odom else None)
        result = self.odometry.process(item.stamp_ns, item.points, item.times, prior)
        if result is None:
            return
        n = len(self.odometry.stamps)
        xyz = result.pose[:3, 3]
        q = matrix_to_quat(result.pose[:3, :3])
        v = result.velocity
        odom = messages.odometry(item.stamp_ns, p.map_frame, p.base_frame, xyz, q, v[:3], v[3:])
        self.publish(p.odometry_topic, messages.ODOMETRY, odom)
        if p.cloud_every_n_frames and (n - 1) % p.cloud_every_n_frames == 0:
            self.publish(p.cloud_topic, messages.POINT_CLOUD2, xyz_cloud(item.stamp_ns, p.map_frame, result.points_map))
        if p.path_every_n_frames and n % p.path_every_n_frames == 0:
            self._publish_path()

    def _publish_path(self) -> None:
        stamps, poses = self.odometry.poses()
        if len(stamps) == 0:
            return
        frame = self.params.map_frame
        pose_stamped = messages.msg_class(messages.POSE_STAMPED)
        items = self._path_items  # built once per pose: a path message holds every pose so far
        items.extend(
            pose_stamped(header=messages.header(int(t), frame), pose=messages.pose(m[:3, 3], matrix_to_quat(m[:3, :3])))
            for t, m in zip(stamps[len(items) :], poses[len(items) :])
        )
        path = messages.msg_class(messages.PATH)(header=messages.header(int(stamps[-1]), frame), poses=list(items))
        self.publish(self.params.path_topic, messages.PATH, path)

    def finish(self) -> None:
        self._drain(force=True)
        self._publish_path()

    # ------------------------------------------------------------ results
    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps_ns (N,), poses (N, 4, 4)) of base_link in the map frame."""
        return self.odometry.poses()

    def map_points(self) -> np.ndarray:
        return self.odometry.global_map()

    def save_pcd(self, path: Path) -> dict[str, Path]:
        """Write the global map (binary float32 PCD, deterministic order) to ``path``, and the
        chunks of ``save_every_n_frames`` frames beside it as ``<stem>_<k>.pcd``; returns what was written."""
        from navlog.replay.io.pcd import write_pcd  # Open3D

        path = Path(path)
        written = {"map_pcd": path}
        write_pcd(path, self.odometry.global_map())
        for k, chunk in enumerate(self.odometry.finish_chunks(), start=1):
            chunk_path = path.with_name(f"{path.stem}_{k:04d}{path.suffix}")
            write_pcd(chunk_path, chunk)
            written[f"map_pcd_{k:04d}"] = chunk_path
        return written
