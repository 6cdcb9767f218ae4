"""The occupancy grid's scan updates in a child process, beside the replay that produces the scans.

A 2D mapping replay spends about 40 % of its thread inserting scans into ``OccupancyGrid2D``: NumPy
work the replay's thread would otherwise wait for. ``GridWorker`` runs the same grid in a child
Python (``serve``, which imports only this module and the grid's) and takes the scans in order:

- ``insert_scan`` sends the scan (pose, beam angles, ranges, limits) and returns at once; the pipe's
  buffer bounds how far the caller runs ahead;
- ``outcomes`` tells, per scan inserted since its last call, whether the grid took it or refused it
  (``GridTooLarge``: a pose or ranges far off), in order;
- ``to_map`` and ``snapshot`` wait for every scan sent so far, then give the trinary map, or the whole
  grid (log-odds, seen cells, origin, statistics) as an in-process ``OccupancyGrid2D``;
- ``request_map`` asks for the map without waiting: its reply (and the outcomes before it) is taken
  by a later ``poll``, or by any call that waits, in the order asked.

Until the child has started (an interpreter and NumPy: a few tenths of a second, longer on a busy
machine) the scans go into a grid in this process; once the child says it is ready, that grid is
handed to it and the scans go there. A caller never waits for the child's start-up, and with
``spawn=False`` (one CPU), or when no child could be started or it ended before it was ready, every
scan stays in this process. Either way the grid's own code runs on the
same arrays in the same order, so the maps and statistics are the same bits (tested).

The processes exchange plain bytes: a frame is one opcode byte, a little-endian uint32 length and the
payload (arrays as raw bytes, the parameters as JSON); nothing is unpickled. The child ignores SIGINT
(a Ctrl-C stops the replay, which closes the pipes) and exits when its input closes, so an interrupted
or failed replay leaves no process behind. An error in the child comes back as ``NavlogError`` with
its traceback; a child that died is named with its exit code.
"""

from __future__ import annotations

import dataclasses
import fcntl
import json
import os
import select
import struct
import subprocess
import sys
import traceback
from collections import deque
from collections.abc import Callable
from typing import IO, Any, BinaryIO

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.mapping.occupancy import GridTooLarge, OccupancyGrid2D, OccupancyParams, ScanStats
from navlog.replay.occupancy_map import OccupancyMap

__all__ = ["GridWorker", "serve"]

_FRAME = struct.Struct("<BI")  # opcode, payload length
# parent -> child: parameters, the grid handed over, a scan, requests (outcomes only, map, whole grid)
_PARAMS, _GRID, _INSERT, _OUTCOMES, _MAP, _SNAPSHOT = (ord(c) for c in "PGIOMS")
_READY, _ERROR = ord("R"), ord("E")  # child -> parent, besides the replies
_LIMITS = struct.Struct("<ddI")  # range_min, range_max, beam count
_SHAPE = struct.Struct("<ddII")  # origin x, y; ny, nx
_STATS = [f.name for f in dataclasses.fields(ScanStats)]
_PIPE_BYTES = 1 << 20  # scans the caller may send ahead (Linux caps a pipe at pipe-max-size, 1 MiB by default)
_F_SETPIPE_SZ = getattr(fcntl, "F_SETPIPE_SZ", 1031)
_CHILD = (
    "import signal; signal.signal(signal.SIGINT, signal.SIG_IGN); "
    "from navlog.replay.mapping.grid_process import serve; serve()"
)


def _state_bytes(grid: OccupancyGrid2D, outcomes: bytes = b"", with_grid: bool = True) -> bytes:
    """``outcomes``, the origin and shape, then (``with_grid``) the statistics, log-odds and seen cells."""
    ny, nx = grid.logodds.shape
    head = outcomes + _SHAPE.pack(float(grid.origin[0]), float(grid.origin[1]), ny, nx)
    if not with_grid:
        return head
    stats = np.array([getattr(grid.stats, k) for k in _STATS], dtype=np.int64)
    return head + stats.tobytes() + grid.logodds.tobytes() + grid.seen.tobytes()


