"""A sweep's preparation (sensor → base_link, deskew, voxel filters), here or in a child process.

``LidarOdometry`` registers one sweep after another, and each registration needs the last one's
pose: that chain cannot be split. What comes before it can: once the motion over a sweep is known
from the IMU and odometry tracks (``LidarOdometry.plan``), moving its points into base_link,
deskewing them and voxel-filtering them (``prepare_sweep``) needs nothing from earlier sweeps. A
``SweepJob`` holds what that takes; ``SweepWorker`` prepares jobs in a child Python (``serve``,
which imports NumPy, small_gicp and the filters only) while the caller registers the sweep before,
and gives the results back in the order submitted.

Until the child has started (an interpreter, NumPy and small_gicp: a few tenths of a second) jobs
are prepared in this process, and with ``spawn=False`` (one CPU), or when no child could be
started, they all are. Either way ``prepare_sweep`` runs on the same arrays, so the results are the
same bits (tested). The processes talk through ``navlog.replay.child``.
"""

from __future__ import annotations

import struct
from collections import deque
from dataclasses import dataclass

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.child import ChildProcess
from navlog.replay.child import serve as serve_requests
from navlog.replay.mapping.lidar_odometry.deskew import move_by_slot
from navlog.replay.mapping.lidar_odometry.preprocess import reduced

__all__ = ["PreparedSweep", "SweepJob", "SweepWorker", "prepare_sweep", "serve"]

_PREPARE = ord("J")
_JOB = struct.Struct("<IIBdd")  # points, deskew slots (0: not deskewed), keep base, save voxel, scan voxel
_SIZES = struct.Struct("<III")  # base (0 when not kept), fine and scan points
_CHILD = "from navlog.replay.mapping.lidar_odometry.sweep_process import serve; serve()"


@dataclass(frozen=True)
class SweepJob:
    """What a sweep's preparation needs: its valid points, the sensor mount, the motion to deskew by."""

    points: np.ndarray  # (N, 3) float64 in the sensor frame, finite and within the range limits
    extrinsic: np.ndarray  # 4x4 base_link <- sensor
    times: np.ndarray | None  # (N,) seconds after the stamp, when deskewed
    deskew: np.ndarray | None  # (K, 4, 4) base_link at the reference time <- base_link at each slot's time
    save_voxel: float  # the maps' voxel filter
    scan_voxel: float  # the registration's voxel filter on the result (0: the registrar filters its own)
    keep_base: bool  # give back the whole deskewed sweep (a frame published as a cloud)


@dataclass(frozen=True)
class PreparedSweep:
    base: np.ndarray | None  # (N, 3) the deskewed sweep in base_link (when kept)
    fine: np.ndarray  # (M, 3) one point per ``save_voxel`` voxel
    scan: np.ndarray | None  # (S, 3) one point per ``scan_voxel`` voxel of ``fine`` (when asked for)


def prepare_sweep(job: SweepJob) -> PreparedSweep:
    """The sweep in base_link (deskewed when the job says so), then its voxel filters."""
    e = job.extrinsic
    base = job.points @ e[:3, :3].T + e[:3, 3]
    if job.deskew is not None and job.times is not None:
        base = move_by_slot(base, job.times, job.deskew)
    fine = reduced(base, job.save_voxel)
    scan = reduced(fine, job.scan_voxel) if job.scan_voxel > 0 else None
    return PreparedSweep(base if job.keep_base else None, fine, scan)


def _job_bytes(job: SweepJob) -> bytes:
    deskew, times = job.deskew, job.times
    slots = 0 if deskew is None or times is None else len(deskew)
    parts = [
        _JOB.pack(len(job.points), slots, job.keep_base, job.save_voxel, job.scan_voxel),
        np.ascontiguousarray(job.extrinsic, dtype=np.float64).tobytes(),
        np.ascontiguousarray(job.points, dtype=np.float64).tobytes(),
    ]
    if deskew is not None and times is not None:
        parts += [np.ascontiguousarray(deskew, dtype=np.float64).tobytes(), times.astype(np.float64).tobytes()]
    return b"".join(parts)


