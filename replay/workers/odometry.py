"""The 3D odometry's frames, completed in this process or ahead in a child process while the replay goes on.

``OdometryFrames`` is what the 3D mapper node uses: ``process`` takes a frame (``LidarOdometry.process``'s
arguments) and hands its result, when there is one, to the receiver the caller gives for it. In this
process the frame is completed at once; offloaded, the frame is planned here and completed in the
child, at most ``in_flight`` frames ahead, and the receivers get the results in the order of the frames.

``LidarOdometry.plan`` checks a frame and finds its motions in the IMU and odometry tracks, and
``prepare_sweep`` moves the sweep into base_link, deskews and voxel-filters it; what is left
(``complete``: the scan's covariances, the registration against the local map, the maps' updates)
needs only the plan, the prepared sweep and the frames completed before it. ``OdometryWorker`` sends
each (plan, prepared sweep) to a child Python that holds a ``LidarOdometry`` of the same parameters
and completes them in the order sent; the replay takes each result back when it needs it
(``LidarOdometry.adopt`` keeps the pose history, the constant velocity and the skips beside the
plans) and the maps at the end. The child runs the same code on the same numbers as
``LidarOdometry.process`` in the replay's process: the same bits (tested).

The preparation stays with the replay: it is about as much work per frame as the rest of the
replay's thread, and the completion as much again, so the two processes keep two cores about equally
busy (on the 138 s mapping log, preparing in the child left the replay's thread waiting for it).

The processes talk through ``navlog.replay.workers.child`` (arrays as raw bytes, the rest as JSON).
"""

from __future__ import annotations

import dataclasses
from collections import deque
from collections.abc import Callable

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.mapping.lidar_odometry.deskew import MotionPrior
from navlog.replay.mapping.lidar_odometry.odometry import FrameResult, LidarOdometry, SweepPlan, Unsettled
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.sweep import PreparedSweep, SweepJob, prepare_sweep
from navlog.replay.workers.background import in_thread
from navlog.replay.workers.child import ChildProcess, pack, unpack
from navlog.replay.workers.child import serve as serve_requests

__all__ = ["OdometryFrames", "OdometryWorker", "serve"]

_INIT, _FRAME, _MAPS, _GLOBAL = ord("I"), ord("F"), ord("M"), ord("G")
_NO_POINTS, _NO_MOUNT = np.zeros((0, 3)), np.eye(4)
_CHILD = "from navlog.replay.workers.odometry import serve; serve()"
NAME = "3D odometry process"


def frame_bytes(plan: SweepPlan, prepared: PreparedSweep) -> bytes:
    """A plan and its prepared sweep (the plan's job is not sent: its sweep is ``prepared``)."""
    job = plan.job
    meta = [plan.stamp_ns, plan.ref_ns, job.save_voxel, job.scan_voxel, job.keep_base]
    return pack(meta, [prepared.base, prepared.fine, prepared.scan, plan.before, plan.after, plan.after_rotation])


def frame_from_bytes(body: bytes | bytearray) -> tuple[SweepPlan, PreparedSweep]:
    (stamp_ns, ref_ns, save_voxel, scan_voxel, keep), arrays = unpack(body)
    base, fine, scan, before, after, after_rotation = arrays
    assert fine is not None
    job = SweepJob(_NO_POINTS, _NO_MOUNT, None, None, save_voxel, scan_voxel, keep)  # its sweep came prepared
    return SweepPlan(stamp_ns, ref_ns, job, before, after, after_rotation), PreparedSweep(base, fine, scan)


def result_bytes(result: FrameResult, skipped: dict[str, int]) -> bytes:
    meta = [result.stamp_ns, result.fitness, result.rmse, result.keyframe, skipped]
    return pack(meta, [result.pose, result.points_base, result.registered, result.velocity])


def result_from_bytes(body: bytes | bytearray) -> tuple[FrameResult, dict[str, int]]:
    (stamp_ns, fitness, rmse, keyframe, skipped), (pose, base, registered, velocity) = unpack(body)
    assert pose is not None and registered is not None and velocity is not None
    # the poses are kept (the trajectory): copies, not views that would keep the whole reply alive
    return FrameResult(
        stamp_ns, pose.copy(), base, registered.copy(), fitness, rmse, keyframe, velocity.copy()
    ), skipped


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

    def submit(self, plan: SweepPlan, prepared: PreparedSweep) -> None:
        """Complete ``plan`` from its ``prepared`` sweep in the child (returns at once)."""
        if self._child is None:
            raise NavlogError(f"{NAME}: closed")
        self._child.ask(_FRAME, frame_bytes(plan, prepared))
        self._owed += 1

    def take(self) -> tuple[FrameResult, dict[str, int]]:
        """The oldest plan's result not yet taken, with the skips its completion counted (waits for it)."""
        if not self._owed:
            raise RuntimeError("no frame was submitted")
        self._owed -= 1
        return result_from_bytes(self._reply())

    def maps(self) -> tuple[np.ndarray, list[np.ndarray]]:
        """The global map and its chunks (``LidarOdometry.global_map``, ``finish_chunks``: the last
        chunk is closed), after every result was taken."""
        points, *chunks = self._ask_maps(_MAPS)
        return points, chunks

    def global_map(self) -> np.ndarray:
        """The global map so far (``LidarOdometry.global_map``), after every result was taken; the
        frames go on."""
        return self._ask_maps(_GLOBAL)[0]

    def _ask_maps(self, op: int) -> list[np.ndarray]:
        if self._owed:
            raise RuntimeError("frames are still owed")
        if self._child is None:
            raise NavlogError(f"{NAME}: closed")
        self._child.ask(op)
        _, arrays = unpack(self._reply())
        return [a for a in arrays if a is not None]

    def close(self) -> None:
        """End the child (it exits when its input closes)."""
        if self._child is not None:
            self._child.close()
            self._child = None

    def __del__(self) -> None:
        self.close()


