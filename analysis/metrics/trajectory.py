"""Trajectories and their error metrics: timestamp association, Umeyama alignment, ATE and RPE.

Pure mathematics, no I/O of its own (``Trajectory.from_tum`` reads a file through
``navlog.replay.io.tum``). The definitions are the ones evo uses:

- association: every stamp of the shorter trajectory is paired with the nearest stamp of the longer
  one, kept when the two are at most ``max_diff_ns`` apart;
- alignment: Umeyama's least-squares similarity (rotation, translation and optionally scale) that
  maps the estimate's positions onto the reference's;
- ATE: statistics of ``|p_ref - p_est|`` after alignment, and of the rotation angle of
  ``R_ref^T R_est`` in degrees;
- RPE: for index pairs (i, j) a fixed delta apart (frames, metres of reference path, or seconds),
  the error ``E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)`` between relative reference motion Q and relative
  estimated motion P; translation ``|t(E)|`` in metres and rotation angle of ``R(E)`` in degrees.

Times are integer nanoseconds; positions (N, 3) metres; quaternions (N, 4) in x, y, z, w order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from scipy.spatial.transform import Rotation

from navlog.errors import NavlogError
from navlog.replay.io.tum import read_tum

AlignMode = Literal["se3", "sim3", "none"]
DeltaUnit = Literal["frames", "m", "s"]
ALIGN_MODES = ("se3", "sim3", "none")
DELTA_UNITS = ("frames", "m", "s")

#: evo's default association window: 10 ms.
DEFAULT_MAX_DIFF_NS = 10_000_000


class TrajectoryError(NavlogError):
    """A trajectory is malformed, or two trajectories cannot be compared."""


# ---------------------------------------------------------------- the trajectory type


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Timestamped poses: ``times_ns`` (N,) int64 strictly increasing, ``positions`` (N, 3),
    ``quaternions`` (N, 4) x, y, z, w (normalised on construction)."""

    times_ns: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray

    def __post_init__(self) -> None:
        t = np.asarray(self.times_ns)
        if t.ndim != 1 or (t.size and not np.issubdtype(t.dtype, np.integer)):
            raise TrajectoryError(
                f"trajectory: times must be a 1-D integer array of nanoseconds, got {t.dtype} {t.shape}"
            )
        t = t.astype(np.int64, copy=True)
        p = (
            np.asarray(self.positions, dtype=np.float64).reshape(-1, 3).copy()
            if np.size(self.positions)
            else np.zeros((0, 3))
        )
        q = (
            np.asarray(self.quaternions, dtype=np.float64).reshape(-1, 4).copy()
            if np.size(self.quaternions)
            else np.zeros((0, 4))
        )
        if not (len(t) == len(p) == len(q)):
            raise TrajectoryError(
                f"trajectory: {len(t)} times, {len(p)} positions and {len(q)} quaternions differ in length"
            )
        if len(t) > 1 and np.any(np.diff(t) <= 0):
            k = int(np.argmax(np.diff(t) <= 0)) + 1
            raise TrajectoryError(
                f"trajectory: times must increase strictly; pose {k} at {t[k]} ns follows {t[k - 1]} ns"
            )
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
            raise TrajectoryError("trajectory: positions and quaternions must be finite")
        norms = np.linalg.norm(q, axis=1)
        if np.any(norms < 1e-9):
            raise TrajectoryError(f"trajectory: pose {int(np.argmax(norms < 1e-9))} has a zero quaternion")
        q /= norms[:, None]
        for name, arr in (("times_ns", t), ("positions", p), ("quaternions", q)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    def __len__(self) -> int:
        return len(self.times_ns)

    @classmethod
    def from_tum(cls, path: str | Path) -> Trajectory:
        """The poses of a TUM file (``navlog.replay.io.tum.read_tum``; its errors name the file and line)."""
        return cls(*read_tum(path))

    @classmethod
    def from_matrices(cls, times_ns, matrices) -> Trajectory:
        """From (N, 4, 4) homogeneous poses."""
        mats = np.asarray(matrices, dtype=np.float64).reshape(-1, 4, 4)
        quats = Rotation.from_matrix(mats[:, :3, :3]).as_quat() if len(mats) else np.zeros((0, 4))
        return cls(np.asarray(times_ns, dtype=np.int64), mats[:, :3, 3], quats)

    def rotations(self) -> Rotation:
        return Rotation.from_quat(self.quaternions)

    def matrices(self) -> np.ndarray:
        """(N, 4, 4) homogeneous poses."""
        out = np.tile(np.eye(4), (len(self), 1, 1))
        if len(self):
            out[:, :3, :3] = self.rotations().as_matrix()
            out[:, :3, 3] = self.positions
        return out

    def subset(self, index) -> Trajectory:
        idx = np.asarray(index, dtype=np.int64)
        return Trajectory(self.times_ns[idx], self.positions[idx], self.quaternions[idx])

    def transformed(self, rotation: np.ndarray, translation, scale: float = 1.0) -> Trajectory:
        """Every pose moved by ``x -> scale * R x + t`` (orientations rotated by R, scale ignored)."""
        r = np.asarray(rotation, dtype=np.float64)
        pos = scale * self.positions @ r.T + np.asarray(translation, dtype=np.float64)
        quats = (Rotation.from_matrix(r) * self.rotations()).as_quat() if len(self) else self.quaternions
        return Trajectory(self.times_ns, pos, quats)

    def path_lengths(self) -> np.ndarray:
        """Cumulative distance travelled along the positions, starting at 0."""
        if len(self) == 0:
            return np.zeros(0)
        steps = np.linalg.norm(np.diff(self.positions, axis=0), axis=1)
        return np.concatenate([[0.0], np.cumsum(steps)])

    @property
    def duration_s(self) -> float:
        return float(self.times_ns[-1] - self.times_ns[0]) / 1e9 if len(self) > 1 else 0.0


# ---------------------------------------------------------------- association


def matching_indices(stamps_a, stamps_b, max_diff_ns: int = DEFAULT_MAX_DIFF_NS, offset_b_ns: int = 0):
    """For each stamp of ``a``, the nearest stamp of ``b`` (sorted) shifted by ``offset_b_ns``;
    pairs further apart than ``max_diff_ns`` are dropped. Ties go to the earlier stamp of ``b``.

    Returns (index_a, index_b) int64 arrays."""
    a = np.asarray(stamps_a, dtype=np.int64)
    b = np.asarray(stamps_b, dtype=np.int64) + np.int64(offset_b_ns)
    if len(a) == 0 or len(b) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    right = np.clip(np.searchsorted(b, a, side="left"), 0, len(b) - 1)
    left = np.clip(right - 1, 0, len(b) - 1)
    d_left = np.abs(a - b[left])
    d_right = np.abs(b[right] - a)
    nearest = np.where(d_left <= d_right, left, right)
    diff = np.minimum(d_left, d_right)
    keep = diff <= int(max_diff_ns)
    return np.flatnonzero(keep).astype(np.int64), nearest[keep].astype(np.int64)


def associate(
    ref: Trajectory, est: Trajectory, *, max_diff_ns: int = DEFAULT_MAX_DIFF_NS, offset_ns: int = 0
) -> tuple[Trajectory, Trajectory]:
    """Pairs of reference and estimate poses whose stamps match within ``max_diff_ns``.

    ``offset_ns`` is added to the estimate's stamps. The shorter trajectory's stamps are matched
    against the longer one (as evo does), so each pose of the shorter one is used at most once.
    Raises ``TrajectoryError`` when nothing matches, giving both time ranges."""
    if len(est) < len(ref):
        i_est, i_ref = matching_indices(est.times_ns, ref.times_ns, max_diff_ns, -offset_ns)
    else:
        i_ref, i_est = matching_indices(ref.times_ns, est.times_ns, max_diff_ns, offset_ns)
    if len(i_ref) == 0:
        raise TrajectoryError(
            "no pose of the estimate is within "
            f"{max_diff_ns / 1e6:g} ms of a reference pose (reference {_span(ref)}, estimate {_span(est)}); "
            "check that both use the same clock, or widen the window (--max-diff)"
        )
    return ref.subset(i_ref), est.subset(i_est)


def interpolate(traj: Trajectory, times_ns, *, max_gap_ns: int | None = None) -> tuple[Trajectory, np.ndarray]:
    """Poses of ``traj`` at ``times_ns`` (sorted): positions linearly, orientations by slerp.

    Times outside the trajectory's span, or between two poses more than ``max_gap_ns`` apart, are
    dropped. Returns the interpolated trajectory and the indices of ``times_ns`` it holds."""
    t = np.asarray(times_ns, dtype=np.int64)
    src = traj.times_ns
    if len(src) == 0 or len(t) == 0:
        return traj.subset(np.zeros(0, np.int64)), np.zeros(0, np.int64)
    hi = np.searchsorted(src, t, side="left")
    exact = (hi < len(src)) & (src[np.minimum(hi, len(src) - 1)] == t)
    inside = exact | ((hi > 0) & (hi < len(src)))
    hi = np.clip(hi, 1, max(len(src) - 1, 1))
    lo = hi - 1
    if max_gap_ns is not None and len(src) > 1:
        inside &= exact | (src[hi] - src[lo] <= int(max_gap_ns))
    keep = np.flatnonzero(inside).astype(np.int64)
    if len(src) == 1:
        return traj.subset(np.zeros(len(keep), np.int64)), keep
    t, lo, hi = t[keep], lo[keep], hi[keep]
    # fractions from integer differences (exact for stamps far from the epoch)
    frac = (t - src[lo]).astype(np.float64) / (src[hi] - src[lo]).astype(np.float64)
    pos = traj.positions[lo] + frac[:, None] * (traj.positions[hi] - traj.positions[lo])
    r_lo = Rotation.from_quat(traj.quaternions[lo])
    delta = (r_lo.inv() * Rotation.from_quat(traj.quaternions[hi])).as_rotvec()
    quats = (r_lo * Rotation.from_rotvec(delta * frac[:, None])).as_quat() if len(keep) else np.zeros((0, 4))
    return Trajectory(t, pos, quats), keep


def associate_interpolated(
    ref: Trajectory, est: Trajectory, *, max_gap_ns: int | None = None, offset_ns: int = 0
) -> tuple[Trajectory, Trajectory]:
    """The reference interpolated at each estimate stamp (shifted by ``offset_ns``) that lies within
    the reference's span (and not across a gap longer than ``max_gap_ns``), paired with the estimate."""
    at, keep = interpolate(ref, est.times_ns + np.int64(offset_ns), max_gap_ns=max_gap_ns)
    if len(keep) == 0:
        raise TrajectoryError(
            f"no estimate stamp lies within the reference's time span (reference {_span(ref)}, "
            f"estimate {_span(est)}); check that both use the same clock"
        )
    return at, est.subset(keep)


def _span(traj: Trajectory) -> str:
    if len(traj) == 0:
        return "empty"
    return f"{len(traj)} poses from {traj.times_ns[0] / 1e9:.3f} s to {traj.times_ns[-1] / 1e9:.3f} s"


# ---------------------------------------------------------------- alignment


@dataclass(frozen=True)
class Alignment:
    """``x_ref ~= scale * rotation @ x_est + translation``."""

    rotation: np.ndarray
    translation: np.ndarray
    scale: float = 1.0

    @classmethod
    def identity(cls) -> Alignment:
        return cls(np.eye(3), np.zeros(3), 1.0)

    def matrix(self) -> np.ndarray:
        """4x4 (rotation scaled by ``scale``)."""
        out = np.eye(4)
        out[:3, :3] = self.scale * self.rotation
        out[:3, 3] = self.translation
        return out

    def apply(self, traj: Trajectory) -> Trajectory:
        return traj.transformed(self.rotation, self.translation, self.scale)

    def to_dict(self) -> dict:
        return {
            "rotation_deg": float(np.degrees(Rotation.from_matrix(self.rotation).magnitude())),
            "translation_m": [float(v) for v in self.translation],
            "scale": float(self.scale),
        }


def umeyama(source, target, *, with_scale: bool = False) -> Alignment:
    """Least-squares similarity taking ``source`` (N, 3) onto ``target`` (N, 3) (Umeyama 1991).

    Minimises ``sum |target_i - (s R source_i + t)|^2`` with R a proper rotation; s = 1 unless
    ``with_scale``. Needs at least 3 points not all on one line."""
    x = np.asarray(source, dtype=np.float64).reshape(-1, 3)
    y = np.asarray(target, dtype=np.float64).reshape(-1, 3)
    if len(x) != len(y):
        raise TrajectoryError(f"alignment: {len(x)} source and {len(y)} target points differ in number")
    if len(x) < 3:
        raise TrajectoryError(f"alignment: needs at least 3 matched poses, got {len(x)}")
    mx, my = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - mx, y - my
    cov = yc.T @ xc / len(x)
    u, d, vt = np.linalg.svd(cov)
    if d[1] <= 1e-12 * max(d[0], 1e-300):
        raise TrajectoryError(
            "alignment: the matched positions lie on a line (or a point), so the rotation is undetermined; "
            "use --align none"
        )
    s = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[2, 2] = -1.0
    rot = u @ s @ vt
    scale = 1.0
    if with_scale:
        var_x = float(np.mean(np.sum(xc**2, axis=1)))
        scale = float(np.trace(np.diag(d) @ s) / var_x)
    return Alignment(rot, my - scale * rot @ mx, scale)


def align(est: Trajectory, ref: Trajectory, mode: AlignMode = "se3") -> tuple[Trajectory, Alignment]:
    """The estimate aligned onto the (already associated) reference, and the alignment used."""
    if mode not in ALIGN_MODES:
        raise TrajectoryError(f"alignment '{mode}' is unknown; use one of {', '.join(ALIGN_MODES)}")
    if mode == "none":
        return est, Alignment.identity()
    _same_length(ref, est)
    a = umeyama(est.positions, ref.positions, with_scale=(mode == "sim3"))
    return a.apply(est), a


def _same_length(ref: Trajectory, est: Trajectory) -> None:
    if len(ref) != len(est):
        raise TrajectoryError(
            f"trajectories of {len(ref)} and {len(est)} poses are not associated; call associate() first"
        )


# ---------------------------------------------------------------- statistics


@dataclass(frozen=True)
class ErrorStats:
    """Summary of a set of non-negative errors (metres or degrees)."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    count: int

    @classmethod
    def of(cls, errors) -> ErrorStats:
        e = np.asarray(errors, dtype=np.float64).reshape(-1)
        if e.size == 0:
            nan = float("nan")
            return cls(nan, nan, nan, nan, nan, nan, 0)
        return cls(
            rmse=float(np.sqrt(np.mean(e * e))),
            mean=float(np.mean(e)),
            median=float(np.median(e)),
            std=float(np.std(e)),
            min=float(np.min(e)),
            max=float(np.max(e)),
            count=int(e.size),
        )

    def to_dict(self) -> dict:
        return {k: _num(getattr(self, k)) for k in ("rmse", "mean", "median", "std", "min", "max", "count")}


def _num(v):
    if isinstance(v, (int, np.integer)):
        return int(v)
    v = float(v)
    return None if not np.isfinite(v) else v


def rotation_angles_deg(rot_a: Rotation, rot_b: Rotation) -> np.ndarray:
    """Angle of ``a^-1 b`` for each pair, in degrees (0..180)."""
    return np.degrees((rot_a.inv() * rot_b).magnitude())


# ---------------------------------------------------------------- ATE


@dataclass(frozen=True)
class AteResult:
    translation: ErrorStats  # metres
    rotation: ErrorStats  # degrees
    alignment: Alignment
    align_mode: str
    pairs: int
    translation_errors: np.ndarray  # per matched pose, metres

    def to_dict(self) -> dict:
        return {
            "align": self.align_mode,
            "pairs": self.pairs,
            "translation_m": self.translation.to_dict(),
            "rotation_deg": self.rotation.to_dict(),
            "alignment": self.alignment.to_dict(),
        }


def ate_errors(ref: Trajectory, est: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """Per-pose translation (m) and rotation (deg) errors of associated, aligned trajectories."""
    _same_length(ref, est)
    trans = np.linalg.norm(ref.positions - est.positions, axis=1)
    rot = rotation_angles_deg(ref.rotations(), est.rotations()) if len(ref) else np.zeros(0)
    return trans, rot


def absolute_trajectory_error(
    ref: Trajectory,
    est: Trajectory,
    *,
    align_mode: AlignMode = "se3",
    max_diff_ns: int | None = DEFAULT_MAX_DIFF_NS,
) -> AteResult:
    """ATE: associate (unless ``max_diff_ns`` is None: then the two must already be paired),
    align the estimate onto the reference, and summarise the errors."""
    if max_diff_ns is not None:
        ref, est = associate(ref, est, max_diff_ns=max_diff_ns)
    aligned, alignment = align(est, ref, align_mode)
    trans, rot = ate_errors(ref, aligned)
    return AteResult(ErrorStats.of(trans), ErrorStats.of(rot), alignment, align_mode, len(ref), trans)


# ---------------------------------------------------------------- RPE


def pair_indices(
    ref: Trajectory, delta: float, unit: DeltaUnit = "frames", *, all_pairs: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j) a ``delta`` apart along the reference.

    ``frames``: j = i + delta. ``m``: j is the first pose whose reference path length from i is at
    least ``delta`` metres. ``s``: the first pose at least ``delta`` seconds after i. Consecutive
    (non-overlapping) pairs, each starting where the previous ended, unless ``all_pairs``."""
    if unit not in DELTA_UNITS:
        raise TrajectoryError(f"RPE delta unit '{unit}' is unknown; use one of {', '.join(DELTA_UNITS)}")
    if not delta > 0:
        raise TrajectoryError(f"RPE delta must be > 0, got {delta}")
    n = len(ref)
    if unit == "frames":
        if int(delta) != delta:
            raise TrajectoryError(f"RPE delta in frames must be a whole number, got {delta}")
        step = int(delta)
        starts = np.arange(0, max(n - step, 0), 1 if all_pairs else step, dtype=np.int64)
        return starts, starts + step
    axis = ref.path_lengths() if unit == "m" else (ref.times_ns - (ref.times_ns[0] if n else 0)) / 1e9
    # a hair of slack so that a delta equal to the spacing of the samples is not missed by rounding
    tol = 1e-9 * max(1.0, float(delta))
    # (a pair ends one sample on at least: a delta below the samples' spacing pairs neighbours)
    ends = np.maximum(np.searchsorted(axis, axis + delta - tol, side="left"), np.arange(1, n + 1))
    if all_pairs:
        i = np.flatnonzero(ends < n).astype(np.int64)
        return i, ends[i].astype(np.int64)
    first, second = [], []
    k = 0
    while k < n and ends[k] < n:
        first.append(k)
        second.append(int(ends[k]))
        k = int(ends[k])
    return np.asarray(first, dtype=np.int64), np.asarray(second, dtype=np.int64)


@dataclass(frozen=True)
class RpeResult:
    translation: ErrorStats  # metres per delta
    rotation: ErrorStats  # degrees per delta
    delta: float
    unit: str
    pairs: int

    def to_dict(self) -> dict:
        return {
            "delta": self.delta,
            "unit": self.unit,
            "pairs": self.pairs,
            "translation_m": self.translation.to_dict(),
            "rotation_deg": self.rotation.to_dict(),
        }


def relative_pose_error(
    ref: Trajectory,
    est: Trajectory,
    *,
    delta: float = 1.0,
    unit: DeltaUnit = "frames",
    all_pairs: bool = False,
    align_mode: AlignMode = "none",
    max_diff_ns: int | None = DEFAULT_MAX_DIFF_NS,
    pairs_from: Literal["reference", "estimate"] = "reference",
) -> RpeResult:
    """RPE over a fixed delta. Associates first unless ``max_diff_ns`` is None. RPE does not depend
    on a rigid alignment; ``align_mode='sim3'`` corrects the estimate's scale first. Pairs are chosen
    along the reference's path (evo's ``--pairs_from_reference``) or, with ``pairs_from='estimate'``,
    along the estimate's (evo's default)."""
    if pairs_from not in ("reference", "estimate"):
        raise TrajectoryError(f"RPE pairs_from '{pairs_from}' is unknown; use reference or estimate")
    if max_diff_ns is not None:
        ref, est = associate(ref, est, max_diff_ns=max_diff_ns)
    _same_length(ref, est)
    if align_mode != "none":
        est, _ = align(est, ref, align_mode)
    i, j = pair_indices(ref if pairs_from == "reference" else est, delta, unit, all_pairs=all_pairs)
    if len(i) == 0:
        raise TrajectoryError(
            f"RPE: no pose pair is {delta:g} {unit} apart along the reference ({_span(ref)}"
            + (f", {ref.path_lengths()[-1]:.3f} m long" if len(ref) else "")
            + "); use a smaller delta"
        )
    q, p = ref.matrices(), est.matrices()
    rel_ref = np.linalg.inv(q[i]) @ q[j]
    rel_est = np.linalg.inv(p[i]) @ p[j]
    err = np.linalg.inv(rel_ref) @ rel_est
    trans = np.linalg.norm(err[:, :3, 3], axis=1)
    rot = np.degrees(Rotation.from_matrix(err[:, :3, :3]).magnitude())
    return RpeResult(ErrorStats.of(trans), ErrorStats.of(rot), float(delta), unit, len(i))


def align_planar(est: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """(N, 3) planar poses (x, y, yaw) ``est`` moved by the rotation and translation in the plane (SE(2))
    that best fits their positions onto ``ref``'s (Umeyama in 2D: a planar trajectory aligned in 3D may
    come out mirrored)."""
    mu_e, mu_r = est[:, :2].mean(0), ref[:, :2].mean(0)
    u, _, vt = np.linalg.svd((est[:, :2] - mu_e).T @ (ref[:, :2] - mu_r))
    rot = vt.T @ np.diag([1.0, np.sign(np.linalg.det(vt.T @ u.T))]) @ u.T
    out = np.array(est, dtype=np.float64)
    out[:, :2] = (est[:, :2] - mu_e) @ rot.T + mu_r
    out[:, 2] = est[:, 2] + np.arctan2(rot[1, 0], rot[0, 0])
    return out


def planar_ate(est: np.ndarray, ref: np.ndarray) -> float:
    """Absolute trajectory error of (N, 3) planar poses ``est`` against ``ref`` (the same instants): the RMSE
    of the positions after ``align_planar``."""
    aligned = align_planar(est, ref)
    return float(np.sqrt(np.mean(np.sum((aligned[:, :2] - ref[:, :2]) ** 2, axis=1))))


def _planar_moves(ref: np.ndarray, travel: float, *trajectories: np.ndarray) -> list[np.ndarray]:
    """For every pose i of ``ref`` the first later j with at least ``travel`` of ``ref``'s path since i:
    j's position in i's frame, (M, 2), in each of ``trajectories`` (planar poses at the same instants)."""
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ref[:, :2], axis=0), axis=1))])
    i = np.arange(len(ref))
    j = np.searchsorted(cum, cum + travel)
    i, j = i[j < len(ref)], j[j < len(ref)]
    return [planar_in_frame(p[i], p[j, :2]) for p in trajectories]