def _grid_from_bytes(params: OccupancyParams, body: bytes) -> OccupancyGrid2D:
    ox, oy, ny, nx = _SHAPE.unpack_from(body)
    at = _SHAPE.size
    stats = np.frombuffer(body, np.int64, len(_STATS), at)
    at += 8 * len(_STATS)
    grid = OccupancyGrid2D(params)
    grid.origin = np.array([ox, oy])
    grid.logodds = np.frombuffer(body, np.float32, ny * nx, at).reshape(ny, nx).copy()
    grid.seen = np.frombuffer(body, np.bool_, ny * nx, at + 4 * ny * nx).reshape(ny, nx).copy()
    grid.stats = ScanStats(**{k: int(v) for k, v in zip(_STATS, stats)})
    return grid


class GridWorker:
    """``OccupancyGrid2D``'s scan updates, in a child process once it has started (module docstring)."""

    def __init__(self, params: OccupancyParams, *, spawn: bool = True) -> None:
        self.params = params
        self.local: OccupancyGrid2D | None = OccupancyGrid2D(params)  # the grid until the child takes it
        self._outcomes: list[bool] = []
        self._sent = 0  # scans sent to the child since the last request
        # map requests whose reply has not been taken: (scans sent before it, frame id, what takes the map)
        self._requests: deque[tuple[int, str, Callable[[OccupancyMap | None], None]]] = deque()
        self._process: subprocess.Popen | None = None
        if spawn:
            try:
                self._process = subprocess.Popen(
                    [sys.executable, "-c", _CHILD], stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0
                )
            except OSError:  # no child here (a process limit, no interpreter to run): the grid stays here
                return
            try:
                assert self._process.stdin is not None
                fcntl.fcntl(self._process.stdin.fileno(), _F_SETPIPE_SZ, _PIPE_BYTES)
            except OSError:  # not allowed here: the caller then waits sooner for the child to read
                pass
            try:
                self._send(_PARAMS, json.dumps(dataclasses.asdict(params)).encode())
            except NavlogError:  # the child ended at once: the grid stays here
                pass

    @property
    def in_child(self) -> bool:
        """True once the child holds the grid."""
        return self.local is None

    # ------------------------------------------------------------ the caller's side
    def insert_scan(
        self, pose: np.ndarray, angles: np.ndarray, ranges: np.ndarray, range_min: float, range_max: float
    ) -> None:
        """Insert a scan (``OccupancyGrid2D.insert_scan``'s arguments); its outcome comes with ``outcomes``."""
        a = np.ascontiguousarray(angles, dtype=np.float64)
        r = np.ascontiguousarray(ranges, dtype=np.float64)
        if len(a) != len(r):
            raise ValueError(f"{len(a)} beam angles for {len(r)} ranges")
        if self.local is not None and self._child_ready():
            self._hand_over()
        if self.local is not None:
            try:
                self.local.insert_scan(pose, a, r, range_min, range_max)
                self._outcomes.append(True)
            except GridTooLarge:
                self._outcomes.append(False)
            return
        limits = _LIMITS.pack(float(range_min), float(range_max), len(r))
        pose_bytes = np.ascontiguousarray(pose, dtype=np.float64).tobytes()
        self._send(_INSERT, b"".join((pose_bytes, limits, a.tobytes(), r.tobytes())))
        self._sent += 1

    def outcomes(self, wait: bool = True) -> list[bool]:
        """Per scan inserted since the last call, in order: True if the grid took it, False if it refused it
        (without ``wait``: those that have come, the first ones)."""
        if wait and (self._sent or self._requests):
            self._ask(_OUTCOMES)
        out, self._outcomes = self._outcomes, []
        return out

    def to_map(self, frame_id: str) -> OccupancyMap | None:
        """The trinary map of every scan so far (``OccupancyGrid2D.to_map``); None while the grid is empty."""
        if self.local is not None:
            return self.local.to_map(frame_id) if self.local.logodds.size else None
        return self._map(self._ask(_MAP), frame_id)

    def request_map(self, frame_id: str, reply: Callable[[OccupancyMap | None], None]) -> None:
        """``to_map`` without waiting for the child: ``reply`` gets the map when a later ``poll`` (or a
        call that waits) takes it, after the outcomes of the scans before it; at once while the grid is
        in this process."""
        if self.local is not None:
            reply(self.to_map(frame_id))
            return
        self._send(_MAP, b"")
        self._requests.append((self._sent, frame_id, reply))
        self._sent = 0

    def poll(self) -> None:
        """Take the replies to ``request_map`` that have come, in order, without waiting."""
        out = self._process.stdout if self._process is not None else None
        while self._requests and out is not None and select.select([out], [], [], 0)[0]:
            self._take_request()

    def _take_request(self) -> None:
        sent, frame_id, reply = self._requests.popleft()
        _, body = self._read_frame()
        self._outcomes.extend(bool(b) for b in body[:sent])
        reply(self._map(body[sent:], frame_id))

    def _map(self, body: bytes, frame_id: str) -> OccupancyMap | None:
        ox, oy, ny, nx = _SHAPE.unpack_from(body)
        if not ny * nx:
            return None
        data = np.frombuffer(body, np.int8, ny * nx, _SHAPE.size).reshape(ny, nx)
        return OccupancyMap(data=data, resolution=self.params.resolution, origin=(ox, oy, 0.0), frame_id=frame_id)

    def snapshot(self) -> OccupancyGrid2D:
        """The grid after every scan so far, in this process (the child's copy when it holds the grid)."""
        if self.local is not None:
            return self.local
        return _grid_from_bytes(self.params, self._ask(_SNAPSHOT))

    def close(self) -> None:
        """End the child: close its input (it exits on that) and wait for it."""
        process, self._process = self._process, None
        if process is None:
            return
        for stream in (process.stdin, process.stdout):
            if stream is not None:
                try:
                    stream.close()
                except OSError:
                    pass
        try:
            process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()

    def __del__(self) -> None:
        self.close()

    # ------------------------------------------------------------ talking to the child
    def _child_ready(self) -> bool:
        process = self._process
        if process is None or process.stdout is None:
            return False
        if not select.select([process.stdout], [], [], 0)[0]:
            return False
        try:
            code, _ = self._read_frame()
        except NavlogError:  # the child ended before it was ready (it is closed now): the grid stays here
            return False
        if code != _READY:
            raise NavlogError(f"occupancy grid process (pid {process.pid}): unexpected reply {code} at start-up")
        return True

    def _hand_over(self) -> None:
        assert self.local is not None
        self._send(_GRID, _state_bytes(self.local))
        self.local = None

    def _send(self, op: int, payload: bytes) -> None:
        process = self._process
        assert process is not None and process.stdin is not None and process.stdout is not None
        data = _FRAME.pack(op, len(payload)) + payload
        try:
            if not self._requests:
                process.stdin.write(data)
                return
            # a map asked for may be in the way: the child writes its reply, we write to it; take the
            # reply while the pipe to the child is full, and write no more than it takes without waiting
            view, fd = memoryview(data), process.stdin.fileno()
            while view:
                readable, writable, _ = select.select([process.stdout], [fd], [])
                if readable and self._requests:
                    self._take_request()
                elif writable:
                    view = view[os.write(fd, view[: select.PIPE_BUF]) :]
        except OSError:  # the child is gone (EPIPE)
            raise self._died() from None

    def _read_frame(self) -> tuple[int, bytes]:
        process = self._process
        assert process is not None and process.stdout is not None
        head = _read(process.stdout, _FRAME.size)
        body = None if head is None else _read(process.stdout, _FRAME.unpack(head)[1])
        if head is None or body is None:
            raise self._died()
        code = _FRAME.unpack(head)[0]
        if code == _ERROR:
            pid = process.pid
            self.close()
            raise NavlogError(f"occupancy grid process (pid {pid}) failed:\n{body.decode(errors='replace')}")
        return code, body

    def _ask(self, op: int) -> bytes:
        """Send request ``op``; its reply (after every scan sent, and the replies asked for before), without
        the outcomes it starts with."""
        self._send(op, b"")
        while self._requests:
            self._take_request()
        _, body = self._read_frame()
        self._outcomes.extend(bool(b) for b in body[: self._sent])
        body, self._sent = body[self._sent :], 0
        return body

    def _died(self) -> NavlogError:
        process = self._process
        self.close()
        pid, code = (process.pid, process.returncode) if process is not None else ("?", "?")
        return NavlogError(
            f"occupancy grid process (pid {pid}) ended unexpectedly (exit code {code}); the replay stops here"
        )


