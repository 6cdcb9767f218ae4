"""LiDAR odometry and mapping (the FAST-LIO role), as pure computation on numpy arrays.

Per frame (points in the sensor frame, per-point times in seconds after the frame stamp):

1. range filter (``min_range``..``max_range`` in the sensor frame), sensor -> base_link;
2. deskew: every point is moved into base_link *at the frame stamp*, using the motion of the
   sweep sampled at ``deskew_slots`` times: rotation from the integrated gyro when it covers the
   sweep, translation from the odometry prior when it covers it, else the constant velocity of the
   last two registered frames;
3. initial guess: the last pose composed with the prior's relative motion between the two stamps
   (gyro rotation / odometry / constant velocity, in that order of preference);
4. scan-to-local-map ICP with Open3D's legacy ``o3d.pipelines.registration`` (point-to-plane by
   default, generalized ICP optional) on the scan voxel-filtered at ``scan_voxel``;
5. keyframes (every ``keyframe_distance`` m or ``keyframe_angle_deg``) are merged into the local
   map (one point per ``map_voxel`` voxel, cropped to ``local_map_radius``); normals are
   estimated per keyframe only for its new points and their neighbours (covariances for GICP);
6. every registered frame is accumulated into one running per-voxel mean (``save_voxel``,
   FAST-LIO's ``interval: -1``), and optionally into chunks of ``save_every_n_frames`` frames.

Poses are base_link in the map frame (4x4); the map frame is the first frame's base_link unless an
initial pose is given. Open3D runs on ``threads`` threads (1 by default) during each call, so the
same input gives the same bytes; the previous limit is restored afterwards.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

_reg = o3d.pipelines.registration

Method = Literal["point_to_plane", "gicp"]


@dataclass(frozen=True)
class LidarOdometryParams:
    """Parameters of the LiDAR odometry; distances in metres."""

    min_range: float = 0.3
    max_range: float = 30.0
    scan_voxel: float = 0.25  # scan downsampling for registration
    map_voxel: float = 0.1  # local map resolution
    method: Method = "point_to_plane"
    max_correspondence: float = 0.3
    max_iterations: int = 30
    convergence: float = 1e-6  # relative fitness and RMSE change that stops ICP
    min_fitness: float = 0.3  # below it a registration is rejected and the prediction kept
    normal_radius: float = 0.3
    normal_max_nn: int = 20
    local_map_radius: float = 15.0
    local_map_max_points: int = 150_000
    keyframe_distance: float = 0.25
    keyframe_angle_deg: float = 15.0
    deskew: bool = True
    deskew_slots: int = 20
    save_voxel: float = 0.05  # global map resolution (the saved PCD)
    save_every_n_frames: int = 0  # > 0: also keep a chunk of every N frames
    min_points: int = 100  # fewer valid points after filtering: the frame is skipped
    threads: int = 1  # Open3D threads during a call; 1 keeps results bit-identical

    def __post_init__(self) -> None:
        positive = (
            "max_range",
            "scan_voxel",
            "map_voxel",
            "max_correspondence",
            "normal_radius",
            "local_map_radius",
            "save_voxel",
        )
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if not 0 <= self.min_range < self.max_range:
            raise ValueError(f"min_range must be in [0, max_range), got {self.min_range}")
        if self.method not in ("point_to_plane", "gicp"):
            raise ValueError(f"method must be point_to_plane or gicp, got {self.method!r}")
        for name in ("max_iterations", "normal_max_nn", "local_map_max_points", "deskew_slots", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be at least 1, got {getattr(self, name)}")
        if (
            self.save_every_n_frames < 0
            or self.min_points < 0
            or self.keyframe_distance < 0
            or self.keyframe_angle_deg < 0
        ):
            raise ValueError("save_every_n_frames, min_points and keyframe spacing must not be negative")


# ------------------------------------------------------------------ motion priors


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions in (x, y, z, w) order."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


def _quat_exp(rotvec: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return np.array([0.5 * rotvec[0], 0.5 * rotvec[1], 0.5 * rotvec[2], 1.0])
    axis = rotvec / angle
    return np.concatenate([axis * math.sin(angle / 2), [math.cos(angle / 2)]])


def _quats_to_matrices(q: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotation matrices of unit quaternions (K, 4) in (x, y, z, w) order."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    out = np.empty((len(q), 3, 3))
    out[:, 0, 0] = 1 - 2 * (y * y + z * z)
    out[:, 0, 1] = 2 * (x * y - z * w)
    out[:, 0, 2] = 2 * (x * z + y * w)
    out[:, 1, 0] = 2 * (x * y + z * w)
    out[:, 1, 1] = 1 - 2 * (x * x + z * z)
    out[:, 1, 2] = 2 * (y * z - x * w)
    out[:, 2, 0] = 2 * (x * z - y * w)
    out[:, 2, 1] = 2 * (y * z + x * w)
    out[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def _quats_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton products of (K, 4) quaternions in (x, y, z, w) order."""
    ax, ay, az, aw = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    bx, by, bz, bw = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=1,
    )


