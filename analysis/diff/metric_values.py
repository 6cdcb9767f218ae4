"""``metrics.json`` compared value by value, each metric judged by its direction.

The JSON is flattened to dotted keys (``trajectory.ate.translation_m.rmse``). A key's direction comes
from its words: higher is better for precision, recall, F1, IoU, accuracy, completeness and coverage;
lower is better for errors and distances (ATE, RPE, RMSE, mean, median, max, std, distance, Chamfer,
Hausdorff); other keys (counts, parameters) must stay equal. A value that moved beyond
``max(atol, rtol * max(|a|, |b|))`` reads IMPROVED or REGRESSED by its direction (CHANGED for keys
without one); within the tolerance it reads WITHIN. The ``inputs`` section (file paths) is skipped.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any, Literal

from navlog.analysis.diff.result import Check, Verdict
from navlog.analysis.diff.tolerances import MetricTolerance, as_dict
from navlog.analysis.tables import figure

__all__ = ["compare_metric_values", "direction", "flatten"]

Direction = Literal["higher", "lower", "equal"]

HIGHER_IS_BETTER = ("precision", "recall", "f1", "iou", "accuracy", "completeness", "coverage")
LOWER_IS_BETTER = (
    *("ate", "rpe", "error", "errors", "rmse", "mean", "median", "max", "min", "std", "dist", "distance"),
    *("chamfer", "hausdorff", "residual"),
)
NEUTRAL_SECTIONS = ("counts", "parameters", "pairs", "points", "count", "samples", "viewpoints")
SKIPPED_SECTIONS = ("inputs",)


def flatten(data: Any, prefix: str = "") -> dict[str, Any]:
    """Nested dicts (and lists) to ``{dotted.key: leaf}``."""
    out: dict[str, Any] = {}
    if isinstance(data, Mapping):
        for k, v in data.items():
            out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    elif isinstance(data, list) and any(isinstance(v, (Mapping, list)) for v in data):
        for i, v in enumerate(data):
            out.update(flatten(v, f"{prefix}[{i}]"))
    else:
        out[prefix] = data
    return out


def direction(key: str) -> Direction:
    """Which way is better for a flattened metric key."""
    words = [w for w in re.split(r"[._\[\]@]+", key.lower()) if w]
    if any(w in NEUTRAL_SECTIONS for w in words):
        return "equal"
    if any(w in HIGHER_IS_BETTER for w in words):
        return "higher"
    if any(w in LOWER_IS_BETTER for w in words):
        return "lower"
    return "equal"


def _number(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


def compare_metric_values(name: str, a: Mapping[str, Any], b: Mapping[str, Any], tol: MetricTolerance) -> list[Check]:
    """One check per metric that differs between two metrics dicts (``name:key``); one EQUAL check
    named ``name`` when none does."""
    fa = {k: v for k, v in flatten(a).items() if k.split(".", 1)[0] not in SKIPPED_SECTIONS}
    fb = {k: v for k, v in flatten(b).items() if k.split(".", 1)[0] not in SKIPPED_SECTIONS}
    checks: list[Check] = []
    td = as_dict(tol)
    for key in sorted(fa.keys() | fb.keys()):
        va, vb = fa.get(key), fb.get(key)
        if key not in fa or key not in fb:
            side = "A" if key in fa else "B"
            checks.append(Check(f"{name}:{key}", "metric", Verdict.CHANGED, {"a": va, "b": vb}, td, f"only in {side}"))
            continue
        if va == vb:
            continue
        na, nb = _number(va), _number(vb)
        d = direction(key)
        values: dict[str, Any] = {"a": va, "b": vb, "direction": d}
        if na is None or nb is None or math.isnan(na) or math.isnan(nb):
            shown = [figure(n) if n is not None else repr(v) for n, v in ((na, va), (nb, vb))]
            checks.append(Check(f"{name}:{key}", "metric", Verdict.CHANGED, values, td, " -> ".join(shown)))
            continue
        delta = nb - na
        values["delta"] = delta
        if abs(delta) <= max(tol.atol, tol.rtol * max(abs(na), abs(nb))):
            verdict = Verdict.WITHIN
        elif d == "equal":
            verdict = Verdict.CHANGED
        else:
            better = delta < 0 if d == "lower" else delta > 0
            verdict = Verdict.IMPROVED if better else Verdict.REGRESSED
        detail = f"{na:.6g} -> {nb:.6g} ({d} is better)" if d != "equal" else f"{na:.6g} -> {nb:.6g}"
        checks.append(Check(f"{name}:{key}", "metric", verdict, values, td, detail))
    if not checks:
        checks.append(Check(name, "metric", Verdict.EQUAL, {"metrics": len(fa)}, td, f"{len(fa)} values equal"))
    return checks
