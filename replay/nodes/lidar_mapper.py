"""The 3D LiDAR mapper node (the FAST-LIO role) around ``LidarOdometry`` (``navlog.replay.mapping``).

Subscribes the LiDAR cloud, the IMU (gyro for deskew and the initial guess, accel for a
gravity-aligned map frame), the wheel/leg odometry (optional translation prior) and /tf_static (the
LiDAR and IMU mounts). The LiDAR mount is, in order: /tf_static; the ``mount`` parameter; identity,
with one warning, when no /tf_static arrived at all. Per-point times are read from the driver's
field (``time``, ``t``, ``timestamp``, ``offset_time``, ``time_offset``; see
``navlog.replay.pointcloud.point_times``); without one, the sweep is deskewed with the constant
velocity of the last two poses over per-point times from the azimuth (``deskew: motion``).
With ``preset: auto`` the odometry is sized from the first sweep (``lidar_odometry.params.for_sweep``).
A cloud is registered once the IMU (and odometry, when used) has reached the end of its sweep, or
when the next cloud arrives, whichever is first, so the same message order always gives the same result. Publishes `/Odometry`
(map -> base_link, stamped at the cloud's header stamp), `/cloud_registered` (the deskewed frame in
`map`, every ``cloud_every_n_frames`` frames) and the path of all poses (every
``path_every_n_frames`` frames and at the end). Inputs that cannot be used are counted by reason.

Frames completed in a child process: when no node reads those outputs and this process may use two
CPUs, the frames go through ``navlog.replay.workers.odometry.OdometryFrames`` offloaded: each is
planned here and completed in a child process while this one goes on with the log; its outputs take
their place in the order when it is accepted (``Node.defer``) and are filled in when it completes, so
the outputs are the same bytes in the same order as one frame after another here (tested).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from navlog.errors import ConfigError
from navlog.replay import messages
from navlog.replay.geometry import make_transform, matrix_to_quat, quat_from_rpy, quat_norm
from navlog.replay.io.cdr import GrowingSequence
from navlog.replay.mapping.lidar_odometry.deskew import GyroTrack, MotionPrior, PoseTrack
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams, Preset, for_sweep, preset
from navlog.replay.mapping.occupancy import MAX_COORDINATE
from navlog.replay.pointcloud import azimuth_times, point_times, read_points, time_field_name, xyz_cloud
from navlog.replay.runtime.cpus import usable_cpus
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TFBuffer, TransformError
from navlog.replay.workers.background import in_thread

if TYPE_CHECKING:
    from navlog.replay.mapping.lidar_odometry.odometry import FrameResult
    from navlog.replay.workers.odometry import OdometryFrames

logger = logging.getLogger("navlog")
Pose6 = tuple[float, float, float, float, float, float]  # x y z roll pitch yaw
_IN_FLIGHT = 4  # frames the child may be completing while this process plans the next ones
REST_ACCEL_SPREAD = 0.1  # m/s^2: the IMU is at rest when its accel samples spread less (std, all axes)


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
    time_field: str = "auto"  # the per-point time field; auto: the first of pointcloud.TIME_FIELDS present
    # auto: the time field when the cloud has one, else the motion model; time_field; motion; off
    deskew: Literal["auto", "time_field", "motion", "off"] = "auto"
    # motion deskew: the head's turn; auto: from the point order, else clockwise from behind
    spin: Literal["auto", "clockwise", "counterclockwise"] = "auto"
    mount: Pose6 | None = None  # base_link <- the cloud's frame when /tf_static has none
    preset: Preset = "auto"  # the odometry's starting point: auto (sized from the first sweep) | indoor | outdoor
    gravity_align: bool = True  # with an IMU and no initial pose: the map's z is up (first IMU accel averaged)
    use_imu: bool = True
    use_odom: bool = True
    cloud_every_n_frames: int = 5  # 0: never publish /cloud_registered
    path_every_n_frames: int = 50  # 0: only at the end
    initial_pose: Pose6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # x y z roll pitch yaw
    odometry: LidarOdometryParams = field(default_factory=LidarOdometryParams)

    def __post_init__(self) -> None:
        if self.cloud_every_n_frames < 0 or self.path_every_n_frames < 0:
            raise ValueError("cloud_every_n_frames and path_every_n_frames must not be negative")
        for name in ("mount", "initial_pose"):
            value = getattr(self, name)
            if value is not None and not np.isfinite(value).all():
                raise ValueError(f"{name} must be 6 finite numbers (x y z roll pitch yaw), got {value}")


def pose6_matrix(pose: Pose6) -> np.ndarray:
    """4x4 transform of (x, y, z, roll, pitch, yaw)."""
    x, y, z, roll, pitch, yaw = pose
    return make_transform((x, y, z), quat_from_rpy(roll, pitch, yaw))


def gravity_tilt(accel: np.ndarray) -> np.ndarray:
    """3x3 rotation (yaw 0) taking base_link to a frame whose z is up, from the mean specific force
    (N, 3) measured at rest in base_link (it points up)."""
    a = np.asarray(accel, dtype=np.float64).reshape(-1, 3).mean(axis=0)
    roll = float(np.arctan2(a[1], a[2]))
    pitch = float(np.arctan2(-a[0], np.hypot(a[1], a[2])))
    return pose6_matrix((0.0, 0.0, 0.0, roll, pitch, 0.0))[:3, :3]


@dataclass
class _Pending:
    stamp_ns: int
    end_ns: int
    points: np.ndarray
    times: np.ndarray | None
    extrinsic: np.ndarray


class LidarMapperNode(Node):
    name = "lidar_mapper"

    def __init__(self, params: LidarMapperParams = LidarMapperParams(), *, sweep_process: bool | None = None) -> None:
        """``sweep_process``: complete frames in a child process when no node reads the outputs (None:
        when this process may use two CPUs); see the module docstring."""
        super().__init__()
        self.params = params
        self._sweep_process = usable_cpus() > 1 if sweep_process is None else sweep_process
        self._frames: OdometryFrames | None = None  # made with the first frame (offloaded or not, decided then)
        odometry = preset(params.odometry, params.preset)
        if params.deskew == "off":
            odometry = replace(odometry, deskew=False)
        self._sized = params.preset != "auto"  # auto: sized from the first usable sweep
        from navlog.replay.mapping.lidar_odometry.odometry import LidarOdometry  # loaded when the mapper runs

        self.odometry = LidarOdometry(odometry, np.eye(4), pose6_matrix(params.initial_pose), background=in_thread)
        self.notes: dict[str, str] = {}  # what the node decided from the data, said once each (for the manifest)
        self._tf_static_seen = False
        self._accel: list[np.ndarray] = []  # IMU specific force in base_link, until the first frame is registered
        self._last_stamp: int | None = None  # of the last cloud, for the sweep period of motion deskew
        self.tf = TFBuffer(skipped=self.skipped)
        self.gyro = GyroTrack()
        self.odom = PoseTrack()
        self.frames_in = 0
        self._pending: list[_Pending] = []
        self._odom_fix: dict[str, np.ndarray] = {}  # odom child frame -> base_link
        self._mounts: dict[str, np.ndarray | None] = {}  # frame -> base_link <- frame, until /tf_static changes
        self._path = GrowingSequence(messages.PATH)  # the path's CDR: each pose encoded once (poses never change)

    # ------------------------------------------------------------ wiring
    def setup(self) -> None:
        p = self.params
        self.subscribe(p.tf_static_topic, self._on_tf_static, (messages.TF_MESSAGE,))
        self.subscribe(p.lidar_topic, self._on_cloud, (messages.POINT_CLOUD2,))
        if p.use_imu:
            self.subscribe(p.imu_topic, self._on_imu, (messages.IMU,))
        if p.use_odom:
            self.subscribe(p.odom_topic, self._on_odom, (messages.ODOMETRY,))

    def _skip(self, reason: str, n: int = 1) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + n

    def _note(self, key: str, text: str, warn: bool = False) -> None:
        """Record (and with ``warn`` log, once) a decision the node took from the data."""
        if key not in self.notes:
            self.notes[key] = text
            if warn:
                logger.warning("lidar_mapper: %s", text)

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
        self._tf_static_seen = True
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
        if self.params.gravity_align and not self.odometry.stamps and len(self._accel) < 200:
            a = msg.linear_acceleration
            acc = mount[:3, :3] @ np.array([a.x, a.y, a.z], dtype=np.float64)
            if np.isfinite(acc).all() and np.linalg.norm(acc) > 1.0:  # a driver without accel sends zeros
                self._accel.append(acc)
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
        norm = quat_norm(q.x, q.y, q.z, q.w)
        if norm == 0.0:  # a zero quaternion: no orientation to normalise
            self._skip("odom_orientation_zero")
            return
        if not norm < math.inf:  # no orientation: its norm does not square without overflow
            self._skip("odom_orientation_invalid")
            return
        pose = make_transform((pp.x, pp.y, pp.z), (q.x, q.y, q.z, q.w)) @ fix
        if not np.isfinite(pose).all():
            self._skip("odom_not_finite")
            return
        if np.abs(pose[:3, 3]).max() > MAX_COORDINATE:  # no robot drives that far: interpolating it overflows
            self._skip("odom_far")
            return
        self.odom.add(messages.to_ns(msg.header.stamp), pose)
        self._drain(force=False)

    def _on_cloud(self, msg: Any, t_ns: int) -> None:
        self.frames_in += 1
        if not messages.valid_stamp(msg.header.stamp):
            self._skip("cloud_stamp_invalid")  # nanosec of a second or more: not a time
            return
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
        mount = self._cloud_mount(msg.header.frame_id)
        if mount is None:
            self._skip("cloud_missing_extrinsic")
            return
        from navlog.replay.mapping.lidar_odometry.preprocess import finite_rows  # loaded with the odometry

        pts = np.empty((len(arr), 3))  # float64, filled field by field: one copy
        pts[:, 0], pts[:, 1], pts[:, 2] = arr["x"], arr["y"], arr["z"]
        times = self._times(arr, names, stamp_ns, pts)
        finite = finite_rows(pts)
        if not finite.all():
            self._skip("points_not_finite", int((~finite).sum()))
        if times is not None:
            bad = finite & ~np.isfinite(times)
            if bad.any():
                self._skip("points_time_invalid", int(bad.sum()))
            finite &= ~bad
        if not finite.all():
            pts = pts[finite]
            times = times[finite] if times is not None else None
        if len(pts) == 0:
            self._skip("cloud_no_finite_points")
            return
        end_ns = stamp_ns + (int(round(float(times.max()) * 1e9)) if times is not None else 0)
        self._pending.append(_Pending(stamp_ns, end_ns, pts, times, mount))
        self._drain(force=False)

    def _cloud_mount(self, frame: str) -> np.ndarray | None:
        """base_link <- the cloud's frame: /tf_static, else the ``mount`` parameter, else identity
        (one warning) when no /tf_static arrived; None (the cloud is skipped) otherwise."""
        mount = self._mount(frame)
        if mount is not None:
            return mount
        if self.params.mount is not None:
            return pose6_matrix(self.params.mount)
        if not self._tf_static_seen:
            self._note(
                "mount",
                f"no /tf_static and no lidar.mount for the cloud frame '{frame}': taking it as "
                f"{self.params.base_frame} (identity); give the mount with --set lidar.mount=[x,y,z,roll,pitch,yaw]",
                warn=True,
            )
            return np.eye(4)
        return None

    def _times(self, arr: np.ndarray, names: tuple[str, ...], stamp_ns: int, pts: np.ndarray) -> np.ndarray | None:
        """Per-point times in seconds after the stamp (NaN where invalid), or None for no deskew."""
        p = self.params
        period_s = 0.1 if self._last_stamp is None else (stamp_ns - self._last_stamp) * 1e-9
        self._last_stamp = stamp_ns
        if p.deskew == "off":
            return None
        name = time_field_name(names, p.time_field) if p.deskew != "motion" else None
        if name is not None:
            try:
                decoded = point_times(arr, name, stamp_ns)
            except ValueError:
                name = None
            else:
                self._note("time_field", f"per-point time from field '{name}' ({decoded.convention})")
                return decoded.seconds
        if p.deskew == "time_field":
            self._note(
                "time_field",
                f"no per-point time field ({p.time_field}) among {', '.join(names)}: not deskewed "
                "(set lidar.deskew=motion to deskew with the motion model)",
                warn=True,
            )
            return None
        if p.deskew == "auto":
            self._note(
                "time_field",
                f"no per-point time field among {', '.join(names)}: deskewing with the motion model "
                f"(constant velocity of the last two poses, times from the azimuth, head turn {p.spin}); "
                "set lidar.deskew=off to not deskew",
                warn=True,
            )
        sweep_s = min(max(period_s, 0.01), 0.5)  # the interval between clouds, within reason
        return azimuth_times(pts, sweep_s, clockwise=None if p.spin == "auto" else p.spin == "clockwise")

    # ------------------------------------------------------------ processing
    def _ready(self, item: _Pending) -> bool:
        for track in (self.gyro, self.odom):
            if track.last_ns is not None and track.last_ns < item.end_ns:
                return False
        return True

    def _drain(self, force: bool) -> None:
        while self._pending and (force or len(self._pending) > 1 or self._ready(self._pending[0])):
            self._process(self._pending.pop(0))

    def _first_frame(self, item: _Pending) -> None:
        """Before the first registration: size the odometry from the sweep (``preset: auto``) and
        level the map frame with the IMU's gravity (no initial pose given)."""
        from navlog.replay.mapping.lidar_odometry.odometry import LidarOdometry

        p = self.params
        odo = self.odometry
        params, initial = odo.params, odo.initial_pose
        if not self._sized:
            self._sized = True
            params = for_sweep(odo.params, np.linalg.norm(item.points, axis=1))
            size = "indoor" if params is odo.params else "outdoor"
            self._note(
                "preset",
                f"auto: {size} (max_range {params.max_range:g} m, scan voxel {params.scan_voxel:g} m"
                + (", adaptive threshold)" if params.adaptive_threshold else ")"),
            )
        if p.gravity_align and p.use_imu and self._accel and not any(p.initial_pose):
            acc = np.asarray(self._accel)
            spread = float(np.linalg.norm(acc.std(axis=0)))
            if spread <= REST_ACCEL_SPREAD:
                tilt = gravity_tilt(acc)
                initial = initial.copy()
                initial[:3, :3] = tilt
                angle = np.degrees(np.arccos(np.clip(tilt[2, 2], -1.0, 1.0)))
                self._note(
                    "gravity", f"map frame levelled with the IMU's gravity ({len(acc)} samples, tilt {angle:.2f} deg)"
                )
            else:  # a moving body's acceleration would tilt the map: the first base_link stays the map frame
                self._note(
                    "gravity",
                    f"map frame not levelled: the IMU was not at rest before the first sweep "
                    f"(accel spread {spread:.2f} m/s^2 over {len(acc)} samples)",
                )
        if params is not odo.params or initial is not odo.initial_pose:
            self.odometry = LidarOdometry(params, odo.extrinsic, initial, background=in_thread)
        self._accel = []

    def _process(self, item: _Pending) -> None:
        p = self.params
        if self._frames is None or not self._frames.frames:  # until a frame is accepted
            self._first_frame(item)
            if self._frames is None or self._frames.odometry is not self.odometry:  # sized or levelled anew
                if self._frames is not None:
                    self._frames.close()
                self._frames = self._start_frames()
        frames = self._frames
        self.odometry.extrinsic = item.extrinsic
        prior = MotionPrior(self.gyro if p.use_imu else None, self.odom if p.use_odom else None)
        n = frames.frames + 1  # this frame's number, if it is accepted
        keep = bool(p.cloud_every_n_frames) and (n - 1) % p.cloud_every_n_frames == 0
        frames.process(item.stamp_ns, item.points, item.times, prior, keep_base=keep, receiver=self._receiver)

    def _start_frames(self) -> OdometryFrames:
        """The frames completed here, or ahead in a child process when no node reads the outputs (they take
        their place when the frame is accepted and are filled in when it completes) and this process may
        use two CPUs."""
        from navlog.replay.workers.odometry import OdometryFrames

        p = self.params
        ahead = self._sweep_process and not self.executor.read_by_nodes([p.odometry_topic, p.cloud_topic, p.path_topic])
        return OdometryFrames(self.odometry, offload=ahead, in_flight=_IN_FLIGHT)

    def _receiver(self) -> Callable[[FrameResult], None]:
        """Where an accepted frame's outputs go: out now in this process, or into their place in the order
        (``Node.defer``) when the frame completes in the child."""
        assert self._frames is not None
        if not self._frames.offloaded:
            return lambda result: self._publish_frame(result, self.publish)
        place = self.defer()

        def fill(result: FrameResult) -> None:
            self._publish_frame(result, place.publish)
            place.close()

        return fill

    def _publish_frame(self, result: FrameResult, publish: Callable[[str, str, Any], None]) -> None:
        """/Odometry of a registered frame, and /cloud_registered and the path when due."""
        p = self.params
        n = len(self.odometry.stamps)
        xyz = result.pose[:3, 3]
        q = matrix_to_quat(result.pose[:3, :3])
        v = result.velocity
        odom = messages.odometry(result.stamp_ns, p.map_frame, p.base_frame, xyz, q, v[:3], v[3:])
        publish(p.odometry_topic, messages.ODOMETRY, odom)
        if p.cloud_every_n_frames and (n - 1) % p.cloud_every_n_frames == 0:
            publish(p.cloud_topic, messages.POINT_CLOUD2, xyz_cloud(result.stamp_ns, p.map_frame, result.points_map))
        if p.path_every_n_frames and n % p.path_every_n_frames == 0:
            self._publish_path(publish)

    def _publish_path(self, publish: Callable[[str, str, Any], None]) -> None:
        """The path of every pose so far. Its CDR grows by the poses added since the last one, each
        encoded once (the same bytes as the whole message's); a node reading the path gets the message."""
        stamps, poses = self.odometry.stamps, self.odometry.trajectory
        if not stamps:
            return
        path, frame = self._path, self.params.map_frame
        added = (
            (*divmod(t, 1_000_000_000), frame, *m[:3, 3], *matrix_to_quat(m[:3, :3]))
            for t, m in zip(stamps[len(path) :], poses[len(path) :])
        )
        msg: Any = path.encode((*divmod(stamps[-1], 1_000_000_000), frame), added)
        if self.executor.read_by_nodes([self.params.path_topic]):
            msg = messages.deserialize(msg, messages.PATH)
        publish(self.params.path_topic, messages.PATH, msg)

    def finish(self) -> None:
        self._drain(force=True)
        if self._frames is not None:
            self._frames.close()
        self._publish_path(self.publish)

    # ------------------------------------------------------------ results
    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps_ns (N,), poses (N, 4, 4)) of base_link in the map frame."""
        return self.odometry.poses()

    def map_points(self) -> np.ndarray:
        """The global map (``LidarOdometry.global_map``) of every frame so far, those in flight completed first."""
        return self._frames.global_map() if self._frames is not None else self.odometry.global_map()

    def _chunks(self) -> list[np.ndarray]:
        return self._frames.chunks() if self._frames is not None else self.odometry.finish_chunks()

    def save_pcd(self, path: Path) -> dict[str, Path]:
        """Write the global map (binary float32 PCD, deterministic order) to ``path``, and the
        chunks of ``save_every_n_frames`` frames beside it as ``<stem>_<k>.pcd``; returns what was written."""
        from navlog.replay.io.pcd import write_pcd

        path = Path(path)
        written = {"map_pcd": path}
        write_pcd(path, self.map_points())
        for k, chunk in enumerate(self._chunks(), start=1):
            chunk_path = path.with_name(f"{path.stem}_{k:04d}{path.suffix}")
            write_pcd(chunk_path, chunk)
            written[f"map_pcd_{k:04d}"] = chunk_path
        return written


# ---------------------------------------------------------------- before replaying: the log's LiDAR


def cloud_topics(topics: dict[str, str]) -> list[str]:
    """The PointCloud2 topics among ``topics`` (name -> type name), sorted."""
    return sorted(t for t, ty in topics.items() if ty == messages.POINT_CLOUD2)


def choose_lidar_topic(params: LidarMapperParams, topics: dict[str, str], choose: bool) -> str:
    """The LiDAR topic to read: the configured one when the log has it; with ``lidar_topic: auto``,
    or when ``choose`` and the configured one is absent, the log's only PointCloud2 topic (several:
    an error listing them). The configured name is returned unchanged when there is nothing to pick."""
    topic = params.lidar_topic
    if topic != "auto" and (topic in topics or not choose):
        return topic
    clouds = cloud_topics(topics)
    if len(clouds) > 1:
        raise ConfigError(
            f"the log has several PointCloud2 topics ({', '.join(clouds)}) and no {topic}: "
            f"choose the LiDAR with --set lidar.lidar_topic={clouds[0]}"
        )
    return clouds[0] if clouds else topic


def first_cloud_and_statics(reader: Any, cloud_topic: str, tf_static_topic: str) -> tuple[str | None, list[Any]]:
    """The frame of the first cloud on ``cloud_topic`` (log names) and the /tf_static messages
    before it; reads only up to that cloud and leaves the reader's counts as they were."""
    read, skipped = reader.report.read, reader.report.skipped.copy()
    frame: str | None = None
    statics: list[Any] = []
    try:
        for env in reader.messages([cloud_topic, tf_static_topic], decode=False):
            try:
                msg = messages.deserialize(env.msg, env.typename)
            except Exception:  # corrupt bytes: the replay counts them
                continue
            if env.topic == tf_static_topic:
                statics.append(msg)
            else:
                frame = msg.header.frame_id
                break
    finally:  # the replay reads these messages again, and counts what it skips then
        reader.report.read, reader.report.skipped = read, skipped
    return frame, statics