def _job_from_bytes(body: bytes | bytearray) -> SweepJob:
    n, slots, keep, save_voxel, scan_voxel = _JOB.unpack_from(body)
    at = _JOB.size
    extrinsic = np.frombuffer(body, np.float64, 16, at).reshape(4, 4)
    points = np.frombuffer(body, np.float64, 3 * n, at + 128).reshape(n, 3)
    at += 128 + 24 * n
    deskew = times = None
    if slots:
        deskew = np.frombuffer(body, np.float64, 16 * slots, at).reshape(slots, 4, 4)
        times = np.frombuffer(body, np.float64, n, at + 128 * slots)
    return SweepJob(points, extrinsic, times, deskew, save_voxel, scan_voxel, bool(keep))


def _prepared_bytes(out: PreparedSweep) -> bytes:
    arrays = [a for a in (out.base, out.fine, out.scan) if a is not None]
    sizes = _SIZES.pack(*(0 if a is None else len(a) for a in (out.base, out.fine, out.scan)))
    return sizes + b"".join(np.ascontiguousarray(a, dtype=np.float64).tobytes() for a in arrays)


def _prepared_from_bytes(body: bytes | bytearray, job: SweepJob) -> PreparedSweep:
    n_base, n_fine, n_scan = _SIZES.unpack_from(body)

    def points(at: int, n: int) -> np.ndarray:
        return np.frombuffer(body, np.float64, 3 * n, at).reshape(n, 3)

    at = _SIZES.size
    base = points(at, n_base) if job.keep_base else None
    fine = points(at + 24 * n_base, n_fine)
    scan = points(at + 24 * (n_base + n_fine), n_scan) if job.scan_voxel > 0 else None
    return PreparedSweep(base, fine, scan)


class SweepWorker:
    """``prepare_sweep`` for jobs in order, in a child process once it has started (module docstring)."""

    def __init__(self, *, spawn: bool = True) -> None:
        self._child: ChildProcess | None = None
        # submitted, not yet taken: (job, its result when prepared here; None when the child has it)
        self._queue: deque[tuple[SweepJob, PreparedSweep | None]] = deque()
        if spawn:
            try:
                self._child = ChildProcess("3D sweep process", _CHILD)
            except OSError:  # no child here (a process limit, no interpreter to run): jobs run here
                self._child = None

    def __len__(self) -> int:
        """Jobs submitted and not yet taken."""
        return len(self._queue)

    def submit(self, job: SweepJob) -> None:
        """Prepare ``job``: in the child once it has started (returns at once), else here."""
        child = self._child
        if child is not None and child.process is not None and child.started():
            child.ask(_PREPARE, _job_bytes(job))
            self._queue.append((job, None))
        else:
            self._queue.append((job, prepare_sweep(job)))

    def take(self) -> PreparedSweep:
        """The result of the oldest job not yet taken (waits for the child)."""
        if not self._queue:
            raise RuntimeError("no sweep was submitted")
        job, done = self._queue.popleft()
        if done is not None:
            return done
        if self._child is None:
            raise NavlogError("3D sweep process: closed with sweeps still owed")
        return _prepared_from_bytes(self._child.reply(), job)

    def close(self) -> None:
        """End the child (it exits when its input closes)."""
        if self._child is not None:
            self._child.close()

    def __del__(self) -> None:
        self.close()


def _handle(code: int, body: bytes | bytearray) -> tuple[int, bytes]:
    if code != _PREPARE:
        raise ValueError(f"unknown request {code}")
    return code, _prepared_bytes(prepare_sweep(_job_from_bytes(body)))


def serve() -> None:
    """The child's loop (``navlog.replay.child.serve``) over the sweeps it is sent."""
    serve_requests(_handle)
