"""``LidarOdometry``: one frame at a time, crop → deskew → reduce (one point per ``save_voxel`` voxel)
→ downsample and register → update the maps."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from navlog.replay.geometry import matrix_to_rotvec, rotation_angle
from navlog.replay.mapping.background import Background, inline
from navlog.replay.mapping.lidar_odometry.deskew import (
    ConstantVelocity,
    MotionPrior,
    prior_motion,
    relative_motion,
    slot_query_ns,
    slot_times,
    sweep_span,
)
from navlog.replay.mapping.lidar_odometry.local_map import GlobalMap, LocalMap
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.preprocess import valid_points
from navlog.replay.mapping.lidar_odometry.sweep import PreparedSweep, SweepJob, prepare_sweep
from navlog.replay.mapping.lidar_odometry.voxel_map import GaussianLocalMap, GaussianRegistrar

if TYPE_CHECKING:
    from navlog.replay.mapping.lidar_odometry.registration import Registrar


@dataclass
class FrameResult:
    stamp_ns: int
    pose: np.ndarray  # base_link in map, 4x4
    points_base: np.ndarray | None  # (N, 3) deskewed points of the frame in base_link at the registration
    # time (None: not kept, see ``LidarOdometry.plan``)
    registered: np.ndarray  # 4x4: base_link in map at the registration time (the middle of the sweep)
    fitness: float
    rmse: float
    keyframe: bool
    velocity: np.ndarray  # (6,) body-frame linear and angular velocity (vx vy vz wx wy wz)

    @property
    def points_map(self) -> np.ndarray:
        """(N, 3) the deskewed points of the frame in the map frame (computed when asked: a sweep's
        worth of points is not moved for frames nobody publishes)."""
        if self.points_base is None:
            raise ValueError("the frame's points were not kept (planned with keep_base=False)")
        return self.points_base @ self.registered[:3, :3].T + self.registered[:3, 3]


@dataclass(frozen=True)
class SweepPlan:
    """A frame checked and its motions known (``LidarOdometry.plan``): the sweep's preparation (``job``)
    and the motions its registration needs. Completing it needs nothing more from the IMU and odometry
    tracks: a plan can be completed where they are not (``odometry_process``)."""

    stamp_ns: int
    ref_ns: int  # the registration time (the middle of the sweep when deskewed)
    job: SweepJob
    before: np.ndarray | None  # 4x4: base_link at the last registration time (first frame: the stamp) <- at ref
    after: np.ndarray | None  # 4x4: base_link at ref <- at the stamp (None: ref == stamp, or see below)
    # where the odometry track does not cover ref -> stamp, ``after`` is the constant velocity this frame's
    # registration gives, its rotation replaced by the gyro's (this, when the IMU covers it)
    after_rotation: np.ndarray | None = None


class Unsettled:
    """``LidarOdometry.plan``'s answer for a frame whose motion needs frames not yet completed."""


UNSETTLED = Unsettled()


class _Threads:
    """Limit Open3D's threads for the duration of a call and restore the previous limit."""

    def __init__(self, n: int, active: bool = True) -> None:
        self.n = n
        self.prev = n
        self.active = active  # setting the limit costs milliseconds: only around Open3D work

    def __enter__(self) -> None:
        if self.active:
            import open3d as o3d

            self.prev = o3d.utility.get_max_threads()
            if self.prev != self.n:
                o3d.utility.set_max_threads(self.n)

    def __exit__(self, *exc) -> None:
        if self.active and self.prev != self.n:
            import open3d as o3d

            o3d.utility.set_max_threads(self.prev)