def _read(stream: IO[bytes] | BinaryIO, n: int) -> bytes | None:
    """Exactly ``n`` bytes from ``stream``; None at its end."""
    parts, left = [], n
    while left:
        chunk = stream.read(left)
        if not chunk:
            return None
        parts.append(chunk)
        left -= len(chunk)
    return b"".join(parts)


# ------------------------------------------------------------ the child's side
def _handle(grid: OccupancyGrid2D, outcomes: bytearray, code: int, body: bytes) -> tuple[int, bytes] | None:
    """One request on the grid: None for a scan inserted (its outcome noted), else the reply ``(code, payload)``."""
    if code == _INSERT:
        pose = np.frombuffer(body, np.float64, 16).reshape(4, 4)
        range_min, range_max, n = _LIMITS.unpack_from(body, 128)
        at = 128 + _LIMITS.size
        angles = np.frombuffer(body, np.float64, n, at)
        ranges = np.frombuffer(body, np.float64, n, at + 8 * n)
        try:
            grid.insert_scan(pose, angles, ranges, range_min, range_max)
            outcomes.append(1)
        except GridTooLarge:
            outcomes.append(0)
        return None
    done = bytes(outcomes)
    outcomes.clear()
    if code == _MAP:
        data = grid.to_map().data.tobytes() if grid.logodds.size else b""
        return code, _state_bytes(grid, done, with_grid=False) + data
    if code == _SNAPSHOT:
        return code, _state_bytes(grid, done)
    if code == _OUTCOMES:
        return code, done
    raise ValueError(f"unknown request {code}")


