"""Trajectories compared (Odometry topics, TUM files): ATE and RPE of B against A.

Poses are associated by nearest stamp within ``max_diff_s`` and compared without alignment (a diff
must see a shift), with ``navlog.analysis.metrics.trajectory``: ATE is the translation RMSE of the
associated poses, RPE the translation RMSE over ``rpe_delta_frames`` frames. Trajectories that cannot
be associated (no common stamps) are CHANGED, with the reason.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navlog.analysis.diff.result import Check, Verdict
from navlog.analysis.diff.tolerances import TrajectoryTolerance, as_dict, within
from navlog.analysis.metrics.trajectory import (
    Trajectory,
    TrajectoryError,
    absolute_trajectory_error,
    associate,
    relative_pose_error,
)
from navlog.analysis.tables import figure

__all__ = ["compare_trajectories"]


def _same(a: Trajectory, b: Trajectory) -> bool:
    return (
        len(a) == len(b)
        and np.array_equal(a.times_ns, b.times_ns)
        and np.array_equal(a.positions, b.positions)
        and np.array_equal(a.quaternions, b.quaternions)
    )


def compare_trajectories(name: str, a: Trajectory, b: Trajectory, tol: TrajectoryTolerance) -> Check:
    """EQUAL for identical poses; WITHIN when ATE and RPE are within ``tol``; else CHANGED."""
    values: dict[str, Any] = {"poses_a": len(a), "poses_b": len(b)}
    max_diff_ns = int(round(tol.max_diff_s * 1e9))
    try:
        ref, est = associate(a, b, max_diff_ns=max_diff_ns)
        ate = absolute_trajectory_error(ref, est, align_mode="none", max_diff_ns=None)
        values.update(pairs=ate.pairs, ate_m=ate.translation.rmse, ate_max_m=ate.translation.max)
        values["ate_rot_deg"] = ate.rotation.rmse
        if len(ref) > tol.rpe_delta_frames:
            rpe = relative_pose_error(ref, est, delta=tol.rpe_delta_frames, unit="frames", max_diff_ns=None)
            values["rpe_m"] = rpe.translation.rmse
        else:
            values["rpe_m"] = None
    except TrajectoryError as exc:
        return Check(name, "trajectory", Verdict.CHANGED, values, as_dict(tol), f"cannot be compared: {exc}")
    if _same(a, b):
        verdict = Verdict.EQUAL
    else:
        rpe_ok = values["rpe_m"] is None or within(values["rpe_m"], tol.rpe_m)
        # every pose must have its partner
        covered = ate.pairs == len(a) == len(b)
        verdict = Verdict.WITHIN if within(ate.translation.rmse, tol.ate_m) and rpe_ok and covered else Verdict.CHANGED
    detail = f"{len(a)} -> {len(b)} poses, {ate.pairs} matched, ATE {figure(ate.translation.rmse, unit='m')}"
    return Check(name, "trajectory", verdict, values, as_dict(tol), detail)