class AdaptiveThreshold:
    """KISS-ICP's adaptive correspondence threshold: 3 sigma of the motion model's deviation from the
    registered poses, each deviation measured as the displacement it causes at ``max_range``
    (``2 r sin(angle / 2)`` plus the translation); frames moving less than ``min_motion`` add nothing.
    Until a deviation is measured the threshold is ``initial``; it stays within [``low``, ``high``]."""

    def __init__(self, initial: float, max_range: float, min_motion: float, low: float, high: float) -> None:
        self.initial, self.max_range, self.min_motion = initial, max_range, min_motion
        self.low, self.high = low, high
        self._sse = 0.0
        self._n = 0

    def update(self, deviation: np.ndarray, motion: np.ndarray) -> None:
        """Add the deviation (predicted pose^-1 @ registered pose) of a frame that made ``motion`` (4x4)."""
        if float(np.linalg.norm(motion[:3, 3])) < self.min_motion:
            return
        angle = rotation_angle(deviation[:3, :3])
        error = 2.0 * self.max_range * math.sin(0.5 * angle) + float(np.linalg.norm(deviation[:3, 3]))
        self._sse += error * error
        self._n += 1

    @property
    def value(self) -> float:
        if self._n == 0:
            return self.initial
        return min(max(3.0 * math.sqrt(self._sse / self._n), self.low), self.high)