def _slerp(q0: np.ndarray, q1: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Row-wise shortest-path slerp of unit quaternions (K, 4) at fractions ``a`` (K,)."""
    dot = np.sum(q0 * q1, axis=1)
    q1 = np.where(dot[:, None] < 0, -q1, q1)
    dot = np.minimum(np.abs(dot), 1.0)
    theta = np.arccos(dot)
    s = np.sin(theta)
    small = s < 1e-9
    s_safe = np.where(small, 1.0, s)
    w0 = np.where(small, 1.0 - a, np.sin((1.0 - a) * theta) / s_safe)
    w1 = np.where(small, a, np.sin(a * theta) / s_safe)
    q = w0[:, None] * q0 + w1[:, None] * q1
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _rotvecs_to_matrices(v: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotation matrices of rotation vectors (K, 3) (Rodrigues' formula)."""
    angle = np.linalg.norm(v, axis=1)
    half = 0.5 * angle
    small = angle < 1e-12
    scale = np.where(small, 0.5, np.sin(half) / np.where(small, 1.0, angle))
    q = np.concatenate([v * scale[:, None], np.cos(half)[:, None]], axis=1)
    return _quats_to_matrices(q)


def _matrices_to_quats(r: np.ndarray) -> np.ndarray:
    """(K, 4) unit quaternions (x, y, z, w) of rotation matrices (K, 3, 3) (Shepperd's method)."""
    m = np.asarray(r, dtype=np.float64).reshape(-1, 3, 3)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    d = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2], tr], axis=1)
    choice = np.argmax(d, axis=1)
    q = np.empty((len(m), 4))
    for c in range(4):
        sel = choice == c
        if not sel.any():
            continue
        s = m[sel]
        if c == 3:
            w = np.sqrt(1.0 + tr[sel]) * 2
            q[sel] = np.stack(
                [(s[:, 2, 1] - s[:, 1, 2]) / w, (s[:, 0, 2] - s[:, 2, 0]) / w, (s[:, 1, 0] - s[:, 0, 1]) / w, 0.25 * w],
                axis=1,
            )
        else:
            i, j, k = c, (c + 1) % 3, (c + 2) % 3
            f = np.sqrt(1.0 + s[:, i, i] - s[:, j, j] - s[:, k, k]) * 2
            out = np.empty((len(s), 4))
            out[:, i] = 0.25 * f
            out[:, j] = (s[:, j, i] + s[:, i, j]) / f
            out[:, k] = (s[:, k, i] + s[:, i, k]) / f
            out[:, 3] = (s[:, k, j] - s[:, j, k]) / f
            q[sel] = out
    return q / np.linalg.norm(q, axis=1, keepdims=True)