Receiver = Callable[[FrameResult], None]


class OdometryFrames:
    """``LidarOdometry``'s frames completed in this process, or (``offload``) ahead in a child process.

    ``process(..., receiver)`` calls ``receiver()`` once the frame is accepted (planned) and gives the
    callable it returns the frame's result when the frame completes: at once in this process, later
    when offloaded (in order; ``flush`` completes every frame in flight). The odometry's pose history
    and skips are the same either way when every frame has completed, and so are the results (tested).
    With ``offload`` and no child to start (a process limit, no interpreter), frames complete here."""

    def __init__(self, odometry: LidarOdometry, *, offload: bool, in_flight: int = 4) -> None:
        self.odometry = odometry
        self.in_flight = in_flight
        self._worker: OdometryWorker | None = None
        if offload:
            try:
                self._worker = OdometryWorker(odometry.params, odometry.initial_pose)
            except OSError:  # frames complete here
                self._worker = None
        self._planned: deque[tuple[SweepPlan, Receiver]] = deque()  # submitted, not yet completed
        self._maps: tuple[np.ndarray, list[np.ndarray]] | None = None  # the child's, when it has ended

    @property
    def offloaded(self) -> bool:
        return self._worker is not None

    @property
    def frames(self) -> int:
        """Frames accepted so far (completed or in flight)."""
        return len(self.odometry.stamps) + len(self._planned)

    def process(
        self,
        stamp_ns: int,
        points: np.ndarray,
        times: np.ndarray | None,
        prior: MotionPrior | None,
        *,
        keep_base: bool,
        receiver: Callable[[], Receiver],
    ) -> None:
        """One frame (see the class docstring); a frame that cannot be used is counted by the odometry."""
        odometry, worker = self.odometry, self._worker
        if worker is None:
            result = odometry.process(stamp_ns, points, times, prior)
            if result is not None:
                receiver()(result)
            return
        # a plan that goes ahead has every motion from the tracks as they are now (it completes later)
        plan = odometry.plan(stamp_ns, points, times, prior, settled=False, keep_base=keep_base)
        if isinstance(plan, Unsettled):  # its motion needs the constant velocity: every frame before first
            self.flush()
            plan = odometry.plan(stamp_ns, points, times, prior, keep_base=keep_base)
        if plan is None:
            return
        assert not isinstance(plan, Unsettled)  # a settled plan never is
        worker.submit(plan, prepare_sweep(plan.job))  # completed in the child while this process goes on
        self._planned.append((plan, receiver()))
        self._complete(len(self._planned) - self.in_flight)

    def flush(self) -> None:
        """Complete every frame in flight."""
        self._complete(len(self._planned))

    def _complete(self, count: int) -> None:
        for _ in range(count):
            assert self._worker is not None  # frames are in flight only with a child completing them
            plan, receive = self._planned.popleft()
            result, skipped = self._worker.take()
            self.odometry.adopt(plan, result, skipped)
            receive(result)

    def global_map(self) -> np.ndarray:
        """The global map of every frame so far (those in flight completed first)."""
        if self._maps is not None:
            return self._maps[0]
        if self._worker is not None:
            self.flush()
            return self._worker.global_map()
        return self.odometry.global_map()

    def chunks(self) -> list[np.ndarray]:
        """The chunks of ``save_every_n_frames`` frames (``LidarOdometry.finish_chunks``)."""
        return self._maps[1] if self._maps is not None else self.odometry.finish_chunks()

    def close(self) -> None:
        """Complete the frames in flight, keep the child's maps, end the child."""
        if self._worker is not None:
            self.flush()
            self._maps = self._worker.maps()
            self._worker.close()
            self._worker = None


class _Completer:
    """The child's side: one ``LidarOdometry``, made by the first request."""

    def __init__(self) -> None:
        self.odometry: LidarOdometry | None = None

    def __call__(self, code: int, body: bytes | bytearray) -> tuple[int, bytes]:
        if code == _INIT:
            fields, (initial,) = unpack(body)
            self.odometry = LidarOdometry(LidarOdometryParams(**fields), None, initial, background=in_thread)
            return code, b""
        odometry = self.odometry
        if odometry is None:
            raise ValueError("a frame before the odometry's parameters")
        if code == _FRAME:
            before = dict(odometry.skipped)
            result = odometry.complete(*frame_from_bytes(body))
            skipped = {k: n - before.get(k, 0) for k, n in odometry.skipped.items() if n != before.get(k, 0)}
            return code, result_bytes(result, skipped)
        if code == _MAPS:
            return code, pack(None, [odometry.global_map(), *odometry.finish_chunks()])
        if code == _GLOBAL:
            return code, pack(None, [odometry.global_map()])
        raise ValueError(f"unknown request {code}")


def serve() -> None:
    """The child's loop (``navlog.replay.workers.child.serve``) over the frames it is sent."""
    serve_requests(_Completer())
