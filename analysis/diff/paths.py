"""Plans compared: success, length, Hausdorff distance between the paths, goal endpoint, cost.

A plan is an (N, 2) or (N, 3) array of positions; an empty plan is a failed one. A change of success
(a plan on one side, a failure on the other) is always CHANGED, whatever the tolerances. The
Hausdorff distance between the two polylines' vertices is scipy's ``directed_hausdorff`` both ways.
Streams of plans (``nav_msgs/Path`` topics, ``plans.json``) are paired in order and judged on the
worst pair.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.distance import directed_hausdorff

from navlog.analysis.diff.result import Check, Verdict
from navlog.analysis.diff.tolerances import PathTolerance, as_dict, within

__all__ = ["PlanPair", "compare_plan_streams", "compare_plans", "path_hausdorff", "path_length", "plan_pair"]


def path_length(p: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1))) if len(p) > 1 else 0.0


def path_hausdorff(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Hausdorff distance (m) between the vertices of two non-empty paths."""
    return float(max(directed_hausdorff(a, b)[0], directed_hausdorff(b, a)[0]))


@dataclass(frozen=True)
class PlanPair:
    """Figures of one pair of plans (B against A). Distances are nan when a side failed."""

    success_a: bool
    success_b: bool
    length_change_m: float
    hausdorff_m: float
    endpoint_m: float
    cost_change_rel: float
    nonfinite: bool = False  # a plan holds a NaN or infinite coordinate, length or cost: always a difference

    @property
    def success_changed(self) -> bool:
        return self.success_a != self.success_b

    def within_tolerance(self, tol: PathTolerance) -> bool:
        if self.success_changed or self.nonfinite:
            return False
        checks = (
            (abs(self.length_change_m), tol.length_m),
            (self.hausdorff_m, tol.hausdorff_m),
            (self.endpoint_m, tol.endpoint_m),
            (abs(self.cost_change_rel), tol.cost_rtol),
        )
        return all(math.isnan(v) or within(v, t) for v, t in checks)


def _positions(p: Any) -> np.ndarray:
    arr = np.asarray(p, dtype=np.float64)
    return arr.reshape(len(arr), -1) if arr.size else np.zeros((0, 2))


def plan_pair(
    a: Any,
    b: Any,
    *,
    cost_a: float | None = None,
    cost_b: float | None = None,
    length_a: float | None = None,
    length_b: float | None = None,
    goal_a: Any = None,
    goal_b: Any = None,
) -> PlanPair:
    """Figures of two plans given as positions (either may be empty: failed). ``length_*`` and
    ``goal_*`` replace what the positions give (plans.json stores lengths and goals, not poses)."""
    pa, pb = _positions(a), _positions(b)
    ok_a = len(pa) > 0 or length_a is not None
    ok_b = len(pb) > 0 or length_b is not None
    nan = float("nan")
    if not (ok_a and ok_b):
        return PlanPair(ok_a, ok_b, nan, nan, nan, nan)
    la = length_a if length_a is not None else path_length(pa)
    lb = length_b if length_b is not None else path_length(pb)
    ga = np.asarray(goal_a if goal_a is not None else pa[-1], dtype=np.float64)[:2]
    gb = np.asarray(goal_b if goal_b is not None else pb[-1], dtype=np.float64)[:2]
    haus = path_hausdorff(pa, pb) if len(pa) and len(pb) else nan
    cost = nan
    if cost_a is not None and cost_b is not None:
        cost = 0.0 if cost_a == cost_b else (cost_b - cost_a) / max(abs(cost_a), abs(cost_b))
    given = [la, lb, *(c for c in (cost_a, cost_b) if c is not None)]
    finite = bool(np.isfinite(pa).all() and np.isfinite(pb).all() and np.isfinite(ga).all() and np.isfinite(gb).all())
    nonfinite = not (finite and all(math.isfinite(v) for v in given))
    return PlanPair(True, True, lb - la, haus, float(np.linalg.norm(gb - ga)), cost, nonfinite)


def _worst(values: Sequence[float], key: Any = abs) -> float | None:
    finite = [v for v in values if not math.isnan(v)]
    return max(finite, key=key) if finite else None


def compare_plan_streams(
    name: str, pairs: Sequence[PlanPair], count_a: int, count_b: int, tol: PathTolerance, *, equal: bool = False
) -> Check:
    """One check of two streams of plans paired in order. ``equal``: the caller knows the bytes match."""
    beyond = sum(not p.within_tolerance(tol) for p in pairs)
    success_changed = sum(p.success_changed for p in pairs)
    values: dict[str, Any] = {
        "plans_a": count_a,
        "plans_b": count_b,
        "pairs": len(pairs),
        "success_changed": success_changed,
        "failed_a": sum(not p.success_a for p in pairs),
        "failed_b": sum(not p.success_b for p in pairs),
        "beyond_tolerance": beyond,
        "max_length_change_m": _worst([p.length_change_m for p in pairs]),
        "max_hausdorff_m": _worst([p.hausdorff_m for p in pairs]),
        "max_endpoint_m": _worst([p.endpoint_m for p in pairs]),
        "max_cost_change_rel": _worst([p.cost_change_rel for p in pairs]),
    }
    if equal:
        verdict = Verdict.EQUAL
    elif count_a != count_b or beyond:
        verdict = Verdict.CHANGED
    else:
        verdict = Verdict.WITHIN
    detail = f"{count_a} -> {count_b} plans, {beyond} beyond tolerance"
    if success_changed:
        detail += f", success changed in {success_changed}"
    nonfinite = sum(p.nonfinite for p in pairs)
    if nonfinite:  # (the key only then: the reports of finite plans keep their bytes)
        values["nonfinite_pairs"] = nonfinite
        detail += f", {nonfinite} pair(s) with a NaN or infinite coordinate, length or cost"
    return Check(name, "plan", verdict, values, as_dict(tol), detail)


def compare_plans(name: str, a: Any, b: Any, tol: PathTolerance) -> Check:
    """One check of two single plans (positions, N x 2 or N x 3; empty = failed)."""
    pa, pb = _positions(a), _positions(b)
    same = pa.shape == pb.shape and np.array_equal(pa, pb)
    return compare_plan_streams(name, [plan_pair(pa, pb)], 1, 1, tol, equal=same)