class GyroTrack:
    """Angular velocity samples of base_link, integrated as they arrive (midpoint rule) into an
    orientation track; rotations between two times are read from it by slerp."""

    def __init__(self, keep_ns: int = 2_000_000_000) -> None:
        self.keep_ns = keep_ns
        self._t: list[int] = []
        self._w: list[np.ndarray] = []
        self._q: list[np.ndarray] = []  # integrated orientation at each sample (arbitrary origin)
        self.out_of_order = 0

    def add(self, t_ns: int, omega) -> None:
        w = np.asarray(omega, dtype=np.float64)
        if self._t and t_ns <= self._t[-1]:
            self.out_of_order += 1
            return
        if not self._t:
            q = np.array([0.0, 0.0, 0.0, 1.0])
        else:
            dt = (t_ns - self._t[-1]) * 1e-9
            q = _quat_mul(self._q[-1], _quat_exp(0.5 * (w + self._w[-1]) * dt))
            q /= np.linalg.norm(q)
        self._t.append(int(t_ns))
        self._w.append(w)
        self._q.append(q)
        if self._t[-1] - self._t[0] > 2 * self.keep_ns:
            drop = bisect.bisect_left(self._t, self._t[-1] - self.keep_ns)
            del self._t[:drop], self._w[:drop], self._q[:drop]

    @property
    def last_ns(self) -> int | None:
        return self._t[-1] if self._t else None

    def covers(self, t0_ns: int, t1_ns: int) -> bool:
        return bool(self._t) and self._t[0] <= min(t0_ns, t1_ns) and self._t[-1] >= max(t0_ns, t1_ns)

    def relative_rotations(self, t_ref_ns: int, query_ns: np.ndarray) -> np.ndarray | None:
        """(K, 3, 3): base_link at ``t_ref`` <- base_link at each query time, or None if not covered."""
        q = np.asarray(query_ns, dtype=np.int64)
        lo, hi = int(min(t_ref_ns, q.min())), int(max(t_ref_ns, q.max()))
        if not self.covers(lo, hi):
            return None
        i0 = max(bisect.bisect_right(self._t, lo) - 1, 0)
        i1 = min(bisect.bisect_left(self._t, hi), len(self._t) - 1)
        if i1 == i0:
            return np.tile(np.eye(3), (len(q), 1, 1))
        ts = np.asarray(self._t[i0 : i1 + 1], dtype=np.int64)
        qs = np.asarray(self._q[i0 : i1 + 1])
        both = np.concatenate([[t_ref_ns], q])  # the reference first
        k = np.clip(np.searchsorted(ts, both, side="right") - 1, 0, len(ts) - 2)
        a = np.clip((both - ts[k]) / (ts[k + 1] - ts[k]), 0.0, 1.0)
        r = _slerp(qs[k], qs[k + 1], a)
        ref_inv = r[0:1] * np.array([-1.0, -1.0, -1.0, 1.0])
        return _quats_to_matrices(_quats_mul(np.repeat(ref_inv, len(q), axis=0), r[1:]))


class PoseTrack:
    """Timed poses of base_link in some odometry frame (e.g. /odom); relative motion between times."""

    def __init__(self, keep_ns: int = 2_000_000_000) -> None:
        self.keep_ns = keep_ns
        self._t: list[int] = []
        self._p: list[np.ndarray] = []
        self.out_of_order = 0

    def add(self, t_ns: int, pose: np.ndarray) -> None:
        if self._t and t_ns <= self._t[-1]:
            self.out_of_order += 1
            return
        self._t.append(int(t_ns))
        self._p.append(np.asarray(pose, dtype=np.float64))
        if self._t[-1] - self._t[0] > 2 * self.keep_ns:
            drop = bisect.bisect_left(self._t, self._t[-1] - self.keep_ns)
            del self._t[:drop], self._p[:drop]

    @property
    def last_ns(self) -> int | None:
        return self._t[-1] if self._t else None

    def covers(self, t0_ns: int, t1_ns: int) -> bool:
        return bool(self._t) and self._t[0] <= min(t0_ns, t1_ns) and self._t[-1] >= max(t0_ns, t1_ns)

    def poses(self, query_ns: np.ndarray) -> np.ndarray:
        """(K, 4, 4) interpolated poses (linear translation, slerp rotation); times must be covered."""
        q = np.asarray(query_ns, dtype=np.int64)
        t = np.asarray(self._t, dtype=np.int64)
        i = np.clip(np.searchsorted(t, q, side="right") - 1, 0, max(len(t) - 2, 0))
        out = np.tile(np.eye(4), (len(q), 1, 1))
        if len(t) == 1:
            out[:] = self._p[0]
            return out
        p0 = np.asarray([self._p[k] for k in i])  # only the poses around the queries
        p1 = np.asarray([self._p[k + 1] for k in i])
        a = np.clip((q - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0)
        r0, r1 = p0[:, :3, :3], p1[:, :3, :3]
        delta = _matrices_to_quats(np.transpose(r0, (0, 2, 1)) @ r1)  # r0 <- r1
        identity = np.tile([0.0, 0.0, 0.0, 1.0], (len(q), 1))
        out[:, :3, :3] = r0 @ _quats_to_matrices(_slerp(identity, delta, a))
        out[:, :3, 3] = (1 - a)[:, None] * p0[:, :3, 3] + a[:, None] * p1[:, :3, 3]
        return out

    def relative(self, t_ref_ns: int, query_ns: np.ndarray) -> np.ndarray | None:
        """(K, 4, 4): pose at ``t_ref`` <- pose at each query time, or None if not covered."""
        q = np.asarray(query_ns, dtype=np.int64)
        if not self.covers(int(min(t_ref_ns, q.min())), int(max(t_ref_ns, q.max()))):
            return None
        both = self.poses(np.concatenate([[t_ref_ns], q]))  # the reference first
        return np.linalg.inv(both[0]) @ both[1:]


@dataclass
class MotionPrior:
    """What the odometry may use besides the LiDAR: a gyro track and/or an odometry track."""

    gyro: GyroTrack | None = None
    odom: PoseTrack | None = None


# ------------------------------------------------------------------ results


@dataclass
class FrameResult:
    stamp_ns: int
    pose: np.ndarray  # base_link in map, 4x4
    points_map: np.ndarray  # (N, 3) deskewed points of the frame in the map frame
    fitness: float
    rmse: float
    keyframe: bool
    velocity: np.ndarray  # (6,) body-frame linear and angular velocity (vx vy vz wx wy wz)


@dataclass
class _Motion:
    """Body-frame constant velocity from the last two registered frames."""

    v: np.ndarray = field(default_factory=lambda: np.zeros(3))
    w: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def relative(self, dt: np.ndarray) -> np.ndarray:
        dt = np.asarray(dt, dtype=np.float64)
        out = np.tile(np.eye(4), (len(dt), 1, 1))
        out[:, :3, :3] = _rotvecs_to_matrices(self.w[None, :] * dt[:, None])
        out[:, :3, 3] = self.v[None, :] * dt[:, None]
        return out


def _rotation_angle(r: np.ndarray) -> float:
    return math.acos(max(-1.0, min(1.0, (float(np.trace(r)) - 1.0) / 2.0)))


def _pcd(points: np.ndarray) -> o3d.geometry.PointCloud:
    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.ascontiguousarray(points, dtype=np.float64)))


