"""The 2D laser and the 3D LiDAR of a robot, in the simulator's process or in a worker process beside it.

``RangeSensors`` is the one implementation: it owns the Open3D scene of the world mesh and the two
noise streams (laser, LiDAR), and turns a request — the stamp, the sensor pose(s) and whether only
the recorder sees the topic — into the scan or the cloud: their CDR bytes (``raw``), or the values
their message objects are built from (the ranges; the cloud's columns).

``SensorWorker`` runs a ``RangeSensors`` in a child process: a new Python interpreter (never a fork
of a process with threads) that imports only this module, so that the caller's main module is not
run again (multiprocessing's "spawn" and "forkserver" import it: a script without a ``__main__``
guard would fail). The child imports Open3D and builds the world mesh itself, so it is started before
the simulator compiles its MuJoCo model and the two start-ups overlap, and the simulator's process
never imports Open3D. Requests (a few kB: the stamp and poses) go through a pipe, framed as
``multiprocessing.connection`` frames them. Results (a sweep is about 250 kB) come back through
shared memory: a ring of ``RING_RESULTS`` of the largest results, in a memory file both processes
map. The child writes each result into the ring, in request order and in one piece, and then a
16-byte note (where, how long) into a result pipe; the simulator takes a result by copying it out
of the ring when it looks for results (``ready``, ``result``, and while it waits for room in the
request pipe), and stores the count of results taken in the shared memory's first 8 bytes, so the
child never writes over a result not yet taken. A result that finds no room (the simulator fell
far behind, or a result larger than the ring) comes through the result pipe after its note
instead. Requests the pipe has no room for yet (the child is still importing Open3D, or fell behind)
wait in a queue in the simulator's process, and go into the pipe as far as it has room each time the
simulator makes a request or looks for results, so the simulation runs on meanwhile. So the child never waits on the simulator's process to write a result (no thread there
has to take the GIL to read it), and the simulator never waits on the child while a result is due:
each side only waits for work to do.

When the simulation has ended and only waits for the results still to come (``ending``), it says so
in the shared memory's next 8 bytes, and the child casts the rays of the rest on every core instead
of one (Open3D gives the same numbers either way): the simulator's process leaves a core idle then.
During the run the child casts on one core: the simulator's threads have the other. (Without shared
memory the child never hears of it and casts on one core to the end.)

The noise streams are the child's, drawn in request order: the same numbers, so the same bytes, as
in the simulator's process. The child is in a process group of its
own and ignores SIGINT (Ctrl-C stops the recording, which then ends the child), and it ends when its
request pipe closes, also when the simulator's process is killed (the memory file goes with the
last process that maps it). An error in the child, or its death, is raised in the simulator as a
``NavlogError`` naming the worker.

The simulator takes a result's place in the order before it has come (``Node.defer``), so the file
does not depend on when it came (``navlog.recorder.sim``).

``InProcessSensors`` has the same interface and computes each request as it is made.
"""

from __future__ import annotations

import fcntl
import json
import mmap
import os
import select
import struct
import subprocess
import sys
import tempfile
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
from navlog.recorder.solids import Solid
from navlog.recorder.world import World, WorldSpec, world_mesh
from navlog.replay.config import from_mapping, to_mapping

