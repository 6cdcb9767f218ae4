"""Velocity command streams compared (Twist, TwistStamped), paired in order (the executor's order).

For each axis (linear x, y, z, angular x, y, z) the RMS and the largest absolute difference over the
pairs; a pair is beyond tolerance when any axis differs by more than ``max_abs``. Streams of
different lengths are CHANGED (the extra commands are counted).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from navlog.analysis.diff.result import Check, Verdict
from navlog.analysis.diff.tolerances import TwistTolerance, as_dict
from navlog.analysis.tables import figure

__all__ = ["AXES", "compare_twists", "twist_row"]

AXES = ("linear.x", "linear.y", "linear.z", "angular.x", "angular.y", "angular.z")


def twist_row(msg: Any) -> tuple[float, float, float, float, float, float]:
    """The six velocities of a Twist or TwistStamped message."""
    t = getattr(msg, "twist", msg)
    return (t.linear.x, t.linear.y, t.linear.z, t.angular.x, t.angular.y, t.angular.z)


def compare_twists(name: str, a: Any, b: Any, tol: TwistTolerance) -> Check:
    """``a``, ``b``: (N, 6) velocities in ``AXES`` order (or rows of ``twist_row``)."""
    va = np.asarray(a, dtype=np.float64).reshape(-1, 6)
    vb = np.asarray(b, dtype=np.float64).reshape(-1, 6)
    n = min(len(va), len(vb))
    d = np.abs(vb[:n] - va[:n])
    d = np.where(np.isnan(va[:n]) & np.isnan(vb[:n]), 0.0, d)
    beyond = int(np.count_nonzero(np.any(~(d <= tol.max_abs + 1e-9 * max(tol.max_abs, 1e-3)), axis=1))) if n else 0
    rms = np.sqrt(np.mean(d * d, axis=0)) if n else np.zeros(6)
    mx = np.max(d, axis=0) if n else np.zeros(6)
    values: dict[str, Any] = {"commands_a": len(va), "commands_b": len(vb), "pairs": n, "beyond_tolerance": beyond}
    for i, axis in enumerate(AXES):
        values[f"rms.{axis}"] = float(rms[i])
        values[f"max.{axis}"] = float(mx[i])
    values["max_abs"] = float(mx.max()) if n else 0.0
    if len(va) == len(vb) and np.array_equal(va, vb, equal_nan=True):
        verdict = Verdict.EQUAL
    elif len(va) != len(vb) or beyond:
        verdict = Verdict.CHANGED
    else:
        verdict = Verdict.WITHIN
    worst = AXES[int(np.argmax(mx))] if n else AXES[0]
    detail = (
        f"{len(va)} -> {len(vb)} commands, {beyond} beyond {tol.max_abs:g}; max {figure(values['max_abs'])} on {worst}"
    )
    return Check(name, "twist", verdict, values, as_dict(tol), detail)