def sorted_points(points: np.ndarray, voxel: float) -> np.ndarray:
    """Points in a deterministic order: by voxel index (x, then y, then z), then by coordinates."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0:
        return p
    key = np.floor(p / voxel).astype(np.int64)
    order = np.lexsort((p[:, 2], p[:, 1], p[:, 0], key[:, 2], key[:, 1], key[:, 0]))
    return p[order]


_KEY_BITS = 21  # voxel indices within +-2**20 of the origin on each axis
_KEY_OFFSET = 1 << (_KEY_BITS - 1)


def voxel_keys(points: np.ndarray, voxel: float) -> np.ndarray:
    """One int64 per point naming its voxel; ordered by x index, then y, then z. The grid is fixed
    (keys stay valid as a map grows) and centred on the origin: voxel centres at multiples of
    ``voxel``, so a surface at a round coordinate falls inside one layer of voxels, not across two."""
    k = np.floor(points / voxel + 0.5).astype(np.int64) + _KEY_OFFSET
    return (k[:, 0] << (2 * _KEY_BITS)) | (k[:, 1] << _KEY_BITS) | k[:, 2]


def voxel_sums(points: np.ndarray, voxel: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sorted unique voxel keys, per-voxel coordinate sums (M, 3), per-voxel counts (M,))."""
    keys = voxel_keys(points, voxel)
    uk, inv = np.unique(keys, return_inverse=True)
    counts = np.bincount(inv, minlength=len(uk))
    sums = np.stack([np.bincount(inv, weights=points[:, d], minlength=len(uk)) for d in range(3)], axis=1)
    return uk, sums, counts


class VoxelStore:
    """A running voxel filter: per-voxel sums and counts under sorted keys; the points are the
    per-voxel means of everything added (what one voxel filter of all the points would give)."""

    def __init__(self, voxel: float) -> None:
        self.voxel = voxel
        self.keys = np.zeros(0, dtype=np.int64)
        self.sums = np.zeros((0, 3))
        self.counts = np.zeros(0, dtype=np.int64)

    def add(self, points: np.ndarray) -> None:
        if len(points) == 0:
            return
        uk, sums, counts = voxel_sums(points, self.voxel)
        pos = np.searchsorted(self.keys, uk)
        found = pos < len(self.keys)
        found[found] = self.keys[pos[found]] == uk[found]
        self.sums[pos[found]] += sums[found]
        self.counts[pos[found]] += counts[found]
        fresh = ~found
        if fresh.any():
            at = pos[fresh]
            self.keys = np.insert(self.keys, at, uk[fresh])
            self.sums = np.insert(self.sums, at, sums[fresh], axis=0)
            self.counts = np.insert(self.counts, at, counts[fresh])

    def points(self) -> np.ndarray:
        return self.sums / self.counts[:, None]

    def __len__(self) -> int:
        return len(self.keys)


