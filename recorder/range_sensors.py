"""The 2D laser and the 3D LiDAR of a robot, in the simulator's process or in a worker process beside it.

``RangeSensors`` is the one implementation: it owns the Open3D scene of the world mesh and the two
noise streams (laser, LiDAR), and turns a request — the stamp, the sensor pose(s) and whether only
the recorder sees the topic — into the scan or the cloud: their CDR bytes (``raw``), or the values
their message objects are built from (the ranges; the cloud's columns).

``SensorWorker`` runs a ``RangeSensors`` in a child process: a new Python interpreter (never a fork
of a process with threads) that imports only this module, so that the caller's main module is not
run again (multiprocessing's "spawn" and "forkserver" import it: a script without a ``__main__``
guard would fail); ``multiprocessing.connection`` frames the messages. The child imports Open3D and
builds the world mesh itself, so it is started before the simulator compiles its MuJoCo model and
the two start-ups overlap, and the simulator's process never imports Open3D. Requests go through
one pipe and results come back through another, in request order (both enlarged to 1 MiB where the
system allows); a thread of the simulator's process reads the results as they come, so the child
never waits to write one (a sweep is about 300 kB) and goes on with the next request, and the
simulator takes them when it needs them (``ready``, ``result``). The noise streams are the child's,
drawn in request order: the same numbers, so the same bytes, as in the simulator's process. The
child is in a process group of its own and ignores SIGINT (Ctrl-C stops the recording, which then
ends the child), and it ends when its request pipe closes, also when the simulator's process is
killed. An error in the child, or its death, is raised in the simulator as a ``NavlogError``
naming the worker.

``PendingMessage`` and ``InOrderSink`` let the simulator publish a result before it has come
without the file depending on when it came (``navlog.recorder.sim``).

``InProcessSensors`` has the same interface and computes each request as it is made.
"""

from __future__ import annotations

import fcntl
import os
import pickle
import subprocess
import sys
import threading
import traceback
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.recorder import sensors
from navlog.recorder.robot import LaserConfig, LidarConfig, RobotSpec
from navlog.recorder.world import World, world_mesh
from navlog.replay.runtime.executor import Envelope, Sink

SCAN, LIDAR = "scan", "lidar"
_PIPE_BYTES = 1 << 20  # room for whole sweeps in the pipes (Linux caps it at pipe-max-size, 1 MiB by default)
_F_SETPIPE_SZ = getattr(fcntl, "F_SETPIPE_SZ", 1031)
# a result's first byte tells what it is, without a tag to copy a sweep for: CDR bytes (of little-endian
# CDR, whose header starts with a zero byte), a pickled object (the pickle protocol's marker), an error
_CDR, _PICKLE, _ERROR = 0x00, 0x80, b"E"


@dataclass(frozen=True)
class RangeSensorSpec:
    """What a ``RangeSensors`` is built from (picklable: it is sent to the worker process)."""

    world: World
    scan: LaserConfig | None
    lidar: LidarConfig | None
    scan_frame: str
    lidar_frame: str
    scan_seed: np.random.SeedSequence | None  # None: no noise
    lidar_seed: np.random.SeedSequence | None


class RangeSensors:
    """Ray casting, sensor models, noise and CDR building of the laser and the LiDAR (module docstring)."""

    def __init__(self, spec: RangeSensorSpec) -> None:
        self.spec = spec
        self.caster = sensors.RayCaster(world_mesh(spec.world))
        self.rng_scan = np.random.default_rng(spec.scan_seed) if spec.scan_seed is not None else None
        self.rng_lidar = np.random.default_rng(spec.lidar_seed) if spec.lidar_seed is not None else None

    def scan(self, t_ns: int, pose: np.ndarray, raw: bool) -> bytes | np.ndarray:
        """The scan taken at ``pose`` (4x4, world): its CDR bytes (``raw``) or its ranges."""
        cfg = self.spec.scan
        assert cfg is not None  # requested only for a configured sensor
        ranges = sensors.laser_ranges(self.caster, cfg, pose, self.rng_scan)
        return sensors.scan_cdr(t_ns, self.spec.scan_frame, cfg, ranges) if raw else ranges

    def lidar(
        self, t_ns: int, frame_index: int, times: tuple[float, ...], poses: np.ndarray, raw: bool
    ) -> bytes | dict[str, np.ndarray]:
        """The sweep ending at ``t_ns`` cast from ``poses`` (n x 4 x 4, world) at ``times`` (s from the stamp):
        its CDR bytes (``raw``) or its columns."""
        cfg = self.spec.lidar
        assert cfg is not None  # requested only for a configured sensor
        cols = sensors.lidar_sweep(self.caster, cfg, frame_index, list(zip(times, poses)), self.rng_lidar)
        return sensors.cloud_cdr(t_ns, self.spec.lidar_frame, cols) if raw else cols

    def compute(self, kind: str, args: tuple) -> Any:
        return self.scan(*args) if kind == SCAN else self.lidar(*args)


