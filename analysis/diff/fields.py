"""Messages compared field by field: the generic comparator for every type without its own.

A message is walked as the dataclass it is (rosbags types): nested messages by field name, sequences
by index (``poses[3].pose.position.x``), numpy arrays elementwise. Numbers are equal within
``max(atol, rtol * max(|a|, |b|))`` (NaN equals NaN); text and booleans must be identical. Field
paths under an ignored prefix (``header.stamp`` ignores ``header.stamp.sec`` and ``.nanosec``) are
skipped.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from navlog.analysis.diff.tolerances import DEFAULT_FIELD_TOLERANCE, FieldTolerance

__all__ = ["FieldDifference", "field_differences", "first_field_difference"]

MAX_TEXT = 60


@dataclass(frozen=True)
class FieldDifference:
    """One field beyond tolerance: its path, the two values as text, and |a - b| for numbers (else nan).
    An array gives one entry: its first element beyond tolerance, with the array's largest |a - b|."""

    path: str
    old: str
    new: str
    abs_diff: float


def _text(v: Any) -> str:
    s = repr(v.item() if isinstance(v, np.generic) else v)
    return s if len(s) <= MAX_TEXT else s[: MAX_TEXT - 3] + "..."


def _ignored(path: str, ignore: Sequence[str]) -> bool:
    return any(path == p or path.startswith((p + ".", p + "[")) for p in ignore)


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def _arrays(path: str, a: np.ndarray, b: np.ndarray, tol: FieldTolerance) -> Iterator[FieldDifference]:
    if a.shape != b.shape:
        yield FieldDifference(f"{path}.length", str(a.size), str(b.size), float("nan"))
        return
    if a.dtype.kind in "fiub" and b.dtype.kind in "fiub":
        fa, fb = a.astype(np.float64).ravel(), b.astype(np.float64).ravel()
        with np.errstate(invalid="ignore", over="ignore"):  # inf - inf: equal infinities are caught by fa == fb
            d = np.abs(fa - fb)
            bound = np.maximum(tol.atol, tol.rtol * np.maximum(np.abs(fa), np.abs(fb)))
            bad = ~(((d <= bound) & np.isfinite(d)) | (fa == fb) | (np.isnan(fa) & np.isnan(fb)))
        if bad.any():  # one entry per array: its first bad element, with the largest difference
            i = int(np.argmax(bad))
            worst = float(np.max(np.where(bad & np.isfinite(d), d, 0.0)))
            yield FieldDifference(f"{path}[{i}]", _text(a.ravel()[i]), _text(b.ravel()[i]), worst)
        return
    for i, (x, y) in enumerate(zip(a.ravel(), b.ravel())):
        if x != y:
            yield FieldDifference(f"{path}[{i}]", _text(x), _text(y), float("nan"))


def field_differences(
    a: Any, b: Any, tol: FieldTolerance = DEFAULT_FIELD_TOLERANCE, ignore: Sequence[str] = (), path: str = ""
) -> Iterator[FieldDifference]:
    """Every field of two messages (or values) that differs beyond ``tol``, in field order."""
    if path and _ignored(path, ignore):
        return
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        if type(a) is not type(b):
            yield FieldDifference(path or "(type)", type(a).__name__, type(b).__name__, float("nan"))
            return
        for f in dataclasses.fields(a):
            yield from field_differences(getattr(a, f.name), getattr(b, f.name), tol, ignore, _join(path, f.name))
        return
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        yield from _arrays(path, np.asarray(a), np.asarray(b), tol)
        return
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        if len(a) != len(b):
            yield FieldDifference(f"{path}.length", str(len(a)), str(len(b)), float("nan"))
        for i, (x, y) in enumerate(zip(a, b)):
            yield from field_differences(x, y, tol, ignore, f"{path}[{i}]")
        return
    numeric = (int, float, np.integer, np.floating)
    if isinstance(a, numeric) and isinstance(b, numeric) and not isinstance(a, bool) and not isinstance(b, bool):
        fa, fb = float(a), float(b)
        if not tol.close(fa, fb):
            yield FieldDifference(path, _text(a), _text(b), abs(fa - fb))
        return
    if a != b:
        yield FieldDifference(path, _text(a), _text(b), float("nan"))


def first_field_difference(
    a: Any, b: Any, tol: FieldTolerance = DEFAULT_FIELD_TOLERANCE, ignore: Sequence[str] = ()
) -> FieldDifference | None:
    """The first field (in field order) that differs beyond ``tol``, or None."""
    return next(iter(field_differences(a, b, tol, ignore)), None)