def mount_problem(params: LidarMapperParams, topic: str, frame: str | None, statics: list[Any]) -> str | None:
    """Why the cloud frame ``frame`` cannot be placed on the robot, or None: it is the base frame,
    /tf_static links it, ``mount`` gives it, or there is no /tf_static at all (identity, with a warning)."""
    base = params.base_frame
    if frame is None or frame.lstrip("/") in ("", base) or params.mount is not None or not statics:
        return None
    tf = TFBuffer()
    for msg in statics:
        tf.add_message(msg, static=True)
    try:
        tf.lookup(base, frame, None)
        return None
    except TransformError:
        pass
    known = sorted({f for msg in statics for t in msg.transforms for f in (t.header.frame_id, t.child_frame_id)})
    return (
        f"{topic}: the cloud frame '{frame}' has no transform to '{base}' in {params.tf_static_topic} "
        f"(its frames: {', '.join(known)}). Give the sensor mount ({base} <- {frame}, metres and radians) "
        f"with --set lidar.mount=[x,y,z,roll,pitch,yaw], or name the body frame with --set lidar.base_frame=FRAME"
    )


def settle_lidar(params: LidarMapperParams, reader: Any, log_to: dict[str, str], *, choose: bool) -> LidarMapperParams:
    """``params`` with the LiDAR topic decided from the log (``choose_lidar_topic``); raises
    ``ConfigError`` before replaying when the first cloud's frame cannot be placed (``mount_problem``)."""
    topics = {log_to.get(name, name): info.typename for name, info in reader.topics.items()}
    topic = choose_lidar_topic(params, topics, choose)
    if topics.get(topic) != messages.POINT_CLOUD2:
        return params
    to_log = {v: k for k, v in log_to.items()}
    frame, statics = first_cloud_and_statics(
        reader, to_log.get(topic, topic), to_log.get(params.tf_static_topic, params.tf_static_topic)
    )
    problem = mount_problem(params, topic, frame, statics)
    if problem is not None:
        raise ConfigError(problem)
    return replace(params, lidar_topic=topic)