class InProcessSensors:
    """``RangeSensors`` in the caller's process: each request is computed when it is made."""

    def __init__(self, spec: RangeSensorSpec) -> None:
        self.sensors = RangeSensors(spec)
        self.caster = self.sensors.caster
        self._results: dict[int, Any] = {}
        self._next = 0

    def request(self, kind: str, args: tuple) -> int:
        """Ask for a scan (``args`` of ``RangeSensors.scan``) or a sweep (of ``RangeSensors.lidar``); a ticket."""
        ticket = self._next
        self._next += 1
        self._results[ticket] = self.sensors.compute(kind, args)
        return ticket

    def result(self, ticket: int) -> Any:
        return self._results.pop(ticket)

    def close(self) -> None:
        self._results.clear()


class SensorWorker:
    """``RangeSensors`` in a child process (module docstring); the same ``request`` / ``result`` interface."""

    def __init__(self, spec: RangeSensorSpec) -> None:
        req_r, req_w = os.pipe()
        res_r, res_w = os.pipe()
        for fd in (req_w, res_w):
            try:
                fcntl.fcntl(fd, _F_SETPIPE_SZ, _PIPE_BYTES)
            except OSError:  # not allowed here: the child then waits while a sweep is read
                pass
        try:
            # a new interpreter (never a fork of this process and its threads), in a process group of its own
            # (a Ctrl-C in the terminal stops the recording, which then ends the worker), that imports only
            # this module: not the caller's main module, as multiprocessing's "spawn" would
            self._process = subprocess.Popen(
                [sys.executable, "-c", _CHILD.format(req=req_r, res=res_w)],
                pass_fds=(req_r, res_w),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                process_group=0,
            )
        finally:
            os.close(req_r)  # the child's ends: only its own copies keep them open now
            os.close(res_w)
        self._requests = Connection(req_w, readable=False)
        self._results = Connection(res_r, writable=False)
        self._next = 0  # ticket of the next request
        # results as they come out of the pipe, read by a thread (so the worker never waits to write one)
        self._ready: dict[int, bytes] = {}
        self._ended = False  # the pipe closed: the worker is gone
        self._arrived = threading.Condition()
        self._reader = threading.Thread(target=self._read, name="navlog-sensor-results", daemon=True)
        self._reader.start()
        self._send(spec)

    def _send(self, obj: object) -> None:
        try:
            self._requests.send_bytes(pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL))
        except OSError:
            raise self._died() from None

    def request(self, kind: str, args: tuple) -> int:
        self._send((kind, args))
        ticket = self._next
        self._next += 1
        return ticket

    def _read(self) -> None:
        """The reader thread: every result into ``_ready`` under its ticket (they come in request order)."""
        ticket = 0
        try:
            while True:
                data = self._results.recv_bytes()  # waits without the GIL
                with self._arrived:
                    self._ready[ticket] = data
                    self._arrived.notify()
                ticket += 1
        except (EOFError, OSError):
            with self._arrived:
                self._ended = True
                self._arrived.notify()

    def ready(self, ticket: int) -> bool:
        """True when the result of request ``ticket`` has come (``result`` returns it without waiting)."""
        return ticket in self._ready or self._ended

    def result(self, ticket: int) -> Any:
        """The result of request ``ticket``, waiting for it."""
        with self._arrived:
            while ticket not in self._ready and not self._ended:
                self._arrived.wait()
            data = self._ready.pop(ticket, None)
        if data is None:
            raise self._died()
        if data[0] == _CDR:
            return data
        if data[0] == _PICKLE:
            return pickle.loads(data)
        self.close()
        raise NavlogError(
            f"sensor worker (the laser and LiDAR process, pid {self._process.pid}) failed:\n"
            f"{data[1:].decode(errors='replace')}"
        )

    def _died(self) -> NavlogError:
        self.close()
        return NavlogError(
            f"sensor worker (the laser and LiDAR process, pid {self._process.pid}) ended unexpectedly "
            f"(exit code {self._process.returncode}); the recording stops here"
        )

    def close(self) -> None:
        """End the child: close its request pipe (it exits on that), wait for it and for the reader thread."""
        if self._requests.closed:
            return
        self._requests.close()
        try:
            self._process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._reader.join()  # the child's end of the result pipe closed with it: the reader saw the end
        self._results.close()
        self._ready.clear()


