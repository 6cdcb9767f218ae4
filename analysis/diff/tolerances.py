"""Tolerances of ``navlog diff``: one typed section per comparator, set from ``KEY=VALUE`` text.

Every key is ``SECTION.FIELD`` (``grid.changed_share=0.001``, ``twist.max_abs=1e-6``); a misspelled
section or field is refused with the key and a did-you-mean. Values are floats; distances in metres,
shares as fractions (0.001 = 0.1 %).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field, fields, replace
from typing import Any

from navlog.errors import ConfigError
from navlog.replay.config import suggest

__all__ = [
    "DEFAULT_TOLERANCES",
    "DiffTolerances",
    "FieldTolerance",
    "GridTolerance",
    "MetricTolerance",
    "PathTolerance",
    "PointsTolerance",
    "TrajectoryTolerance",
    "TwistTolerance",
    "as_dict",
    "parse_tolerances",
    "tolerance_keys",
    "within",
]


@dataclass(frozen=True)
class GridTolerance:
    """Occupancy grids: share of cells that changed class, and the Hausdorff distance of the occupied sets."""

    changed_share: float = 0.001  # 0.1 % of the cells
    hausdorff_m: float = 0.05  # one cell at 0.05 m


@dataclass(frozen=True)
class PointsTolerance:
    """Point maps (PCD): a point is 'beyond' when its nearest neighbour on the other side is farther than tau_m."""

    tau_m: float = 0.05
    beyond_share: float = 0.001
    chamfer_m: float = 0.01


@dataclass(frozen=True)
class PathTolerance:
    """Plans: Hausdorff distance between the paths, length change, goal-endpoint error, relative cost change."""

    hausdorff_m: float = 0.05
    length_m: float = 0.05
    endpoint_m: float = 0.05
    cost_rtol: float = 0.01


@dataclass(frozen=True)
class TwistTolerance:
    """Velocity commands, paired in order: the largest difference on any axis (m/s, rad/s)."""

    max_abs: float = 1e-6


@dataclass(frozen=True)
class TrajectoryTolerance:
    """Trajectories: ATE and RPE (translation RMSE, m) of B against A, poses associated within max_diff_s."""

    ate_m: float = 0.01
    rpe_m: float = 0.01
    max_diff_s: float = 0.01
    rpe_delta_frames: float = 1.0


@dataclass(frozen=True)
class MetricTolerance:
    """metrics.json values: equal within max(atol, rtol * max(|a|, |b|)); beyond it IMPROVED or REGRESSED."""

    atol: float = 1e-9
    rtol: float = 1e-6


@dataclass(frozen=True)
class FieldTolerance:
    """Any other message, field by field: equal within max(atol, rtol * max(|a|, |b|))."""

    atol: float = 0.0
    rtol: float = 0.0

    def close(self, a: float, b: float) -> bool:
        if a == b or (math.isnan(a) and math.isnan(b)):
            return True
        if not (math.isfinite(a) and math.isfinite(b)):
            return False
        return abs(a - b) <= max(self.atol, self.rtol * max(abs(a), abs(b)))


@dataclass(frozen=True)
class DiffTolerances:
    """All the tolerances of one diff; each section is one comparator's."""

    grid: GridTolerance = field(default_factory=GridTolerance)
    points: PointsTolerance = field(default_factory=PointsTolerance)
    path: PathTolerance = field(default_factory=PathTolerance)
    twist: TwistTolerance = field(default_factory=TwistTolerance)
    trajectory: TrajectoryTolerance = field(default_factory=TrajectoryTolerance)
    metric: MetricTolerance = field(default_factory=MetricTolerance)
    field: FieldTolerance = field(default_factory=FieldTolerance)

    def to_dict(self) -> dict[str, dict[str, float]]:
        return {s.name: as_dict(getattr(self, s.name)) for s in fields(self)}


#: the defaults, shared (the sections are frozen)
DEFAULT_TOLERANCES = DiffTolerances()
DEFAULT_FIELD_TOLERANCE = FieldTolerance()


def within(value: float, limit: float) -> bool:
    """``value <= limit``, forgiving the last bits of float rounding (0.1 + 0.2 is within 0.3)."""
    return value <= limit + 1e-9 * max(abs(limit), 1e-3)


def as_dict(section: Any) -> dict[str, float]:
    """One section's tolerances as ``{field: value}``."""
    return {f.name: float(getattr(section, f.name)) for f in fields(section)}


def tolerance_keys() -> list[str]:
    """Every ``SECTION.FIELD`` key ``parse_tolerances`` accepts."""
    return [f"{s}.{k}" for s, section in DiffTolerances().to_dict().items() for k in section]


def parse_tolerances(items: Iterable[str], base: DiffTolerances | None = None) -> DiffTolerances:
    """``base`` (default: the defaults) with ``SECTION.FIELD=VALUE`` items applied; bad keys or values
    raise ``ConfigError`` naming the item, with a did-you-mean for the key."""
    tol = base or DiffTolerances()
    keys = tolerance_keys()
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep:
            raise ConfigError(f"--tol '{item}': expected KEY=VALUE, e.g. grid.changed_share=0.001")
        if key not in keys:
            raise ConfigError(
                f"--tol '{item}': unknown tolerance '{key}'{suggest(key, keys)}; known: {', '.join(keys)}"
            )
        try:
            value = float(text)
        except ValueError:
            raise ConfigError(f"--tol '{item}': value '{text.strip()}' is not a number") from None
        if not (math.isfinite(value) and value >= 0):
            raise ConfigError(f"--tol '{item}': value must be a finite number >= 0")
        section, name = key.split(".", 1)
        sub: Any = getattr(tol, section)
        tol = replace(tol, **{section: replace(sub, **{name: value})})
    return tol
