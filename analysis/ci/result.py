"""What ``run_suite`` returns: a status per check and per case, the suite's verdict and exit code.

Statuses, from best to worst: PASS, IMPROVED (a metric moved the good way: the case passes; update
the baseline to keep the gain), NEW (no baseline, or one from another navlog version: a failure unless
updating), FAIL (an output moved beyond tolerance, an invariant does not hold, the recorded golden log
differs from the baseline's), NONDETERMINISTIC (two replays gave different bytes), INVALID_INPUT (the
log fails its checks), ERROR (the case could not run). A case takes its worst check's status.

Exit codes: 2 when a case is INVALID_INPUT or ERROR (bad input), else 3 when one is NONDETERMINISTIC,
else 1 when one is FAIL or NEW (a regression), else 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

__all__ = ["CaseResult", "CheckResult", "Status", "SuiteResult", "exit_code", "worst"]

SCHEMA = "navlog-ci/1"


class Status(StrEnum):
    PASS = "PASS"
    IMPROVED = "IMPROVED"
    NEW = "NEW"
    FAIL = "FAIL"
    NONDETERMINISTIC = "NONDETERMINISTIC"
    INVALID_INPUT = "INVALID_INPUT"
    ERROR = "ERROR"

    @property
    def failed(self) -> bool:
        return self not in (Status.PASS, Status.IMPROVED)


ORDER = tuple(Status)  # best first


def worst(statuses: list[Status]) -> Status:
    """The most severe status of a list (PASS for an empty one)."""
    return max(statuses, key=ORDER.index, default=Status.PASS)


def exit_code(statuses: list[Status]) -> int:
    if any(s in (Status.INVALID_INPUT, Status.ERROR) for s in statuses):
        return 2
    if Status.NONDETERMINISTIC in statuses:
        return 3
    if any(s in (Status.FAIL, Status.NEW) for s in statuses):
        return 1
    return 0


@dataclass(frozen=True)
class CheckResult:
    """One check of a case: ``kind`` is input, recipe, baseline, determinism, diff, invariant or error;
    ``name`` the artifact, metric or invariant it judged; ``values`` the figures it was judged on."""

    name: str
    kind: str
    status: Status
    message: str = ""
    values: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "status": str(self.status),
            "message": self.message,
            "values": dict(self.values),
        }


@dataclass(frozen=True)
class CaseResult:
    """One case: its checks, the facts its invariants read (numbers, for reports), notes, and the wall
    times of its steps (``timings``: log, replay, compare; not part of the JSON, which must not vary)."""

    name: str
    pipeline: str
    source: str
    checks: tuple[CheckResult, ...]
    facts: dict[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    baseline_written: bool = False
    timings: dict[str, float] = field(default_factory=dict, compare=False)
    replay_cached: bool = field(default=False, compare=False)

    @property
    def status(self) -> Status:
        return worst([c.status for c in self.checks])

    def failed(self) -> list[CheckResult]:
        return [c for c in self.checks if c.status.failed]

    def check(self, name: str) -> CheckResult:
        """A check by name (KeyError when there is none)."""
        for c in self.checks:
            if c.name == name:
                return c
        raise KeyError(name)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "pipeline": self.pipeline,
            "source": self.source,
            "status": str(self.status),
            "checks": [c.to_dict() for c in self.checks],
            "facts": dict(sorted(self.facts.items())),
            "notes": list(self.notes),
            "baseline_written": self.baseline_written,
        }


@dataclass(frozen=True)
class SuiteResult:
    suite: str
    path: str
    navlog_version: str
    cases: tuple[CaseResult, ...]
    unused_baselines: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    @property
    def status(self) -> Status:
        return worst([c.status for c in self.cases])

    @property
    def exit_code(self) -> int:
        return exit_code([c.status for c in self.cases])

    def case(self, name: str) -> CaseResult:
        for c in self.cases:
            if c.name == name:
                return c
        raise KeyError(name)

    def counts(self) -> dict[str, int]:
        return {str(s): sum(c.status is s for c in self.cases) for s in Status}

    def to_dict(self) -> dict[str, Any]:
        return {
            "schema": SCHEMA,
            "suite": self.suite,
            "path": self.path,
            "navlog_version": self.navlog_version,
            "status": str(self.status),
            "exit_code": self.exit_code,
            "counts": self.counts(),
            "cases": [c.to_dict() for c in self.cases],
            "unused_baselines": list(self.unused_baselines),
            "notes": list(self.notes),
        }
