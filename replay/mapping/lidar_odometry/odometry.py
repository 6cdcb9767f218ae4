"""``LidarOdometry``: one frame at a time, crop → deskew → downsample and register → update the maps."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import open3d as o3d

from navlog.replay.geometry import matrix_to_rotvec
from navlog.replay.mapping.lidar_odometry.deskew import ConstantVelocity, MotionPrior, deskew_points, relative_motion
from navlog.replay.mapping.lidar_odometry.local_map import GlobalMap, LocalMap
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.preprocess import downsample, valid_points
from navlog.replay.mapping.lidar_odometry.registration import Registrar


@dataclass
class FrameResult:
    stamp_ns: int
    pose: np.ndarray  # base_link in map, 4x4
    points_map: np.ndarray  # (N, 3) deskewed points of the frame in the map frame
    fitness: float
    rmse: float
    keyframe: bool
    velocity: np.ndarray  # (6,) body-frame linear and angular velocity (vx vy vz wx wy wz)


class _Threads:
    """Limit Open3D's threads for the duration of a call and restore the previous limit."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.prev = 0

    def __enter__(self) -> None:
        self.prev = o3d.utility.get_max_threads()
        if self.prev != self.n:
            o3d.utility.set_max_threads(self.n)

    def __exit__(self, *exc) -> None:
        if self.prev != self.n:
            o3d.utility.set_max_threads(self.prev)


class LidarOdometry:
    """Scan-to-local-map LiDAR odometry with deskew and a motion prior; see the package docstring."""

    def __init__(
        self,
        params: LidarOdometryParams | None = None,
        extrinsic: np.ndarray | None = None,
        initial_pose: np.ndarray | None = None,
    ) -> None:
        params = LidarOdometryParams() if params is None else params
        self.params = params
        self.extrinsic = np.eye(4) if extrinsic is None else np.asarray(extrinsic, dtype=np.float64)  # base <- sensor
        self.initial_pose = np.eye(4) if initial_pose is None else np.asarray(initial_pose, dtype=np.float64)
        self.stamps: list[int] = []
        self.trajectory: list[np.ndarray] = []
        self.skipped: dict[str, int] = {}
        self.local_map = LocalMap(params)
        self.global_store = GlobalMap(params.save_voxel, params.save_every_n_frames)
        self.registrar = Registrar(params)
        self._velocity = ConstantVelocity()
        self._ref: tuple[int, np.ndarray] | None = None  # (time, pose) of the last registration

    @property
    def registrations(self) -> int:
        """ICP registrations run so far (every frame but the first)."""
        return self.registrar.count

    @property
    def chunks(self) -> list[np.ndarray]:
        """The chunks of ``save_every_n_frames`` frames closed so far."""
        return self.global_store.chunks

    def _skip(self, reason: str) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + 1

    def _relative(self, t_ref_ns: int, query_ns: np.ndarray, prior: MotionPrior | None) -> np.ndarray:
        return relative_motion(t_ref_ns, query_ns, prior, self._velocity)

    # -------------------------------------------------- the algorithm
    def process(
        self, stamp_ns: int, points: np.ndarray, times: np.ndarray | None = None, prior: MotionPrior | None = None
    ) -> FrameResult | None:
        """Register one frame; returns None (and counts why) when the frame cannot be used.

        With deskew, the scan is registered at the middle of its sweep (so that an error of the
        velocity used for deskewing stretches the scan symmetrically instead of shifting it, which
        would feed back into the next velocity estimate); the reported pose is moved to the stamp.
        """
        p = self.params
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if times is not None:
            times = np.asarray(times, dtype=np.float64).reshape(-1)
            if len(times) != len(pts):
                self._skip("time_field_length_mismatch")
                return None
        # 1. preprocess: finite points within the range limits, in base_link
        keep = valid_points(pts, times, p.min_range, p.max_range)
        pts = pts[keep]
        if len(pts) < max(p.min_points, 1):
            self._skip("too_few_points")
            return None
        if self.stamps and stamp_ns <= self.stamps[-1]:
            self._skip("stamp_not_increasing")
            return None
        base = pts @ self.extrinsic[:3, :3].T + self.extrinsic[:3, 3]
        # 2. deskew into base_link at the middle of the sweep
        ref_ns = stamp_ns
        if p.deskew and times is not None:
            t = times[keep]
            ref_ns = stamp_ns + int(round(0.5 * (float(t.min()) + float(t.max())) * 1e9))
            base = deskew_points(base, t, stamp_ns, ref_ns, p.deskew_slots, prior, self._velocity)
        with _Threads(p.threads):
            # 3. register against the local map (the first frame defines it)
            pose, fitness, rmse = self._register(stamp_ns, ref_ns, base, prior)
            # 4. update the pose history and the maps
            return self._update(stamp_ns, ref_ns, pose, base, fitness, rmse, prior)

    def _register(
        self, stamp_ns: int, ref_ns: int, base: np.ndarray, prior: MotionPrior | None
    ) -> tuple[np.ndarray, float, float]:
        """The pose of base_link at ``ref_ns``, with ICP's fitness and RMSE; updates the constant velocity."""
        if self._ref is None:
            pose = self.initial_pose.copy()
            if ref_ns != stamp_ns:  # the initial pose is given at the stamp
                pose = pose @ self._relative(stamp_ns, np.array([ref_ns]), prior)[0]
            return pose, 1.0, 0.0
        last_ns, last = self._ref
        guess = last @ self._relative(last_ns, np.array([ref_ns]), prior)[0]
        result = self.registrar.register(downsample(base, self.params.scan_voxel), self.local_map.cloud, guess)
        if not result.accepted:
            self._skip("registration_rejected")
        pose = result.pose
        # constant-velocity model for the next frame, from the registration-time poses
        dt = (ref_ns - last_ns) * 1e-9
        rel = np.linalg.inv(last) @ pose
        self._velocity = ConstantVelocity(rel[:3, 3] / dt, matrix_to_rotvec(rel[:3, :3]) / dt)
        return pose, result.fitness, result.rmse

    def _update(
        self,
        stamp_ns: int,
        ref_ns: int,
        pose: np.ndarray,
        base: np.ndarray,
        fitness: float,
        rmse: float,
        prior: MotionPrior | None,
    ) -> FrameResult:
        self._ref = (ref_ns, pose)
        out = pose if ref_ns == stamp_ns else pose @ self._relative(ref_ns, np.array([stamp_ns]), prior)[0]
        self.stamps.append(int(stamp_ns))
        self.trajectory.append(out)
        points_map = base @ pose[:3, :3].T + pose[:3, 3]
        keyframe = self.local_map.update(pose, points_map)
        self.global_store.add(points_map)
        velocity = np.concatenate([self._velocity.v, self._velocity.w])
        return FrameResult(int(stamp_ns), out, points_map, fitness, rmse, keyframe, velocity)

    # -------------------------------------------------- results
    def global_map(self) -> np.ndarray:
        """(N, 3) every registered frame, voxel-filtered at ``save_voxel``, in a deterministic order."""
        with _Threads(self.params.threads):
            self.global_store.flush()
        return self.global_store.points()

    def finish_chunks(self) -> list[np.ndarray]:
        """The chunks of ``save_every_n_frames`` frames, the last partial one included."""
        with _Threads(self.params.threads):
            self.global_store.close_chunk()
        return list(self.global_store.chunks)

    def local_map_size(self) -> int:
        return len(self.local_map)

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps_ns (N,), poses (N, 4, 4))."""
        return np.asarray(self.stamps, dtype=np.int64), np.asarray(self.trajectory).reshape(-1, 4, 4)