def planar_in_frame(frames: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(M, 2) positions ``xy`` given in the parent frame, each expressed in its planar frame of ``frames`` (M, 3:
    x, y, yaw)."""
    c, s = np.cos(frames[:, 2]), np.sin(frames[:, 2])
    dx, dy = (xy - frames[:, :2]).T
    return np.stack([c * dx + s * dy, -s * dx + c * dy], axis=1)


def planar_relative_error(est: np.ndarray, ref: np.ndarray, travel: float) -> float:
    """Mean translational relative error over ``travel`` metres (Kuemmerle et al. 2009): for every pose i
    the first later j with at least ``travel`` of reference path since i; the norm of the difference of
    j's position in i's frame, estimated minus reference. NaN when the path is shorter than ``travel``."""
    e, r = _planar_moves(ref, travel, est, ref)
    return float(np.mean(np.linalg.norm(e - r, axis=1))) if len(r) else float("nan")


def own_relative_errors(
    a: np.ndarray, b: np.ndarray, c: np.ndarray, travel: float, along: np.ndarray | None = None
) -> tuple[float, float, float]:
    """Each trajectory's own RMS translational error over ``travel`` metres, from three planar trajectories of
    the same instants whose errors are independent, none of them the truth (the three-cornered hat of clock
    comparisons): with d_xy the RMS of the difference of x's and y's moves (``planar_relative_error``'s pairs,
    taken along ``along``, by default ``a``: pairs taken along a noisier path are shorter moves), a's own mean square is (d_ab^2 + d_ac^2 - d_bc^2) / 2, and so on round. A reference
    that is itself an estimate scores a perfect one at its own error. A mean square that comes out negative
    (errors correlated, or too few pairs) is NaN; all NaN when the path is shorter than ``travel``."""
    ma, mb, mc = _planar_moves(a if along is None else along, travel, a, b, c)
    if not len(ma):
        return (float("nan"),) * 3
    ab, ac, bc = (float(np.mean(np.sum((x - y) ** 2, axis=1))) for x, y in ((ma, mb), (ma, mc), (mb, mc)))
    own = ((ab + ac - bc) / 2, (ab + bc - ac) / 2, (ac + bc - ab) / 2)
    return tuple(math.sqrt(v) if v >= 0 else float("nan") for v in own)  # type: ignore[return-value]
