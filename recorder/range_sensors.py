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
import json
import os
import struct
import subprocess
import sys
import threading
import traceback
from collections import deque
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.recorder import sensors
from navlog.recorder.robot import LaserConfig, LidarConfig, RobotSpec
from navlog.recorder.world import Solid, World, WorldSpec, world_mesh
from navlog.replay.config import from_mapping, to_mapping
from navlog.replay.runtime.executor import Envelope, Sink

SCAN, LIDAR = "scan", "lidar"
_PIPE_BYTES = 1 << 20  # room for whole sweeps in the pipes (Linux caps it at pipe-max-size, 1 MiB by default)
_F_SETPIPE_SZ = getattr(fcntl, "F_SETPIPE_SZ", 1031)
# a result's first byte tells what it is, without a tag to copy a sweep for: CDR bytes (of little-endian
# CDR, whose header starts with a zero byte), arrays (``_pack_arrays``), an error
_CDR, _ARRAYS, _ERROR = 0x00, ord("A"), b"E"
_SCAN_REQUEST = struct.Struct("<qB")  # stamp, raw; then the 4x4 pose (float64)
_LIDAR_REQUEST = struct.Struct("<qqIB")  # stamp, frame index, pose count, raw; then the times and poses


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


def _spec_bytes(spec: RangeSensorSpec) -> bytes:
    """The spec as JSON for the worker (plain data only: nothing the worker reads is unpickled or evaluated)."""

    def seed(s: np.random.SeedSequence | None) -> dict | None:
        return None if s is None else {"entropy": s.entropy, "spawn_key": list(s.spawn_key), "pool_size": s.pool_size}

    return json.dumps(
        {
            "world": {"name": spec.world.name, "floor": spec.world.spec.floor, "path": str(spec.world.path)},
            "solids": [to_mapping(s) for s in spec.world.solids],
            "scan": None if spec.scan is None else to_mapping(spec.scan),
            "lidar": None if spec.lidar is None else to_mapping(spec.lidar),
            "scan_frame": spec.scan_frame,
            "lidar_frame": spec.lidar_frame,
            "scan_seed": seed(spec.scan_seed),
            "lidar_seed": seed(spec.lidar_seed),
        }
    ).encode()


def _spec_from_bytes(data: bytes) -> RangeSensorSpec:
    d = json.loads(data)

    def seed(s: dict | None) -> np.random.SeedSequence | None:
        if s is None:
            return None
        return np.random.SeedSequence(s["entropy"], spawn_key=tuple(s["spawn_key"]), pool_size=s["pool_size"])

    w = d["world"]
    solids = [from_mapping(Solid, s) for s in d["solids"]]
    return RangeSensorSpec(  # the world as world_mesh reads it: its solids and whether it has a floor
        World(WorldSpec(w["name"], floor=w["floor"]), solids, Path(w["path"])),
        None if d["scan"] is None else from_mapping(LaserConfig, d["scan"]),
        None if d["lidar"] is None else from_mapping(LidarConfig, d["lidar"]),
        d["scan_frame"],
        d["lidar_frame"],
        seed(d["scan_seed"]),
        seed(d["lidar_seed"]),
    )


def _request_bytes(kind: str, args: tuple) -> bytes:
    """A scan's or a sweep's request as bytes: a fixed header, then the float64 times and poses."""
    if kind == SCAN:
        t_ns, pose, raw = args
        return b"S" + _SCAN_REQUEST.pack(t_ns, raw) + np.ascontiguousarray(pose, dtype=np.float64).tobytes()
    t_ns, frame_index, times, poses, raw = args
    head = _LIDAR_REQUEST.pack(t_ns, frame_index, len(times), raw)
    return b"L" + head + np.asarray(times, dtype=np.float64).tobytes() + np.asarray(poses, np.float64).tobytes()


def _request_from_bytes(data: bytes) -> tuple[str, tuple]:
    if data[:1] == b"S":
        t_ns, raw = _SCAN_REQUEST.unpack_from(data, 1)
        pose = np.frombuffer(data, np.float64, 16, 1 + _SCAN_REQUEST.size).reshape(4, 4)
        return SCAN, (t_ns, pose, bool(raw))
    t_ns, frame_index, n, raw = _LIDAR_REQUEST.unpack_from(data, 1)
    at = 1 + _LIDAR_REQUEST.size
    times = tuple(np.frombuffer(data, np.float64, n, at).tolist())
    poses = np.frombuffer(data, np.float64, 16 * n, at + 8 * n).reshape(n, 4, 4)
    return LIDAR, (t_ns, frame_index, times, poses, bool(raw))


def _pack_arrays(arrays: dict[str, np.ndarray]) -> bytes:
    """Named arrays as bytes: a JSON header (name, dtype, shape of each), then their data in that order."""
    arrays = {k: np.ascontiguousarray(v) for k, v in arrays.items()}
    head = json.dumps([[k, v.dtype.str, list(v.shape)] for k, v in arrays.items()]).encode()
    return bytes([_ARRAYS]) + struct.pack("<I", len(head)) + head + b"".join(v.tobytes() for v in arrays.values())


def _unpack_arrays(data: bytes) -> dict[str, np.ndarray]:
    (n,) = struct.unpack_from("<I", data, 1)
    at = 5 + n
    out = {}
    for name, dtype, shape in json.loads(data[5:at]):
        a = np.frombuffer(data, np.dtype(dtype), int(np.prod(shape)), at).reshape(shape).copy()
        out[name] = a
        at += a.nbytes
    return out


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
        self._send(_spec_bytes(spec))

    def _send(self, data: bytes) -> None:
        try:
            self._requests.send_bytes(data)
        except OSError:
            raise self._died() from None

    def request(self, kind: str, args: tuple) -> int:
        self._send(_request_bytes(kind, args))
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
        if data[0] == _ARRAYS:
            arrays = _unpack_arrays(data)
            return arrays[""] if list(arrays) == [""] else arrays  # a scan's ranges, or a sweep's columns
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
        ranges = RangeSensors(_spec_from_bytes(requests.recv_bytes()))
        while True:
            try:
                kind, args = _request_from_bytes(requests.recv_bytes())
            except EOFError:
                return
            out = ranges.compute(kind, args)
            if not isinstance(out, bytes):
                out = _pack_arrays(out if isinstance(out, dict) else {"": out})
            results.send_bytes(out)
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
