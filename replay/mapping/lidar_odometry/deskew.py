"""The motion prior and per-point deskew.

The motion of base_link during a sweep comes from, in order of preference: the integrated gyro
(rotation) when it covers the times asked, the odometry track (translation and rotation) when it
covers them, else the constant velocity of the last two registered frames. ``deskew`` moves every
point into base_link at one reference time, sampling that motion at a fixed number of slots.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field

import numpy as np

from navlog.replay.geometry import (
    matrices_to_quats,
    quat_exp,
    quat_mul,
    quats_mul,
    rotvecs_to_matrices,
    slerp_rows,
    unit_quats_to_matrices,
)

MAX_STEP_RAD = 1e6  # a rotation between two gyro samples beyond this (or not finite) is no measurement


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
        with np.errstate(over="ignore", invalid="ignore"):
            rotvec = 0.5 * (w + self._w[-1]) * ((t_ns - self._t[-1]) * 1e-9) if self._t else None
        if rotvec is not None and (t_ns - self._t[-1] > self.keep_ns or not np.all(np.abs(rotvec) <= MAX_STEP_RAD)):
            # a gap longer than what is kept, or a rotation no gyro measures: the track starts afresh here
            self._t, self._w, self._q = [], [], []
            rotvec = None
        if rotvec is None:
            q = np.array([0.0, 0.0, 0.0, 1.0])
        else:
            q = quat_mul(self._q[-1], quat_exp(rotvec))
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
        r = slerp_rows(qs[k], qs[k + 1], a)
        ref_inv = r[0:1] * np.array([-1.0, -1.0, -1.0, 1.0])
        return unit_quats_to_matrices(quats_mul(np.repeat(ref_inv, len(q), axis=0), r[1:]))


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
        delta = matrices_to_quats(np.transpose(r0, (0, 2, 1)) @ r1)  # r0 <- r1
        identity = np.tile([0.0, 0.0, 0.0, 1.0], (len(q), 1))
        out[:, :3, :3] = r0 @ unit_quats_to_matrices(slerp_rows(identity, delta, a))
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


@dataclass
class ConstantVelocity:
    """Body-frame constant velocity (linear ``v`` m/s, angular ``w`` rad/s), from the last two registered frames."""

    v: np.ndarray = field(default_factory=lambda: np.zeros(3))
    w: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def relative(self, dt: np.ndarray) -> np.ndarray:
        """(K, 4, 4): base_link now <- base_link ``dt`` seconds later, for each ``dt``."""
        dt = np.asarray(dt, dtype=np.float64)
        out = np.tile(np.eye(4), (len(dt), 1, 1))
        out[:, :3, :3] = rotvecs_to_matrices(self.w[None, :] * dt[:, None])
        out[:, :3, 3] = self.v[None, :] * dt[:, None]
        return out


def prior_motion(
    t_ref_ns: int, query_ns: np.ndarray, prior: MotionPrior | None, velocity: ConstantVelocity | None
) -> np.ndarray | None:
    """(K, 4, 4): base_link at ``t_ref`` <- base_link at each query time, from the best prior: the
    odometry track (else the constant ``velocity``), with its rotation replaced by the gyro's; None
    when the odometry track does not cover the times and no ``velocity`` is given."""
    q_ns = np.asarray(query_ns, dtype=np.int64)
    rel = None
    if prior is not None and prior.odom is not None:
        rel = prior.odom.relative(t_ref_ns, q_ns)
    if rel is None:
        if velocity is None:
            return None
        rel = velocity.relative((q_ns - t_ref_ns) * 1e-9)
    if prior is not None and prior.gyro is not None:
        rot = prior.gyro.relative_rotations(t_ref_ns, q_ns)
        if rot is not None:
            rel = rel.copy()
            rel[:, :3, :3] = rot
    return rel


def relative_motion(
    t_ref_ns: int, query_ns: np.ndarray, prior: MotionPrior | None, velocity: ConstantVelocity
) -> np.ndarray:
    """``prior_motion`` with the constant ``velocity`` where the odometry track does not reach."""
    rel = prior_motion(t_ref_ns, query_ns, prior, velocity)
    assert rel is not None
    return rel


def sweep_span(times: np.ndarray) -> tuple[float, float]:
    """The first and last per-point time of a sweep (seconds after its stamp)."""
    return float(times.min()), float(times.max())


def slot_times(span: tuple[float, float], slots: int) -> np.ndarray:
    """The times (seconds after the stamp) at which the motion over a sweep spanning ``span`` is sampled."""
    t_lo, t_hi = span
    return np.array([t_lo]) if t_hi - t_lo <= 0 else np.linspace(t_lo, t_hi, slots)


def move_by_slot(points: np.ndarray, times: np.ndarray, motions: np.ndarray) -> np.ndarray:
    """Points (base_link at their own ``times``) moved by the motion (``motions`` (K, 4, 4), sampled at
    ``slot_times``) of the slot nearest each point's time."""
    slots = len(motions)
    t_lo, t_hi = sweep_span(times)
    if slots == 1:
        idx = np.zeros(len(times), dtype=np.int64)
    else:
        idx = np.clip(np.round((times - t_lo) / (t_hi - t_lo) * (slots - 1)).astype(np.int64), 0, slots - 1)
    out = np.empty_like(points)
    order = np.argsort(idx, kind="stable")
    bounds = np.searchsorted(idx[order], np.arange(slots + 1))
    for k in range(slots):
        sel = order[bounds[k] : bounds[k + 1]]
        if len(sel):
            out[sel] = points[sel] @ motions[k, :3, :3].T + motions[k, :3, 3]
    return out


def slot_query_ns(stamp_ns: int, slot_t: np.ndarray) -> np.ndarray:
    """The slots' times in nanoseconds."""
    return stamp_ns + np.round(slot_t * 1e9).astype(np.int64)


def deskew_points(
    points: np.ndarray,
    times: np.ndarray,
    stamp_ns: int,
    ref_ns: int,
    slots: int,
    prior: MotionPrior | None,
    velocity: ConstantVelocity,
) -> np.ndarray:
    """Points (base_link at their own times: ``stamp_ns`` + ``times`` seconds) moved into base_link at
    ``ref_ns``; the motion is sampled at ``slots`` times spread over the sweep and each point takes
    the nearest slot's."""
    slot_t = slot_times(sweep_span(times), slots)
    return move_by_slot(points, times, relative_motion(ref_ns, slot_query_ns(stamp_ns, slot_t), prior, velocity))