def serve(stdin: BinaryIO | None = None, stdout: BinaryIO | None = None) -> None:
    """The child's loop: say it is ready, then answer requests until the input ends; an exception goes
    back as an error reply and ends the loop. A parent gone (its pipes closed, e.g. an interrupted
    replay) ends it quietly."""
    inp = stdin or sys.stdin.buffer
    out = stdout or open(sys.stdout.fileno(), "wb", buffering=0, closefd=False)  # nothing held back at exit
    try:
        _serve(inp, out)
    except OSError:  # BrokenPipeError and its kin: nobody is listening any more
        return


def _serve(inp: BinaryIO, out: BinaryIO) -> None:
    out.write(_FRAME.pack(_READY, 0))
    out.flush()
    params: OccupancyParams | None = None
    grid: OccupancyGrid2D | None = None
    outcomes = bytearray()
    while (head := _read(inp, _FRAME.size)) is not None:
        code, n = _FRAME.unpack(head)
        body = _read(inp, n) if n else b""
        if body is None:
            return
        try:
            if code == _PARAMS:
                params = OccupancyParams(**_params(json.loads(body)))
                continue
            if params is not None and code == _GRID:
                grid = _grid_from_bytes(params, body)
                continue
            if grid is None:
                raise ValueError(f"request {code} before the parameters and the grid")
            reply = _handle(grid, outcomes, code, body)
        except Exception:
            reply = (_ERROR, traceback.format_exc().encode())
        if reply is not None:
            out.write(_FRAME.pack(reply[0], len(reply[1])) + reply[1])
            out.flush()
            if reply[0] == _ERROR:
                return


def _params(values: dict[str, Any]) -> dict[str, Any]:
    """The parameters as JSON gives them back (its lists were tuples)."""
    return {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}