SCAN, LIDAR = "scan", "lidar"
_PIPE_BYTES = 1 << 20  # room for many requests in the pipe (Linux caps it at pipe-max-size, 1 MiB by default)
_F_SETPIPE_SZ = getattr(fcntl, "F_SETPIPE_SZ", 1031)
_FRAME = struct.Struct("!i")  # a request's length, as ``multiprocessing.connection`` frames it
# a result's first byte tells what it is, without a tag to copy a sweep for: CDR bytes (of little-endian
# CDR, whose header starts with a zero byte), arrays (``_pack_arrays``), an error
_CDR, _ARRAYS, _ERROR = 0x00, ord("A"), b"E"
_SCAN_REQUEST = struct.Struct("<qB")  # stamp, raw; then the 4x4 pose (float64)
_LIDAR_REQUEST = struct.Struct("<qqIB")  # stamp, frame index, pose count, raw; then the times and poses
# the result pipe carries a note per result: where it is (in the ring, or the bytes follow in the pipe), its
# length, its offset in the ring
_NOTE = struct.Struct("<IIQ")
_IN_RING, _INLINE = 0, 1
# the shared file: the count of results the simulator has taken (uint64, at offset 0: an aligned 8-byte store
# and load, never seen half-written), whether the simulation has ended (uint64, at offset 8), then the ring
_RING_AT = 64
_COPIED, _ENDING = 0, 1  # the header's two words
RING_RESULTS = 8  # the ring holds this many of the largest results the sensors can give (go2: 2 MB)
# the worker's numpy on one thread: its small matrix products gain nothing from more, and OpenBLAS's idle
# threads spin for a while after each, taking CPU time from the simulator's process (Open3D casts on one)
_ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _ring_size(spec: RangeSensorSpec) -> int:
    """Bytes of the result ring: ``RING_RESULTS`` of the largest scan or sweep (CDR, or its arrays: at most
    22 bytes a point either way, with a few kB of header), in whole pages."""
    largest = 0
    if spec.scan is not None:
        largest = 4 * spec.scan.samples + 4096
    if spec.lidar is not None:
        lidar = spec.lidar
        rays = lidar.lines * lidar.columns if lidar.pattern == "velodyne" else lidar.points
        largest = max(largest, 22 * rays + 4096)
    size = RING_RESULTS * largest
    return -(-size // mmap.PAGESIZE) * mmap.PAGESIZE


def _shared_file(size: int) -> int | None:
    """A file descriptor of ``size`` bytes of memory to share with the worker, gone with its last descriptor;
    None where there is no room for it (a file-size limit, ``ulimit -f``, counts it as a file)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("navlog-range-sensors", os.MFD_CLOEXEC)
    else:  # pragma: no cover - every Linux has memfd_create; an unlinked temporary file elsewhere
        with tempfile.TemporaryFile() as f:
            fd = os.dup(f.fileno())
    try:
        os.ftruncate(fd, size)
    except OSError:
        os.close(fd)
        return None
    return fd


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
        returns = sensors.lidar_returns(self.caster, cfg, frame_index, list(zip(times, poses)), self.rng_lidar)
        return sensors.returns_cdr(t_ns, self.spec.lidar_frame, returns) if raw else returns.columns()

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

    def ending(self) -> None:
        """Nothing is still to come here: each request was computed when it was made."""

    def close(self) -> None:
        self._results.clear()


class SensorWorker:
    """``RangeSensors`` in a child process (module docstring); the same ``request`` / ``result`` interface.

    ``ring_bytes``: the size of the shared result ring (default: ``RING_RESULTS`` of the largest result the
    spec can give); results that do not fit come through the pipe instead."""

    def __init__(self, spec: RangeSensorSpec, *, ring_bytes: int | None = None) -> None:
        ring = _ring_size(spec) if ring_bytes is None else int(ring_bytes)
        shared = _shared_file(_RING_AT + ring)  # None: no ring, every result comes through the pipe
        passed = () if shared is None else (shared,)
        req_r, req_w = os.pipe()
        res_r, res_w = os.pipe()
        try:
            try:
                fcntl.fcntl(req_w, _F_SETPIPE_SZ, _PIPE_BYTES)
            except OSError:  # not allowed here: the simulator then waits sooner for the worker to read
                pass
            # a new interpreter (never a fork of this process and its threads), in a process group of its own
            # (a Ctrl-C in the terminal stops the recording, which then ends the worker), that imports only
            # this module: not the caller's main module, as multiprocessing's "spawn" would
            self._process = subprocess.Popen(
                [sys.executable, "-c", _CHILD.format(req=req_r, res=res_w, shm=-1 if shared is None else shared)],
                pass_fds=(req_r, res_w, *passed),
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                process_group=0,
                env={**os.environ, **_ONE_THREAD},
            )
            self._shared = mmap.mmap(-1, _RING_AT) if shared is None else mmap.mmap(shared, _RING_AT + ring)
        except BaseException:
            for fd in (req_w, res_r):
                os.close(fd)
            raise
        finally:
            for fd in (req_r, res_w, *passed):  # the child's ends: only its own copies keep them open now
                os.close(fd)
        self._header = np.frombuffer(self._shared, np.uint64, 2)  # read by the worker (module docstring)
        self._req, self._res = req_w, res_r
        os.set_blocking(req_w, False)  # a full request pipe is waited on beside the results (``_write``)
        self._poll = select.poll()
        self._poll.register(res_r, select.POLLIN)
        self._both = select.poll()  # room for a request, or a result to take
        self._both.register(req_w, select.POLLOUT)
        self._both.register(res_r, select.POLLIN)
        self._unsent: deque[tuple[int, memoryview]] = deque()  # (ticket, framed bytes) the pipe had no room for
        self._next = 0  # ticket of the next request
        self._copied = 0  # results taken out of the ring or the pipe, in request order
        self._ready: dict[int, bytes] = {}  # taken, not yet asked for
        self.piped = 0  # results that came through the pipe, not the ring (it had no room for them)
        self._ended = False  # the result pipe closed: the worker is gone
        self._closed = False
        self._send(_spec_bytes(spec))

    def _send(self, data: bytes, ticket: int = -1) -> None:
        """Queue one request, framed as ``multiprocessing.connection`` frames it (the worker reads it so), and
        put what the pipe has room for into it now: the simulation does not wait for the worker to read."""
        self._unsent.append((ticket, memoryview(_FRAME.pack(len(data)) + data)))
        self._write(until=None)

    def _write(self, until: int | None) -> None:
        """Put the queued requests into the pipe while it has room; with ``until`` (a ticket), wait for room
        until that request is in, taking the results meanwhile, so that the worker, writing one, never waits
        on this."""
        unsent = self._unsent
        while unsent:
            ticket, view = unsent[0]
            try:
                view = view[os.write(self._req, view) :]
            except BlockingIOError:
                if until is None or ticket > until:
                    return
                for fd, _ in self._both.poll():
                    if fd == self._res and not self._take():
                        raise self._gone() from None
                continue
            except OSError:  # the worker is gone (EPIPE)
                raise self._gone() from None
            if view:
                unsent[0] = (ticket, view)
            else:
                unsent.popleft()

    def request(self, kind: str, args: tuple) -> int:
        ticket = self._next
        self._next += 1
        self._send(_request_bytes(kind, args), ticket)
        return ticket

    def _take(self) -> bool:
        """Take the next result (waiting for it) out of the ring or the pipe; False when the worker is gone."""
        note = self._read(_NOTE.size)
        if note is None:
            self._ended = True
            return False
        how, n, at = _NOTE.unpack(note)
        if how == _IN_RING:
            data = self._shared[_RING_AT + at : _RING_AT + at + n]  # a copy: the worker may reuse the place now
        else:
            inline = self._read(n)
            if inline is None:
                self._ended = True
                return False
            data = inline
            self.piped += 1
        self._ready[self._copied] = data
        self._copied += 1
        self._header[_COPIED] = self._copied
        return True

    def _read(self, n: int) -> bytes | None:
        parts, left = [], n
        while left:
            try:
                chunk = os.read(self._res, left)
            except OSError:
                return None
            if not chunk:
                return None
            parts.append(chunk)
            left -= len(chunk)
        return parts[0] if len(parts) == 1 else b"".join(parts)

    def ready(self, ticket: int) -> bool:
        """True when the result of request ``ticket`` has come (``result`` returns it without waiting)."""
        if self._unsent:
            self._write(until=None)
        while ticket not in self._ready and not self._ended and self._poll.poll(0):
            self._take()
        return ticket in self._ready or self._ended

    def result(self, ticket: int) -> Any:
        """The result of request ``ticket``, waiting for it."""
        if ticket not in self._ready and not self._ended and ticket < self._next:
            self._write(until=ticket)
            while ticket not in self._ready and not self._ended:
                self._take()
        data = self._ready.pop(ticket, None)
        if data is None:
            raise self._died()
        if data[0] == _CDR:
            return data
        if data[0] == _ARRAYS:
            arrays = _unpack_arrays(data)
            return arrays[""] if list(arrays) == [""] else arrays  # a scan's ranges, or a sweep's columns
        raise self._failed(data)

    def _failed(self, error: bytes) -> NavlogError:
        self.close()
        return NavlogError(
            f"sensor worker (the laser and LiDAR process, pid {self._process.pid}) failed:\n"
            f"{error[1:].decode(errors='replace')}"
        )

    def _gone(self) -> NavlogError:
        """The error of a worker whose pipes broke: its own, with its traceback, when it failed on a request
        (it writes that and ends), else that it ended unexpectedly."""
        while not self._ended and self._take():  # what it wrote before it ended, up to the pipe's end
            pass
        for data in self._ready.values():
            if data[:1] == _ERROR:
                return self._failed(data)
        return self._died()

    def _died(self) -> NavlogError:
        self.close()
        return NavlogError(
            f"sensor worker (the laser and LiDAR process, pid {self._process.pid}) ended unexpectedly "
            f"(exit code {self._process.returncode}); the recording stops here"
        )

    def ending(self) -> None:
        """The simulation has ended and only waits for the results still to come: the worker casts them on
        every core (module docstring)."""
        if not self._closed:
            self._header[_ENDING] = 1

    def close(self) -> None:
        """End the child: close its pipes (it exits on that, also when writing a result) and wait for it."""
        if self._closed:
            return
        self._closed = True
        os.close(self._req)
        os.close(self._res)
        try:
            self._process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        self._ready.clear()
        self._unsent.clear()
        del self._header  # the last view of the mapping, which can then be closed
        self._shared.close()


# the worker process's program: SIGINT ignored before anything else (module docstring); once it has served,
# it leaves at once: every result is written (pipe writes and the shared memory need no flush), and tearing
# down Open3D and the interpreter took 60 ms that the simulator waited for at the end of every recording
_CHILD = (
    "import os, signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
    "from navlog.recorder.range_sensors import serve; serve({req}, {res}, {shm}); os._exit(0)"
)


class _Ring:
    """Where the worker puts each result in the shared ring: in request order, each in one piece, never over
    a result the simulator has not taken yet (those of tickets from ``copied`` on)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._live: deque[tuple[int, int, int]] = deque()  # (ticket, start, end) of results maybe not taken

    def place(self, ticket: int, n: int, copied: int) -> int | None:
        """The offset for result ``ticket`` of ``n`` bytes, or None when it does not fit now."""
        live = self._live
        while live and live[0][0] < copied:
            live.popleft()
        at: int | None
        if not live:
            at = 0 if n <= self.size else None
        else:
            tail, head = live[0][1], live[-1][2]
            if tail < head:  # the results in the ring do not wrap: after them, else from the start
                at = head if head + n <= self.size else (0 if n <= tail else None)
            else:  # they wrap: between the newest and the oldest
                at = head if head + n <= tail else None
        if at is not None:
            live.append((ticket, at, at + n))
        return at


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view) :]


