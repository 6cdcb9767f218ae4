"""The occupancy grid's scan updates in a child process, beside the replay that produces the scans.

``GridWorker`` runs ``OccupancyGrid2D``'s scan updates (NumPy work the replay's thread would
otherwise wait for) in a child Python (``serve``, which imports only this module and the grid's) and takes the scans in order:

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

The two processes talk through ``navlog.replay.workers.child`` (frames of raw bytes, errors and a dead
child named, nothing left behind after a Ctrl-C).
"""

from __future__ import annotations

import dataclasses
import json
import struct
import subprocess
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.mapping.occupancy import GridTooLarge, OccupancyGrid2D, OccupancyParams, ScanStats
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.workers.child import ChildProcess
from navlog.replay.workers.child import serve as serve_requests

__all__ = ["GridWorker", "serve"]

# parent -> child: parameters, the grid handed over, a scan, requests (outcomes only, map, whole grid)
_PARAMS, _GRID, _INSERT, _OUTCOMES, _MAP, _SNAPSHOT = (ord(c) for c in "PGIOMS")
_LIMITS = struct.Struct("<ddI")  # range_min, range_max, beam count
_SHAPE = struct.Struct("<ddII")  # origin x, y; ny, nx
_STATS = [f.name for f in dataclasses.fields(ScanStats)]
_CHILD = "from navlog.replay.workers.grid import serve; serve()"


def _state_bytes(grid: OccupancyGrid2D, outcomes: bytes = b"", with_grid: bool = True) -> bytes:
    """``outcomes``, the origin and shape, then (``with_grid``) the statistics, log-odds and seen cells."""
    ny, nx = grid.logodds.shape
    head = outcomes + _SHAPE.pack(float(grid.origin[0]), float(grid.origin[1]), ny, nx)
    if not with_grid:
        return head
    stats = np.array([getattr(grid.stats, k) for k in _STATS], dtype=np.int64)
    return head + stats.tobytes() + grid.logodds.tobytes() + grid.seen.tobytes()


def _grid_from_bytes(params: OccupancyParams, body: bytes | bytearray) -> OccupancyGrid2D:
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
        self._child: ChildProcess | None = None
        if spawn:
            try:
                self._child = ChildProcess("occupancy grid process", _CHILD)
            except OSError:  # no child here (a process limit, no interpreter to run): the grid stays here
                return
            try:
                self._send(_PARAMS, json.dumps(dataclasses.asdict(params)).encode())
            except NavlogError:  # the child ended at once: the grid stays here
                pass

    @property
    def in_child(self) -> bool:
        """True once the child holds the grid."""
        return self.local is None

    @property
    def _process(self) -> subprocess.Popen | None:
        return self._child.process if self._child is not None else None

    # ------------------------------------------------------------ the caller's side
    def insert_scan(
        self, pose: np.ndarray, angles: np.ndarray, ranges: np.ndarray, range_min: float, range_max: float
    ) -> None:
        """Insert a scan (``OccupancyGrid2D.insert_scan``'s arguments); its outcome comes with ``outcomes``."""
        a = np.ascontiguousarray(angles, dtype=np.float64)
        r = np.ascontiguousarray(ranges, dtype=np.float64)
        if len(a) != len(r):
            raise ValueError(f"{len(a)} beam angles for {len(r)} ranges")
        if self.local is not None and self._child is not None and self._child.started():
            self._send(_GRID, _state_bytes(self.local))  # handed over
            self.local = None
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
        assert self._child is not None
        self._child.ask(_MAP)
        self._requests.append((self._sent, frame_id, reply))
        self._sent = 0

    def poll(self, at_most: int | None = None) -> None:
        """Take the replies to ``request_map`` that have come, in order, without waiting; with ``at_most``,
        then wait for the oldest until no more than that many are owed."""
        while self._requests and self._child is not None and self._child.reply_ready():
            self._take_request()
        while at_most is not None and len(self._requests) > at_most and self._child is not None:
            self._take_request()

    def _take_request(self) -> None:
        assert self._child is not None
        sent, frame_id, reply = self._requests.popleft()
        body = self._child.reply()
        self._outcomes.extend(bool(b) for b in body[:sent])
        reply(self._map(body[sent:], frame_id))

    def _map(self, body: bytes | bytearray, frame_id: str) -> OccupancyMap | None:
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
        if self._child is not None:
            self._child.close()

    def __del__(self) -> None:
        self.close()

    # ------------------------------------------------------------ talking to the child
    def _send(self, op: int, payload: bytes) -> None:
        if self._child is None:
            raise NavlogError("occupancy grid process: not started")
        self._child.send(op, payload)

    def _ask(self, op: int) -> bytes | bytearray:
        """Send request ``op``; its reply (after every scan sent, and the replies asked for before), without
        the outcomes it starts with."""
        assert self._child is not None
        self._child.ask(op)
        while self._requests:
            self._take_request()
        body = self._child.reply()
        self._outcomes.extend(bool(b) for b in body[: self._sent])
        body, self._sent = body[self._sent :], 0
        return body


# ------------------------------------------------------------ the child's side
def _handle(grid: OccupancyGrid2D, outcomes: bytearray, code: int, body: bytes | bytearray) -> tuple[int, bytes] | None:
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


class _GridServer:
    """The child's grid: the parameters, then the grid handed over, then scans and requests."""

    def __init__(self) -> None:
        self.params: OccupancyParams | None = None
        self.grid: OccupancyGrid2D | None = None
        self.outcomes = bytearray()

    def __call__(self, code: int, body: bytes | bytearray) -> tuple[int, bytes] | None:
        if code == _PARAMS:
            self.params = OccupancyParams(**_params(json.loads(body)))
            return None
        if self.params is not None and code == _GRID:
            self.grid = _grid_from_bytes(self.params, body)
            return None
        if self.grid is None:
            raise ValueError(f"request {code} before the parameters and the grid")
        return _handle(self.grid, self.outcomes, code, body)


def serve() -> None:
    """The child's loop (``navlog.replay.workers.child.serve``) over the grid's requests."""
    serve_requests(_GridServer())


def _params(values: dict[str, Any]) -> dict[str, Any]:
    """The parameters as JSON gives them back (its lists were tuples)."""
    return {k: tuple(v) if isinstance(v, list) else v for k, v in values.items()}
