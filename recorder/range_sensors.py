"""The 2D laser and the 3D LiDAR of a robot, in the simulator's process or in a worker process beside it.

``RangeSensors`` is the one implementation: it owns the Open3D scene of the world mesh and the two
noise streams (laser, LiDAR), and turns a request — the stamp, the sensor pose(s) and whether only
the recorder sees the topic — into the scan or the cloud: their CDR bytes (``raw``), or the values
their message objects are built from (the ranges; the cloud's columns).

``SensorWorker`` runs a ``RangeSensors`` in a child process (``navlog.replay.workers.ring``: a new
Python interpreter that imports only this module, never a fork, and does not run the caller's main
module again as multiprocessing's "spawn" would). The child imports Open3D and builds the world mesh
itself, so it is started before the simulator compiles its MuJoCo model and the two start-ups
overlap, and the simulator's process never imports Open3D. Requests (a few kB: the stamp and poses,
``_request_bytes``) are queued in the simulator's process while the pipe has no room (the child is
still importing Open3D, or fell behind), so the simulation runs on meanwhile; results (a sweep is
about 250 kB: CDR bytes, or arrays packed by ``_pack_arrays``) come back in request order through a
shared ring of ``RING_RESULTS`` of the largest results the spec can give, the pipe carrying those
that find no room. So the worker never waits on the simulator's process to write a result, and the
simulator never waits on the worker while a result is due.

When the simulation has ended and only waits for the results still to come (``ending``), the worker
casts the rest on every core instead of one (Open3D gives the same numbers either way): the
simulator's process leaves a core idle then. During the run the worker casts on one core: the
simulator's threads have the other.

The noise streams are the worker's, drawn in request order: the same numbers, so the same bytes, as
in the simulator's process. The worker is in a process group of its own and ignores SIGINT (Ctrl-C
stops the recording, which then ends the worker), and it ends when its request pipe closes, also when
the simulator's process is killed. An error in the worker, or its death, is raised in the simulator
as a ``NavlogError`` naming the sensor worker.

The simulator takes a result's place in the order before it has come (``Node.defer``), so the file
does not depend on when it came (``navlog.recorder.sim``).

``InProcessSensors`` has the same interface and computes each request as it is made.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.recorder import sensors
from navlog.recorder.robot import LaserConfig, LidarConfig, RobotSpec
from navlog.recorder.solids import Solid
from navlog.recorder.world import World, WorldSpec, world_mesh
from navlog.replay.config import from_mapping, to_mapping
from navlog.replay.workers.ring import RingProcess

SCAN, LIDAR = "scan", "lidar"
# a result's first byte tells what it is, without a tag to copy a sweep for: CDR bytes (of little-endian
# CDR, whose header starts with a zero byte), or arrays (``_pack_arrays``)
_CDR, _ARRAYS = 0x00, ord("A")
_SCAN_REQUEST = struct.Struct("<qB")  # stamp, raw; then the 4x4 pose (float64)
_LIDAR_REQUEST = struct.Struct("<qqIB")  # stamp, frame index, pose count, raw; then the times and poses
RING_RESULTS = 8  # the ring holds this many of the largest results the sensors can give (go2: 2 MB)
NAME = "sensor worker"  # how errors name the worker process
# the worker's numpy on one thread: its small matrix products gain nothing from more, and OpenBLAS's idle
# threads spin for a while after each, taking CPU time from the simulator's process (Open3D casts on one)
_ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _ring_size(spec: RangeSensorSpec) -> int:
    """Bytes of the result ring: ``RING_RESULTS`` of the largest scan or sweep (CDR, or its arrays: at most
    22 bytes a point either way, with a few kB of header)."""
    largest = 0
    if spec.scan is not None:
        largest = 4 * spec.scan.samples + 4096
    if spec.lidar is not None:
        lidar = spec.lidar
        rays = lidar.lines * lidar.columns if lidar.pattern == "velodyne" else lidar.points
        largest = max(largest, 22 * rays + 4096)
    return RING_RESULTS * largest


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


def worker_handler(spec: bytes) -> Callable[[bytes, bool], bytes]:
    """The worker process's side (``RingProcess``): the sensors built from ``_spec_bytes``, then each request
    (``_request_bytes``) computed into its result's bytes, on one core, or on every core once the simulator
    is ``ending`` (0: Open3D's every core; the same numbers either way)."""
    ranges = RangeSensors(_spec_from_bytes(spec))

    def handle(request: bytes, ending: bool) -> bytes:
        ranges.caster.threads = 0 if ending else 1
        out = ranges.compute(*_request_from_bytes(request))
        return out if isinstance(out, bytes) else _pack_arrays(out if isinstance(out, dict) else {"": out})

    return handle


class SensorWorker:
    """``RangeSensors`` in a child process (module docstring); the same ``request`` / ``result`` interface.

    ``ring_bytes``: the size of the shared result ring (default: ``RING_RESULTS`` of the largest result the
    spec can give); results that do not fit come through the pipe instead."""

    def __init__(self, spec: RangeSensorSpec, *, ring_bytes: int | None = None) -> None:
        self.ring = RingProcess(
            NAME,
            f"{__name__}:{worker_handler.__name__}",
            _spec_bytes(spec),
            _ring_size(spec) if ring_bytes is None else int(ring_bytes),
            run="recording",
            env=_ONE_THREAD,
        )

    def request(self, kind: str, args: tuple) -> int:
        """Ask for a scan (``args`` of ``RangeSensors.scan``) or a sweep (of ``RangeSensors.lidar``); a ticket."""
        return self.ring.request(_request_bytes(kind, args))

    def ready(self, ticket: int) -> bool:
        """True when the result of request ``ticket`` has come (``result`` returns it without waiting)."""
        return self.ring.ready(ticket)

    def result(self, ticket: int) -> Any:
        """The result of request ``ticket``, waiting for it: CDR bytes, a scan's ranges or a sweep's columns."""
        data = self.ring.result(ticket)
        if data[0] == _CDR:
            return data
        if data[0] == _ARRAYS:
            arrays = _unpack_arrays(data)
            return arrays[""] if list(arrays) == [""] else arrays
        raise NavlogError(f"{NAME}: a result of unknown kind {data[0]}")

    def ending(self) -> None:
        """The simulation has ended and only waits for the results still to come: the worker casts them on
        every core (module docstring)."""
        self.ring.ending()

    def close(self) -> None:
        """End the worker process and wait for it."""
        self.ring.close()


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