def serve(req_fd: int, res_fd: int, shm_fd: int) -> None:
    """The worker process: build the sensors from the first request, then answer requests in order until
    the request pipe closes (each result in the shared ring, or through the result pipe when it has no room)."""
    requests = Connection(req_fd, writable=False)
    shared = bytearray(_RING_AT) if shm_fd < 0 else mmap.mmap(shm_fd, 0)  # no shared memory: no ring
    if shm_fd >= 0:
        os.close(shm_fd)
    header = np.frombuffer(shared, np.uint64, 2)  # results the simulator has taken; whether it has ended
    ring = _Ring(len(shared) - _RING_AT)
    try:
        ranges = RangeSensors(_spec_from_bytes(requests.recv_bytes()))
        ticket = 0
        while True:
            try:
                kind, args = _request_from_bytes(requests.recv_bytes())
            except EOFError:
                return
            ranges.caster.threads = 0 if header[_ENDING] else 1  # 0: Open3D's every core (module docstring)
            out = ranges.compute(kind, args)
            if not isinstance(out, bytes):
                out = _pack_arrays(out if isinstance(out, dict) else {"": out})
            at = ring.place(ticket, len(out), int(header[_COPIED]))
            if at is None:
                _write_all(res_fd, _NOTE.pack(_INLINE, len(out), 0))
                _write_all(res_fd, out)
            else:
                shared[_RING_AT + at : _RING_AT + at + len(out)] = out
                _write_all(res_fd, _NOTE.pack(_IN_RING, len(out), at))
            ticket += 1
    except (EOFError, BrokenPipeError, ConnectionResetError):  # the simulator is gone
        return
    except Exception:
        error = _ERROR + traceback.format_exc().encode()
        try:
            _write_all(res_fd, _NOTE.pack(_INLINE, len(error), 0) + error)
        except OSError:
            pass


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
