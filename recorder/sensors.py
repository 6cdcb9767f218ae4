"""Sensor models: ray patterns, ray casting against the world mesh, and noise.

Everything here is pure given poses and a random generator: the simulator node decides when a
sensor fires and at which poses. Ray casting uses Open3D's RaycastingScene on the world's static
mesh (the robot is not in it, so sensors never see their own body).

A scan and a cloud are built either as message objects (``scan_message``, ``make_cloud`` of
``LidarReturns.columns()``) for nodes that subscribe, or as their CDR bytes directly (``scan_cdr``,
``cloud_cdr``; ``returns_cdr`` packs a sweep's points straight from its returns; through
``navlog.replay.io.cdr``) for the recorder alone: the same bytes, without the objects.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from navlog.recorder.robot import LaserConfig, LidarConfig, Mount
from navlog.replay import messages
from navlog.replay.geometry import make_transform, quat_from_rpy
from navlog.replay.io.cdr import layout
from navlog.replay.pointcloud import VELODYNE_FIELDS, VELODYNE_POINT_STEP, cloud_dtype

_NS = 1_000_000_000
_NO_INTENSITIES = np.zeros(0, dtype=np.float32)
_NO_INTENSITIES.flags.writeable = False


def mount_matrix(mount: Mount) -> np.ndarray:
    x, y, z, roll, pitch, yaw = mount
    return make_transform((x, y, z), quat_from_rpy(roll, pitch, yaw))


class RayCaster:
    """Casts rays against a static triangle mesh; returns distances (inf for no hit) and normals.

    ``threads``: Open3D's threads for a cast (1; 0 for every core). Each ray's result is the same either way."""

    def __init__(self, mesh) -> None:
        import open3d as o3d

        self._o3d = o3d
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))
        self.threads = 1

    def _cast(self, origins: np.ndarray, directions: np.ndarray) -> dict:
        rays = np.empty((len(directions), 6), dtype=np.float32)
        rays[:, :3] = origins
        rays[:, 3:] = directions
        return self.scene.cast_rays(self._o3d.core.Tensor.from_numpy(rays), nthreads=self.threads)

    def cast(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        out = self._cast(origins, directions)
        return out["t_hit"].numpy().astype(np.float64), out["primitive_normals"].numpy().astype(np.float64)

    def cast_rays(self, rays: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``cast`` of rays already laid out as Open3D takes them: float32 (N, 6), origin then direction."""
        out = self.scene.cast_rays(self._o3d.core.Tensor.from_numpy(rays), nthreads=self.threads)
        return out["t_hit"].numpy().astype(np.float64), out["primitive_normals"].numpy().astype(np.float64)

    def cast_distances(self, origins: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """Distances only (float64, inf for no hit): ``cast`` without the normals."""
        return self._cast(origins, directions)["t_hit"].numpy().astype(np.float64)


# ---------------------------------------------------------------- 2D laser


def laser_directions(cfg: LaserConfig) -> tuple[np.ndarray, float]:
    """Unit directions (N, 3) in the sensor frame and the angle increment (computed once per config)."""
    return _laser_directions(cfg)


@lru_cache(maxsize=8)
def _laser_directions(cfg: LaserConfig) -> tuple[np.ndarray, float]:
    inc = (cfg.angle_max - cfg.angle_min) / cfg.samples
    ang = cfg.angle_min + inc * np.arange(cfg.samples)
    dirs = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1)
    dirs.flags.writeable = False
    return dirs, inc