class LidarOdometry:
    """Scan-to-local-map LiDAR odometry with deskew and a motion prior; see the package docstring."""

    def __init__(
        self,
        params: LidarOdometryParams | None = None,
        extrinsic: np.ndarray | None = None,
        initial_pose: np.ndarray | None = None,
        *,
        background: Background = inline,
    ) -> None:
        """``background`` runs the global map's batch updates (``GlobalMap``); the results do not depend on it."""
        params = LidarOdometryParams() if params is None else params
        self.params = params
        self.extrinsic = np.eye(4) if extrinsic is None else np.asarray(extrinsic, dtype=np.float64)  # base <- sensor
        self.initial_pose = np.eye(4) if initial_pose is None else np.asarray(initial_pose, dtype=np.float64)
        self.stamps: list[int] = []
        self.trajectory: list[np.ndarray] = []
        self.skipped: dict[str, int] = {}
        self.local_map: LocalMap | GaussianLocalMap
        self.registrar: Registrar | GaussianRegistrar
        if params.method == "vgicp":
            self.local_map, self.registrar = GaussianLocalMap(params), GaussianRegistrar(params)
        else:  # Open3D's ICP: Open3D and SciPy are loaded for these methods only
            from navlog.replay.mapping.lidar_odometry.registration import Registrar

            self.local_map, self.registrar = LocalMap(params), Registrar(params)
        self.global_store = GlobalMap(params.save_voxel, params.save_every_n_frames, background=background)
        self._velocity = ConstantVelocity()
        self.threshold = (
            AdaptiveThreshold(
                params.max_correspondence,
                params.max_range,
                params.min_motion,
                params.scan_voxel,
                3 * params.max_correspondence,
            )
            if params.adaptive_threshold
            else None
        )
        self._ref: tuple[int, np.ndarray] | None = None  # (time, pose) of the last registration
        self._planned: tuple[int, int] | None = None  # (stamp, registration time) of the last frame planned

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
        plan = self.plan(stamp_ns, points, times, prior)  # settled: never UNSETTLED
        if not isinstance(plan, SweepPlan):
            return None
        return self.complete(plan, prepare_sweep(plan.job))

    def plan(
        self,
        stamp_ns: int,
        points: np.ndarray,
        times: np.ndarray | None = None,
        prior: MotionPrior | None = None,
        *,
        settled: bool = True,
        keep_base: bool = True,
    ) -> SweepPlan | Unsettled | None:
        """The frame's checks and its motions; None (counted) when the frame cannot be used. Every plan
        returned must be completed (``complete``), in order. Without ``settled`` (frames planned and not
        yet completed), a frame whose motion needs the constant velocity (the odometry track does not
        cover it) is ``UNSETTLED``: nothing is counted, complete the frames before and plan it again. A
        settled plan takes those motions from the constant velocity as it is now (every frame planned
        before is completed)."""
        p = self.params
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if times is not None:
            times = np.asarray(times, dtype=np.float64).reshape(-1)
            if len(times) != len(pts):
                self._skip("time_field_length_mismatch")
                return None
        # 1. preprocess: finite points within the range limits
        keep = valid_points(pts, times, p.min_range, p.max_range)
        every = bool(keep.all())  # the usual sweep: nothing to copy out
        pts = pts if every else pts[keep]
        if len(pts) < max(p.min_points, 1):
            self._skip("too_few_points")
            return None
        if self._planned is not None and stamp_ns <= self._planned[0]:
            self._skip("stamp_not_increasing")
            return None
        # 2. deskew into base_link at the middle of the sweep
        ref_ns = stamp_ns
        t = None
        if p.deskew and times is not None:
            t = times if every else times[keep]
            span = sweep_span(t)
            ref_ns = stamp_ns + int(round(0.5 * (span[0] + span[1]) * 1e9))
            if self._planned is not None and ref_ns <= self._planned[1]:  # times that put this sweep before the last
                self._skip("sweep_time_not_increasing")
                return None
        last = self._planned[1] if self._planned is not None else None
        moved = ref_ns != stamp_ns
        # the motions over the sweep (deskew), back from the registration time to the stamp (after), and
        # to the registration time from the last one (the first frame: from its stamp)
        deskew = after = None
        if t is not None:
            slots = slot_query_ns(stamp_ns, slot_times(span, p.deskew_slots))
            rel = prior_motion(ref_ns, np.append(slots, stamp_ns), prior, None)  # one lookup for both
            if rel is not None:
                deskew, after = rel[:-1], (rel[-1] if moved else None)
            elif settled:  # the constant velocity over the sweep; back to the stamp when completed
                deskew = prior_motion(ref_ns, slots, prior, self._velocity)
            else:
                return UNSETTLED
        velocity = self._velocity if settled else None
        before = (
            self._motion(stamp_ns if last is None else last, ref_ns, prior, velocity)
            if last is not None or moved
            else None
        )
        after_rotation = None
        if after is None and moved:
            after = self._motion(ref_ns, stamp_ns, prior, None)  # the odometry track may reach the stamp alone
            if after is None and settled and prior is not None and prior.gyro is not None:
                rot = prior.gyro.relative_rotations(ref_ns, np.array([stamp_ns]))
                after_rotation = None if rot is None else rot[0]
        if not settled and ((before is None and (last is not None or moved)) or (after is None and moved)):
            return UNSETTLED
        self._planned = (stamp_ns, ref_ns)
        scan_voxel = p.scan_voxel if p.method == "vgicp" else 0.0
        job = SweepJob(pts, self.extrinsic.copy(), t, deskew, p.save_voxel, scan_voxel, keep_base)
        return SweepPlan(stamp_ns, ref_ns, job, before, after, after_rotation)

    @staticmethod
    def _motion(
        from_ns: int, to_ns: int, prior: MotionPrior | None, velocity: ConstantVelocity | None
    ) -> np.ndarray | None:
        """base_link at ``from_ns`` <- at ``to_ns`` from the prior (``velocity`` where the odometry track
        does not reach; without it, None there)."""
        rel = prior_motion(from_ns, np.array([to_ns]), prior, velocity)
        return None if rel is None else rel[0]

    def complete(self, plan: SweepPlan, prepared: PreparedSweep) -> FrameResult:
        """Register a planned frame from its prepared sweep and update the maps."""
        with _Threads(self.params.threads, self.params.method != "vgicp"):  # vgicp: Open3D is not called per frame
            # 3. register against the local map (the first frame defines it)
            pose, fitness, rmse, source = self._register(plan, prepared)
            # 4. update the pose history and the maps
            return self._update(plan, pose, prepared, source, fitness, rmse)

    def adopt(self, plan: SweepPlan, result: FrameResult, skipped: dict[str, int]) -> None:
        """Take ``plan``'s frame as completed by another ``LidarOdometry`` of the same parameters fed the
        same plans (``odometry_process``): the pose history, the constant velocity and the skips as
        ``complete`` leaves them; the maps stay with that one."""
        self._ref = (plan.ref_ns, result.registered)
        self.stamps.append(int(result.stamp_ns))
        self.trajectory.append(result.pose)
        self._velocity = ConstantVelocity(result.velocity[:3], result.velocity[3:])
        for reason, n in skipped.items():
            self.skipped[reason] = self.skipped.get(reason, 0) + n

    def _register(self, plan: SweepPlan, prepared: PreparedSweep) -> tuple[np.ndarray, float, float, Any]:
        """The pose of base_link at the registration time, with ICP's fitness and RMSE and the registered
        source cloud; updates the constant velocity."""
        stamp_ns, ref_ns = plan.stamp_ns, plan.ref_ns
        if prepared.scan is not None and isinstance(self.registrar, GaussianRegistrar):
            source = self.registrar.source_of_reduced(prepared.scan)
        else:
            source = self.registrar.source(prepared.fine)
        if self._ref is None:
            pose = self.initial_pose.copy()
            if ref_ns != stamp_ns:  # the initial pose is given at the stamp
                pose = pose @ self._before(plan)
            return pose, 1.0, 0.0, source
        last_ns, last = self._ref
        guess = last @ self._before(plan)
        distance = self.threshold.value if self.threshold is not None else None
        result = self.registrar.register(source, self.local_map.target, guess, distance)
        if not result.accepted:
            self._skip("registration_rejected")
        pose = result.pose
        if self.threshold is not None and result.accepted:
            self.threshold.update(np.linalg.inv(guess) @ pose, np.linalg.inv(last) @ pose)
        # constant-velocity model for the next frame, from the registration-time poses
        dt = (ref_ns - last_ns) * 1e-9
        rel = np.linalg.inv(last) @ pose
        self._velocity = ConstantVelocity(rel[:3, 3] / dt, matrix_to_rotvec(rel[:3, :3]) / dt)
        return pose, result.fitness, result.rmse, source

    @staticmethod
    def _before(plan: SweepPlan) -> np.ndarray:
        """base_link at the last registration time (the first frame: the stamp) <- at this one."""
        if plan.before is None:
            raise ValueError("a plan whose frame moved since the last registration has its motion (before)")
        return plan.before

    def _after(self, plan: SweepPlan) -> np.ndarray:
        """base_link at the registration time <- at the stamp: the plan's, else the constant velocity
        (just updated by this frame) with the gyro's rotation when the plan has it."""
        if plan.after is not None:
            return plan.after
        rel = self._relative(plan.ref_ns, np.array([plan.stamp_ns]), None)[0]
        if plan.after_rotation is not None:
            rel = rel.copy()
            rel[:3, :3] = plan.after_rotation
        return rel

    def _update(
        self,
        plan: SweepPlan,
        pose: np.ndarray,
        prepared: PreparedSweep,
        source: Any,
        fitness: float,
        rmse: float,
    ) -> FrameResult:
        stamp_ns, ref_ns, fine = plan.stamp_ns, plan.ref_ns, prepared.fine
        self._ref = (ref_ns, pose)
        out = pose if ref_ns == stamp_ns else pose @ self._after(plan)
        self.stamps.append(int(stamp_ns))
        self.trajectory.append(out)
        fine_map = fine @ pose[:3, :3].T + pose[:3, 3]
        if isinstance(self.local_map, GaussianLocalMap):
            keyframe = self.local_map.update(pose, source)
        else:
            keyframe = self.local_map.update(pose, fine_map)
        self.global_store.add(fine_map)
        velocity = np.concatenate([self._velocity.v, self._velocity.w])
        return FrameResult(int(stamp_ns), out, prepared.base, pose, fitness, rmse, keyframe, velocity)

    # -------------------------------------------------- results
    def global_map(self) -> np.ndarray:
        """(N, 3) every registered frame, voxel-filtered at ``save_voxel``, in a deterministic order."""
        self.global_store.flush()  # NumPy only: no Open3D thread limit to set
        return self.global_store.points()

    def finish_chunks(self) -> list[np.ndarray]:
        """The chunks of ``save_every_n_frames`` frames, the last partial one included."""
        with _Threads(self.params.threads, self.global_store.chunk_open):  # Open3D only for a chunk to close
            self.global_store.close_chunk()
        return list(self.global_store.chunks)

    def local_map_size(self) -> int:
        return len(self.local_map)

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps_ns (N,), poses (N, 4, 4))."""
        return np.asarray(self.stamps, dtype=np.int64), np.asarray(self.trajectory).reshape(-1, 4, 4)
