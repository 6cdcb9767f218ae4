"""The 3D odometry's frames completed in a child process, while the replay goes on.

``LidarOdometry.plan`` checks a frame and finds its motions in the IMU and odometry tracks; what is
left (``complete``: the sweep into base_link, deskewed and voxel-filtered, its covariances, the
registration against the local map, the maps' updates) needs only the plan and the frames completed
before it. ``OdometryWorker`` sends each plan to a child Python that holds a ``LidarOdometry`` of the
same parameters and completes the plans in the order sent; the replay takes each result back when it
needs it (``LidarOdometry.adopt`` keeps the pose history, the constant velocity and the skips beside
the plans) and the maps at the end. The child runs the same code on the same numbers as
``LidarOdometry.process`` in the replay's process: the same bits (tested).

The processes talk through ``navlog.replay.child`` (arrays as raw bytes, the rest as JSON).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.child import ChildProcess, pack, unpack
from navlog.replay.child import serve as serve_requests
from navlog.replay.mapping.lidar_odometry.odometry import FrameResult, LidarOdometry, SweepPlan
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.sweep_process import SweepJob, prepare_sweep

__all__ = ["OdometryWorker", "serve"]

_INIT, _FRAME, _MAPS = ord("I"), ord("F"), ord("M")
_CHILD = "from navlog.replay.mapping.lidar_odometry.odometry_process import serve; serve()"
NAME = "3D odometry process"


def plan_bytes(plan: SweepPlan) -> bytes:
    job = plan.job
    meta = [plan.stamp_ns, plan.ref_ns, job.save_voxel, job.scan_voxel, job.keep_base]
    arrays = [job.points, job.extrinsic, job.times, job.deskew, plan.before, plan.after, plan.after_rotation]
    return pack(meta, arrays)


def plan_from_bytes(body: bytes | bytearray) -> SweepPlan:
    (stamp_ns, ref_ns, save_voxel, scan_voxel, keep), arrays = unpack(body)
    points, extrinsic, times, deskew, before, after, after_rotation = arrays
    assert points is not None and extrinsic is not None
    job = SweepJob(points, extrinsic, times, deskew, save_voxel, scan_voxel, keep)
    return SweepPlan(stamp_ns, ref_ns, job, before, after, after_rotation)


def result_bytes(result: FrameResult, skipped: dict[str, int]) -> bytes:
    meta = [result.stamp_ns, result.fitness, result.rmse, result.keyframe, skipped]
    return pack(meta, [result.pose, result.points_base, result.registered, result.velocity])


def result_from_bytes(body: bytes | bytearray) -> tuple[FrameResult, dict[str, int]]:
    (stamp_ns, fitness, rmse, keyframe, skipped), (pose, base, registered, velocity) = unpack(body)
    assert pose is not None and registered is not None and velocity is not None
    return FrameResult(stamp_ns, pose, base, registered, fitness, rmse, keyframe, velocity), skipped


class OdometryWorker:
    """``LidarOdometry.complete`` for plans in order, in a child process (see the module docstring).
    Raises ``OSError`` when no child can be started."""

    def __init__(self, params: LidarOdometryParams, initial_pose: np.ndarray) -> None:
        self._child: ChildProcess | None = ChildProcess(NAME, _CHILD)
        self._child.ask(_INIT, pack(dataclasses.asdict(params), [np.asarray(initial_pose, dtype=np.float64)]))
        self._init_owed = True  # its (empty) reply is taken before the first result
        self._owed = 0  # plans submitted, results not yet taken

    def __len__(self) -> int:
        """Plans submitted whose results were not yet taken."""
        return self._owed

    def _reply(self) -> bytearray:
        if self._child is None:
            raise NavlogError(f"{NAME}: closed with frames still owed")
        if self._init_owed:
            self._child.reply()
            self._init_owed = False
        return self._child.reply()

    def submit(self, plan: SweepPlan) -> None:
        """Complete ``plan`` in the child (returns at once)."""
        if self._child is None:
            raise NavlogError(f"{NAME}: closed")
        self._child.ask(_FRAME, plan_bytes(plan))
        self._owed += 1

    def take(self) -> tuple[FrameResult, dict[str, int]]:
        """The oldest plan's result not yet taken, with the skips its completion counted (waits for it)."""
        if not self._owed:
            raise RuntimeError("no frame was submitted")
        self._owed -= 1
        return result_from_bytes(self._reply())

    def maps(self) -> tuple[np.ndarray, list[np.ndarray]]:
        """The global map and its chunks (``LidarOdometry.global_map``, ``finish_chunks``), after every
        result was taken."""
        if self._owed:
            raise RuntimeError("frames are still owed")
        if self._child is None:
            raise NavlogError(f"{NAME}: closed")
        self._child.ask(_MAPS)
        _, arrays = unpack(self._reply())
        points, *chunks = arrays
        assert points is not None
        return points, [c for c in chunks if c is not None]

    def close(self) -> None:
        """End the child (it exits when its input closes)."""
        if self._child is not None:
            self._child.close()
            self._child = None

    def __del__(self) -> None:
        self.close()


class _Completer:
    """The child's side: one ``LidarOdometry``, made by the first request."""

    def __init__(self) -> None:
        self.odometry: LidarOdometry | None = None

    def __call__(self, code: int, body: bytes | bytearray) -> tuple[int, bytes]:
        if code == _INIT:
            fields, (initial,) = unpack(body)
            self.odometry = LidarOdometry(LidarOdometryParams(**fields), None, initial)
            return code, b""
        odometry = self.odometry
        if odometry is None:
            raise ValueError("a frame before the odometry's parameters")
        if code == _FRAME:
            before = dict(odometry.skipped)
            plan = plan_from_bytes(body)
            result = odometry.complete(plan, prepare_sweep(plan.job))
            skipped = {k: n - before.get(k, 0) for k, n in odometry.skipped.items() if n != before.get(k, 0)}
            return code, result_bytes(result, skipped)
        if code == _MAPS:
            return code, pack(None, [odometry.global_map(), *odometry.finish_chunks()])
        raise ValueError(f"unknown request {code}")


def serve() -> None:
    """The child's loop (``navlog.replay.child.serve``) over the frames it is sent."""
    handler: Any = _Completer()
    serve_requests(handler)