def laser_ranges(caster: RayCaster, cfg: LaserConfig, pose: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
    """Ranges (float32) of one scan taken at sensor pose ``pose`` (4x4, world frame).

    No return within range_max is +inf; a return closer than range_min is -inf (REP 117).
    """
    dirs, _ = laser_directions(cfg)
    world_dirs = dirs @ pose[:3, :3].T
    origins = np.broadcast_to(pose[:3, 3], world_dirs.shape)
    dist = caster.cast_distances(origins, world_dirs)
    if rng is not None and cfg.noise_std > 0:
        dist = dist + rng.normal(0.0, cfg.noise_std, size=dist.shape)
    out = dist.copy()
    out[~np.isfinite(dist) | (dist > cfg.range_max)] = np.inf
    out[np.isfinite(dist) & (dist < cfg.range_min)] = -np.inf
    return out.astype(np.float32)


@lru_cache(maxsize=8)
def _scan_constants(cfg: LaserConfig) -> tuple[float, float, float, float, float, float]:
    _, inc = laser_directions(cfg)
    # float32 fields hold float32 values, so that live subscribers see what a replayed log gives back
    f = messages.f32
    return (
        f(cfg.angle_min),
        f(cfg.angle_min + inc * (cfg.samples - 1)),
        f(inc),
        f(1.0 / cfg.rate),
        f(cfg.range_min),
        f(cfg.range_max),
    )


def scan_message(ns: int, frame: str, cfg: LaserConfig, ranges: np.ndarray):
    angle_min, angle_max, inc, scan_time, range_min, range_max = _scan_constants(cfg)
    return messages.msg_class(messages.LASER_SCAN)(
        header=messages.header(ns, frame),
        angle_min=angle_min,
        angle_max=angle_max,
        angle_increment=inc,
        time_increment=0.0,
        scan_time=scan_time,
        range_min=range_min,
        range_max=range_max,
        ranges=np.asarray(ranges, dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )


def scan_cdr(ns: int, frame: str, cfg: LaserConfig, ranges: np.ndarray) -> bytes:
    """The CDR bytes of ``scan_message(ns, frame, cfg, ranges)``, encoded without building the message."""
    angle_min, angle_max, inc, scan_time, range_min, range_max = _scan_constants(cfg)
    sec, nsec = divmod(ns, _NS)
    return layout(messages.LASER_SCAN).encode(
        (sec, nsec, frame, angle_min, angle_max, inc, 0.0, scan_time, range_min, range_max, ranges, _NO_INTENSITIES)
    )


# ---------------------------------------------------------------- 3D LiDAR


def lidar_pattern(cfg: LidarConfig, frame_index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """See ``_lidar_pattern``; the velodyne pattern is the same every frame and is computed once."""
    return _lidar_pattern(cfg, 0 if cfg.pattern == "velodyne" else frame_index)


@lru_cache(maxsize=4)
def _lidar_pattern(cfg: LidarConfig, frame_index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directions (N, 3) in the sensor frame, ring index (N,) and fraction of the sweep (N,) in [0, 1).

    ``velodyne``: ``lines`` rings evenly over the vertical field of view, ``columns`` azimuth steps,
    swept column by column. ``livox_mid360``: a non-repetitive pattern: azimuth advances by the
    golden angle and elevation follows an incommensurate oscillation, shifted every frame, so that
    successive frames cover different directions; points are spread evenly over the sweep.
    """
    lo, hi = np.radians(cfg.vertical_fov[0]), np.radians(cfg.vertical_fov[1])
    if cfg.pattern == "velodyne":
        elev = np.linspace(lo, hi, cfg.lines) if cfg.lines > 1 else np.array([(lo + hi) / 2])
        col = np.arange(cfg.columns)
        azim = -math.pi + 2 * math.pi * col / cfg.columns
        az_grid, el_grid = np.meshgrid(azim, elev, indexing="ij")  # column-major: all rings of a column together
        ring = np.broadcast_to(np.arange(cfg.lines), az_grid.shape).ravel()
        frac = np.broadcast_to((col / cfg.columns)[:, None], az_grid.shape).ravel()
        az, el = az_grid.ravel(), el_grid.ravel()
    else:
        k = np.arange(cfg.points, dtype=np.float64) + frame_index * cfg.points
        golden = math.pi * (3.0 - math.sqrt(5.0))
        az = np.mod(k * golden, 2 * math.pi) - math.pi
        phase = np.mod(k * (math.sqrt(2.0) - 1.0) * 0.013 + frame_index * 0.371, 1.0)
        el = lo + (hi - lo) * (0.5 - 0.5 * np.cos(2 * math.pi * phase))
        ring = (np.arange(cfg.points) % 4).astype(np.int64)
        frac = np.arange(cfg.points) / cfg.points
    dirs = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)], axis=1)
    return dirs, ring.astype(np.uint16), frac


@lru_cache(maxsize=8)
def _sweep_timing(cfg: LidarConfig, frame_index: int, pose_times: tuple[float, ...]):
    """Per-point times (float32, as published), and the runs of points cast from each pose of the window.

    Returns (times, runs, per-point pose index); runs is a list of (pose index, start, end), or None
    when the pose index does not grow along the sweep (then every point picks its pose itself).
    """
    _, _, frac = lidar_pattern(cfg, frame_index)
    period = 1.0 / cfg.rate
    t_rel = -period + (frac + 1.0 / max(len(frac), 1)) * period  # last point at 0
    idx = np.clip(np.searchsorted(np.array(pose_times), t_rel, side="left"), 0, len(pose_times) - 1)
    runs = None
    if np.all(np.diff(idx) >= 0):
        bounds = np.flatnonzero(np.diff(idx)) + 1
        starts = np.concatenate([[0], bounds])
        ends = np.concatenate([bounds, [len(idx)]])
        runs = [(int(idx[a]), int(a), int(b)) for a, b in zip(starts, ends)]
    t32 = t_rel.astype(np.float32)
    for arr in (t32, idx):
        arr.flags.writeable = False
    return t32, runs, idx


def _run_rays(
    dirs: np.ndarray, runs: list[tuple[int, int, int]], poses: list[tuple[float, np.ndarray]], *, at_once: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """World directions (float64) and Open3D's rays (float32 origin, direction) of the rays ``dirs`` (sensor
    frame) grouped in runs (pose index, start, end) cast from one pose each: one matrix product per run, or,
    ``at_once`` and the runs of one length (a velodyne sweep), all in one call, with the same results."""
    world_dirs = np.empty_like(dirs)
    rays = np.empty((len(dirs), 6), dtype=np.float32)
    length = runs[0][2] - runs[0][1]
    if at_once and all(b - a == length for _, a, b in runs):
        k, start, end = len(runs), runs[0][1], runs[-1][2]
        stack = np.stack([poses[i][1] for i, _, _ in runs])
        # the same BLAS product for each run as one call per run gives (a stack is multiplied item by item), the
        # transposed rotations made contiguous, which BLAS multiplies several times faster
        rot_t = np.ascontiguousarray(stack[:, :3, :3].transpose(0, 2, 1))
        np.matmul(dirs[start:end].reshape(k, length, 3), rot_t, out=world_dirs[start:end].reshape(k, length, 3))
        rays[start:end, :3].reshape(k, length, 3)[:] = stack[:, None, :3, 3]
    else:
        for i, a, b in runs:
            pose = poses[i][1]
            np.matmul(dirs[a:b], pose[:3, :3].T, out=world_dirs[a:b])
            rays[a:b, :3] = pose[:3, 3]
    rays[:, 3:] = world_dirs  # rounded to float32 as they are copied (as astype rounds), with no array between
    return world_dirs, rays


class LidarReturns(NamedTuple):
    """The returns of a sweep (``lidar_returns``): every ray that returned within range."""

    distance: np.ndarray  # m (float64)
    directions: np.ndarray  # unit directions in the sensor frame at each ray's time (N, 3)
    intensity: np.ndarray  # 255 |cos(incidence)| exp(-distance / 20) (float64)
    ring: np.ndarray  # uint16; may be a read-only cached array
    time: np.ndarray  # s from the stamp (float32); may be a read-only cached array

    def columns(self) -> dict[str, np.ndarray]:
        """The cloud's columns (``navlog.replay.pointcloud.make_cloud``): the points in float32, new arrays."""
        d, dirs = self.distance, self.directions
        return {
            "x": (dirs[:, 0] * d).astype(np.float32),
            "y": (dirs[:, 1] * d).astype(np.float32),
            "z": (dirs[:, 2] * d).astype(np.float32),
            "intensity": self.intensity.astype(np.float32),
            "ring": self.ring.copy(),
            "time": self.time.copy(),
        }


def lidar_returns(
    caster: RayCaster,
    cfg: LidarConfig,
    frame_index: int,
    poses: list[tuple[float, np.ndarray]],
    rng: np.random.Generator | None,
) -> LidarReturns:
    """One sweep: each ray is cast from the sensor pose at its own time (motion distortion included).

    ``poses`` are (time offset from the stamp in s, 4x4 sensor pose) spanning the sweep, oldest first;
    the stamp is the end of the sweep, so point times are in [-1/rate, 0]. Points are expressed in
    the sensor frame at their capture time, as a real spinning sensor reports them. ``.columns()`` gives
    the cloud's columns, ``returns_cdr`` its CDR bytes.
    """
    dirs, ring, _ = lidar_pattern(cfg, frame_index)
    pattern_index = 0 if cfg.pattern == "velodyne" else frame_index
    t32, runs, idx = _sweep_timing(cfg, pattern_index, tuple(p[0] for p in poses))
    # rays are grouped by the pose they are cast from: one matrix product per pose
    if runs is not None:
        world_dirs, rays = _run_rays(dirs, runs, poses)
        dist, normals = caster.cast_rays(rays)
    else:
        rots = np.stack([p[1][:3, :3] for p in poses])
        world_dirs = np.einsum("nij,nj->ni", rots[idx], dirs)
        origins = np.stack([p[1][:3, 3] for p in poses])[idx]
        dist, normals = caster.cast(origins, world_dirs)
    if rng is not None and cfg.noise_std > 0:
        dist += rng.normal(0.0, cfg.noise_std, size=dist.shape)
    # the two comparisons alone keep exactly the finite returns within range: +inf (a miss) fails the
    # upper bound, -inf the lower one, NaN both
    ok = (dist >= cfg.range_min) & (dist <= cfg.range_max)
    cos = np.einsum("ij,ij->i", normals, world_dirs)
    if ok.all():  # the usual case indoors: every ray returns; no selection copies
        d, dirs_ok, ring_ok, t_ok = dist, dirs, ring, t32
    else:
        sel = np.flatnonzero(ok)  # ``take``: the same copies as fancy indexing, several times faster for rows
        d, dirs_ok, cos, ring_ok, t_ok = (
            dist.take(sel),
            dirs.take(sel, axis=0),
            cos.take(sel),
            ring.take(sel),
            t32.take(sel),
        )
    # intensity = 255 |cos| exp(-d / 20), evaluated in place where that cannot change a bit
    np.abs(cos, out=cos)
    cos *= 255.0
    fade = d / 20.0
    np.negative(fade, out=fade)
    cos *= np.exp(fade)
    return LidarReturns(d, dirs_ok, cos, ring_ok, t_ok)


@lru_cache(maxsize=1)
def _cloud_layout() -> tuple[np.dtype, tuple[tuple[str, int, int, int], ...]]:
    """The LiDAR cloud's point dtype and its PointField values (name, offset, datatype, count)."""
    PointField = messages.msg_class(messages.POINT_FIELD)
    fields = [PointField(name=name, offset=off, datatype=code, count=1) for name, off, code in VELODYNE_FIELDS]
    return cloud_dtype(fields, VELODYNE_POINT_STEP), tuple((name, off, code, 1) for name, off, code in VELODYNE_FIELDS)


def cloud_cdr(ns: int, frame: str, columns: dict[str, np.ndarray]) -> bytes:
    """The CDR bytes of ``navlog.replay.pointcloud.make_cloud(ns, frame, columns)`` (the Velodyne layout),
    encoded without building the message: the points are packed once and copied once into the bytes."""
    dtype, _ = _cloud_layout()
    n = len(next(iter(columns.values()))) if columns else 0
    points = np.zeros(n, dtype=dtype)
    for name, _, _ in VELODYNE_FIELDS:
        if name in columns:
            points[name] = columns[name]
    return _points_cdr(ns, frame, points)


def returns_cdr(ns: int, frame: str, returns: LidarReturns) -> bytes:
    """``cloud_cdr(ns, frame, returns.columns())``: the same bytes, the points packed straight from the returns."""
    dtype, _ = _cloud_layout()
    points = np.empty(len(returns.distance), dtype=dtype)  # the fields fill every byte of a point
    for i, name in enumerate("xyz"):  # float64 products rounded to float32 as they are stored, as astype does
        np.multiply(returns.directions[:, i], returns.distance, out=points[name], casting="same_kind")
    points["intensity"] = returns.intensity
    points["ring"] = returns.ring
    points["time"] = returns.time
    return _points_cdr(ns, frame, points)


def _points_cdr(ns: int, frame: str, points: np.ndarray) -> bytes:
    """The CDR bytes of a cloud of ``points`` (of the Velodyne layout's dtype), copied once into them."""
    _, fields = _cloud_layout()
    sec, nsec = divmod(ns, _NS)
    step, n = VELODYNE_POINT_STEP, len(points)
    return layout(messages.POINT_CLOUD2).encode(
        (sec, nsec, frame, 1, n, fields, False, step, step * n, points.view(np.uint8), True)
    )