# the worker process's program: SIGINT ignored before anything else (module docstring)
_CHILD = (
    "import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
    "from navlog.recorder.range_sensors import serve; serve({req}, {res})"
)


def serve(req_fd: int, res_fd: int) -> None:
    """The worker process: build the sensors from the first request, then answer requests in order until
    the request pipe closes."""
    requests = Connection(req_fd, writable=False)
    results = Connection(res_fd, readable=False)
    try:
        ranges = RangeSensors(pickle.loads(requests.recv_bytes()))
        while True:
            try:
                kind, args = pickle.loads(requests.recv_bytes())
            except EOFError:
                return
            out = ranges.compute(kind, args)
            results.send_bytes(out if isinstance(out, bytes) else pickle.dumps(out, protocol=pickle.HIGHEST_PROTOCOL))
    except (EOFError, BrokenPipeError, ConnectionResetError):  # the simulator is gone
        return
    except Exception:
        try:
            results.send_bytes(_ERROR + traceback.format_exc().encode())
        except OSError:
            pass


class PendingMessage:
    """The place of a raw scan or sweep published before the worker computed it; ``fill`` gives its bytes."""

    __slots__ = ("data",)

    def __init__(self) -> None:
        self.data: bytes | None = None

    def fill(self, data: bytes) -> None:
        self.data = data


class InOrderSink:
    """A sink that passes every message to ``sink`` in the order it is given them, its bytes in place of a
    ``PendingMessage``: the messages after a pending one are held until it is filled (a few sensor periods)."""

    def __init__(self, sink: Sink) -> None:
        self.sink = sink
        self._held: deque[Envelope] = deque()

    def write(self, env: Envelope) -> None:
        if self._held or isinstance(env.msg, PendingMessage):
            self._held.append(env)
            self.flush()
        else:
            self.sink.write(env)

    def flush(self) -> None:
        """Pass on the held messages up to the first pending one still unfilled."""
        held, write = self._held, self.sink.write
        while held:
            env = held[0]
            if isinstance(env.msg, PendingMessage):
                if env.msg.data is None:
                    return
                env = Envelope(env.topic, env.typename, env.time_ns, env.msg.data)
            held.popleft()
            write(env)

    def close(self) -> None:
        """Pass on everything held; every pending message must have been filled (the simulator's ``finish``)."""
        self.flush()
        if self._held:
            raise NavlogError(f"{len(self._held)} message(s) held behind a scan or sweep never computed")


RangeSensorsLike = InProcessSensors | SensorWorker


def start_range_sensors(
    world: World, robot: RobotSpec, seed: int, noise: bool, *, worker: bool
) -> RangeSensorsLike | None:
    """The laser and the LiDAR of ``robot`` in ``world`` (None when it has neither), in a worker process
    (``worker``) or in this one. Their noise streams are the seed's third and fourth (the simulator's
    odometry and IMU take the first two)."""
    if robot.scan is None and robot.lidar is None:
        return None
    streams = np.random.SeedSequence(seed).spawn(4)
    spec = RangeSensorSpec(
        world,
        robot.scan,
        robot.lidar,
        robot.frame(robot.scan.frame) if robot.scan else "",
        robot.frame(robot.lidar.frame) if robot.lidar else "",
        streams[2] if noise else None,
        streams[3] if noise else None,
    )
    return SensorWorker(spec) if worker else InProcessSensors(spec)
