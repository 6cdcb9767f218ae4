"""The plain data a diff returns: one ``Check`` per artifact, topic or metric, a ``Divergence``, the report.

Verdicts: ``EQUAL`` (same bytes or same values), ``WITHIN`` (different, within tolerance), ``CHANGED``
(beyond tolerance, or present on one side only), and for metrics with a direction ``IMPROVED`` /
``REGRESSED``. A report passes when no check is CHANGED or REGRESSED.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Check", "DiffReport", "Divergence", "Verdict"]


class Verdict(enum.Enum):
    EQUAL = "EQUAL"
    WITHIN = "WITHIN"
    IMPROVED = "IMPROVED"
    CHANGED = "CHANGED"
    REGRESSED = "REGRESSED"

    @property
    def failed(self) -> bool:
        return self in (Verdict.CHANGED, Verdict.REGRESSED)


@dataclass(frozen=True)
class Check:
    """One compared thing: ``name`` (artifact file, topic or metric key), ``kind`` (the comparator),
    the verdict, the figures it was judged on (``values``), the tolerances used and a short note."""

    name: str
    kind: str
    verdict: Verdict
    values: dict[str, Any] = field(default_factory=dict)
    tolerance: dict[str, float] = field(default_factory=dict)
    detail: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "verdict": self.verdict.value,
            "values": dict(self.values),
            "tolerance": dict(self.tolerance),
            "detail": self.detail,
        }


@dataclass(frozen=True)
class Divergence:
    """Where two logs first differ: the message's log time (ns, and s from the log's start), topic,
    index within the topic, the field path and the two values (as text)."""

    topic: str
    index: int
    time_ns: int
    time_s: float
    field: str
    old: str
    new: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "topic": self.topic,
            "index": self.index,
            "time_ns": self.time_ns,
            "time_s": self.time_s,
            "field": self.field,
            "old": self.old,
            "new": self.new,
        }

    def describe(self) -> str:
        return (
            f"{self.topic}[{self.index}] at {self.time_s:.3f} s: {self.field or '(message)'} {self.old} -> {self.new}"
        )


@dataclass(frozen=True)
class DiffReport:
    """What moved between A and B. ``kind`` is ``replay`` (two output folders) or ``log``."""

    a: str
    b: str
    kind: str
    checks: tuple[Check, ...]
    first_divergence: Divergence | None = None
    notes: tuple[str, ...] = ()
    ignored: tuple[str, ...] = ()
    tolerances: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return not any(c.verdict.failed for c in self.checks)

    @property
    def exit_code(self) -> int:
        return 0 if self.passed else 1

    def check(self, name: str) -> Check:
        """The check of an artifact, topic or metric by name (KeyError when there is none)."""
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def counts(self) -> dict[str, int]:
        return {v.value: sum(c.verdict is v for c in self.checks) for v in Verdict}

    def to_dict(self) -> dict[str, Any]:
        return {
            "schema": "navlog-diff/1",
            "a": self.a,
            "b": self.b,
            "kind": self.kind,
            "passed": self.passed,
            "counts": self.counts(),
            "checks": [c.to_dict() for c in self.checks],
            "first_divergence": self.first_divergence.to_dict() if self.first_divergence else None,
            "notes": list(self.notes),
            "ignored": list(self.ignored),
            "tolerances": self.tolerances,
        }