class _Threads:
    """Limit Open3D's threads for the duration of a call and restore the previous limit."""

    def __init__(self, n: int) -> None:
        self.n = n
        self.prev = 0

    def __enter__(self) -> None:
        self.prev = o3d.utility.get_max_threads()
        if self.prev != self.n:
            o3d.utility.set_max_threads(self.n)

    def __exit__(self, *exc) -> None:
        if self.prev != self.n:
            o3d.utility.set_max_threads(self.prev)


# ------------------------------------------------------------------ the odometry


class LidarOdometry:
    """Scan-to-local-map LiDAR odometry with deskew and a motion prior; see the module docstring."""

    def __init__(
        self,
        params: LidarOdometryParams = LidarOdometryParams(),
        extrinsic: np.ndarray | None = None,
        initial_pose: np.ndarray | None = None,
    ) -> None:
        self.params = params
        self.extrinsic = np.eye(4) if extrinsic is None else np.asarray(extrinsic, dtype=np.float64)  # base <- sensor
        self.initial_pose = np.eye(4) if initial_pose is None else np.asarray(initial_pose, dtype=np.float64)
        self.stamps: list[int] = []
        self.trajectory: list[np.ndarray] = []
        self.skipped: dict[str, int] = {}
        self.registrations = 0
        self._motion = _Motion()
        self._ref: tuple[int, np.ndarray] | None = None  # (time, pose) of the last registration
        self._local = o3d.geometry.PointCloud()
        self._local_keys = np.zeros(0, dtype=np.int64)  # sorted voxel keys of the local map points
        self._local_points = np.zeros((0, 3))
        self._local_normals = np.zeros((0, 3))
        self._last_key: np.ndarray | None = None
        self._global = VoxelStore(params.save_voxel)
        self._buffer: list[np.ndarray] = []
        self._buffered = 0
        self._chunk: list[np.ndarray] = []
        self._chunk_frames = 0
        self.chunks: list[np.ndarray] = []
        self._estimation = (
            _reg.TransformationEstimationPointToPlane()
            if params.method == "point_to_plane"
            else _reg.TransformationEstimationForGeneralizedICP()
        )
        self._criteria = _reg.ICPConvergenceCriteria(params.convergence, params.convergence, params.max_iterations)

    def _skip(self, reason: str) -> None:
        self.skipped[reason] = self.skipped.get(reason, 0) + 1

    # -------------------------------------------------- motion model
    def _relative(self, t_ref_ns: int, query_ns: np.ndarray, prior: MotionPrior | None) -> np.ndarray:
        """(K, 4, 4): base_link at ``t_ref`` <- base_link at each query time, from the best prior."""
        q_ns = np.asarray(query_ns, dtype=np.int64)
        rel = None
        if prior is not None and prior.odom is not None:
            rel = prior.odom.relative(t_ref_ns, q_ns)
        if rel is None:
            rel = self._motion.relative((q_ns - t_ref_ns) * 1e-9)
        if prior is not None and prior.gyro is not None:
            rot = prior.gyro.relative_rotations(t_ref_ns, q_ns)
            if rot is not None:
                rel = rel.copy()
                rel[:, :3, :3] = rot
        return rel

    def _deskew(
        self, pts: np.ndarray, times: np.ndarray, stamp_ns: int, ref_ns: int, prior: MotionPrior | None
    ) -> np.ndarray:
        """Points (base_link at their own times) moved into base_link at ``ref_ns``."""
        n = self.params.deskew_slots
        t_lo, t_hi = float(times.min()), float(times.max())
        if t_hi - t_lo <= 0:
            slot_t = np.array([t_lo])
            idx = np.zeros(len(times), dtype=np.int64)
        else:
            slot_t = np.linspace(t_lo, t_hi, n)
            idx = np.clip(np.round((times - t_lo) / (t_hi - t_lo) * (n - 1)).astype(np.int64), 0, n - 1)
        rel = self._relative(ref_ns, stamp_ns + np.round(slot_t * 1e9).astype(np.int64), prior)
        out = np.empty_like(pts)
        order = np.argsort(idx, kind="stable")
        bounds = np.searchsorted(idx[order], np.arange(len(slot_t) + 1))
        for k in range(len(slot_t)):
            sel = order[bounds[k] : bounds[k + 1]]
            if len(sel):
                out[sel] = pts[sel] @ rel[k, :3, :3].T + rel[k, :3, 3]
        return out

    # -------------------------------------------------- public API
    def process(
        self, stamp_ns: int, points: np.ndarray, times: np.ndarray | None = None, prior: MotionPrior | None = None
    ) -> FrameResult | None:
        """Register one frame; returns None (and counts why) when the frame cannot be used.

        With deskew, the scan is registered at the middle of its sweep (so that an error of the
        velocity used for deskewing stretches the scan symmetrically instead of shifting it, which
        would feed back into the next velocity estimate); the reported pose is moved to the stamp.
        """
        p = self.params
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        finite = np.isfinite(pts).all(axis=1)
        if times is not None:
            times = np.asarray(times, dtype=np.float64).reshape(-1)
            if len(times) != len(pts):
                self._skip("time_field_length_mismatch")
                return None
            finite &= np.isfinite(times)
        rng = np.linalg.norm(np.where(finite[:, None], pts, 0.0), axis=1)
        keep = finite & (rng >= p.min_range) & (rng <= p.max_range)
        pts = pts[keep]
        if len(pts) < max(p.min_points, 1):
            self._skip("too_few_points")
            return None
        if self.stamps and stamp_ns <= self.stamps[-1]:
            self._skip("stamp_not_increasing")
            return None
        base = pts @ self.extrinsic[:3, :3].T + self.extrinsic[:3, 3]
        ref_ns = stamp_ns
        if p.deskew and times is not None:
            t = times[keep]
            ref_ns = stamp_ns + int(round(0.5 * (float(t.min()) + float(t.max())) * 1e9))
            base = self._deskew(base, t, stamp_ns, ref_ns, prior)
        with _Threads(p.threads):
            return self._register(stamp_ns, ref_ns, base, prior)

    def _register(self, stamp_ns: int, ref_ns: int, base: np.ndarray, prior: MotionPrior | None) -> FrameResult:
        p = self.params
        frame = _pcd(base)
        if self._ref is None:
            pose = self.initial_pose.copy()
            if ref_ns != stamp_ns:  # the initial pose is given at the stamp
                pose = pose @ self._relative(stamp_ns, np.array([ref_ns]), prior)[0]
            fitness, rmse = 1.0, 0.0
        else:
            last_ns, last = self._ref
            guess = last @ self._relative(last_ns, np.array([ref_ns]), prior)[0]
            source = frame.voxel_down_sample(p.scan_voxel)
            if p.method == "gicp":
                source.estimate_covariances(o3d.geometry.KDTreeSearchParamKNN(p.normal_max_nn))
            result = _reg.registration_icp(
                source, self._local, p.max_correspondence, guess, self._estimation, self._criteria
            )
            self.registrations += 1
            fitness, rmse = float(result.fitness), float(result.inlier_rmse)
            if fitness < p.min_fitness:
                self._skip("registration_rejected")
                pose = guess
            else:
                pose = np.asarray(result.transformation, dtype=np.float64).copy()
            # constant-velocity model for the next frame, from the registration-time poses
            dt = (ref_ns - last_ns) * 1e-9
            rel = np.linalg.inv(last) @ pose
            self._motion = _Motion(rel[:3, 3] / dt, Rotation.from_matrix(rel[:3, :3]).as_rotvec() / dt)
        self._ref = (ref_ns, pose)
        out = pose if ref_ns == stamp_ns else pose @ self._relative(ref_ns, np.array([stamp_ns]), prior)[0]
        self.stamps.append(int(stamp_ns))
        self.trajectory.append(out)
        points_map = base @ pose[:3, :3].T + pose[:3, 3]
        keyframe = self._update_local_map(pose, points_map)
        self._accumulate(points_map)
        velocity = np.concatenate([self._motion.v, self._motion.w])
        return FrameResult(int(stamp_ns), out, points_map, fitness, rmse, keyframe, velocity)

    def _update_local_map(self, pose: np.ndarray, points_map: np.ndarray) -> bool:
        """Add a keyframe to the local map: one point per ``map_voxel`` voxel (a voxel keeps the
        point it got first, so the map does not shift under the registration), cropped around the
        pose; normals are estimated only for the new points and the map points within
        ``normal_radius`` of them (on the cloud of their neighbourhoods), the others keep theirs."""
        p = self.params
        if self._last_key is not None:
            rel = np.linalg.inv(self._last_key) @ pose
            moved = float(np.linalg.norm(rel[:3, 3]))
            turned = math.degrees(_rotation_angle(rel[:3, :3]))
            if moved < p.keyframe_distance and turned < p.keyframe_angle_deg:
                return False
        self._last_key = pose
        uk, sums, counts = voxel_sums(points_map, p.map_voxel)
        pos = np.searchsorted(self._local_keys, uk)
        found = pos < len(self._local_keys)
        found[found] = self._local_keys[pos[found]] == uk[found]
        fresh = ~found
        at = pos[fresh]
        keys = np.insert(self._local_keys, at, uk[fresh])
        pts = np.insert(self._local_points, at, sums[fresh] / counts[fresh, None], axis=0)
        normals = np.insert(self._local_normals, at, 0.0, axis=0)
        is_new = np.insert(np.zeros(len(self._local_keys), dtype=bool), at, True)
        dist = np.linalg.norm(pts - pose[:3, 3], axis=1)
        keep = np.nonzero(dist <= p.local_map_radius)[0]
        if len(keep) > p.local_map_max_points:
            keep = keep[np.argsort(dist[keep], kind="stable")[: p.local_map_max_points]]
            keep.sort()
        if len(keep) < len(pts):
            keys, pts, normals, is_new = keys[keep], pts[keep], normals[keep], is_new[keep]
        if is_new.any():
            r = p.normal_radius
            near, _ = cKDTree(pts[is_new]).query(pts, k=1, distance_upper_bound=2.0 * r)
            context = near <= 2.0 * r  # every neighbour (within r) of an updated point
            update = near[context] <= r
            sub = _pcd(pts[context])
            sub.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=r, max_nn=p.normal_max_nn))
            idx = np.nonzero(context)[0][update]
            normals[idx] = np.asarray(sub.normals)[update]
        local = _pcd(pts)
        local.normals = o3d.utility.Vector3dVector(normals)
        if p.method == "gicp":
            local.estimate_covariances(o3d.geometry.KDTreeSearchParamKNN(p.normal_max_nn))
        self._local_keys, self._local_points, self._local_normals = keys, pts, normals
        self._local = local
        return True

    def _accumulate(self, points_map: np.ndarray) -> None:
        p = self.params
        self._buffer.append(points_map)
        self._buffered += len(points_map)
        if self._buffered >= 400_000:
            self._flush()
        if p.save_every_n_frames > 0:
            self._chunk.append(points_map)
            self._chunk_frames += 1
            if self._chunk_frames >= p.save_every_n_frames:
                self._close_chunk()

    def _flush(self) -> None:
        if not self._buffer:
            return
        self._global.add(np.concatenate(self._buffer))
        self._buffer, self._buffered = [], 0

    def _close_chunk(self) -> None:
        if self._chunk:
            pts = np.asarray(_pcd(np.concatenate(self._chunk)).voxel_down_sample(self.params.save_voxel).points)
            self.chunks.append(sorted_points(pts, self.params.save_voxel))
        self._chunk, self._chunk_frames = [], 0

    def global_map(self) -> np.ndarray:
        """(N, 3) every registered frame, voxel-filtered at ``save_voxel``, in a deterministic order."""
        with _Threads(self.params.threads):
            self._flush()
        return sorted_points(self._global.points(), self.params.save_voxel)

    def finish_chunks(self) -> list[np.ndarray]:
        """The chunks of ``save_every_n_frames`` frames, the last partial one included."""
        with _Threads(self.params.threads):
            self._close_chunk()
        return list(self.chunks)

    def local_map_size(self) -> int:
        return len(self._local.points)

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """(stamps_ns (N,), poses (N, 4, 4))."""
        return np.asarray(self.stamps, dtype=np.int64), np.asarray(self.trajectory).reshape(-1, 4, 4)
