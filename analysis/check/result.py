"""What ``check_log`` returns: plain data (statuses, checks, per-topic figures), as JSON and as text.

Every check has a name (``integrity``, ``types``, ``required``, ``rate``, ``gaps``, ``stamps``, ``tf``,
``scan_values``), the topic or frame chain it is about, a status (PASS, WARN, FAIL), its numbers and a
one-line message that names the topic and suggests a fix. A log is fit to replay when no check FAILs.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from enum import StrEnum
from typing import Any

from navlog.replay.io import json_text

__all__ = ["Check", "LogCheck", "Status", "TopicFigures", "format_check"]

Number = int | float | str | None


class Status(StrEnum):
    PASS = "PASS"
    WARN = "WARN"
    FAIL = "FAIL"


_RANK = {Status.PASS: 0, Status.WARN: 1, Status.FAIL: 2}


def worst(statuses: list[Status]) -> Status:
    """The most severe status of a list (PASS for an empty one)."""
    return max(statuses, key=_RANK.__getitem__, default=Status.PASS)


@dataclass(frozen=True)
class Check:
    name: str  # the kind of check: integrity, types, required, rate, gaps, stamps, tf, scan_values
    subject: str  # the topic, the frame chain (``map->base_link``) or the file it is about
    status: Status
    message: str  # one line: what was found, and how to fix it
    numbers: dict[str, Number] = field(default_factory=dict)


@dataclass(frozen=True)
class TopicFigures:
    """The measured figures of one topic (times in seconds; rates in Hz; None when not measurable)."""

    topic: str
    typename: str
    count: int
    rate_hz: float | None  # (distinct log times - 1) / the topic's own span of log times (checks._instants)
    median_rate_hz: float | None  # 1 / the median period
    max_gap_s: float | None
    log_time_backward: int  # steps back in log time, in the order the file stores the messages
    stamp_backward: int | None  # steps back in header stamps (None: the type has no header stamp)


@dataclass(frozen=True)
class LogCheck:
    path: str
    format: str
    start_ns: int
    end_ns: int
    messages: int  # messages read
    order: str  # the order the stamps were checked in: "file" (MCAP) or "log time" (rosbag2 storage)
    topics: list[TopicFigures]
    checks: list[Check]

    @property
    def status(self) -> Status:
        return worst([c.status for c in self.checks])

    @property
    def failed(self) -> list[Check]:
        return [c for c in self.checks if c.status is Status.FAIL]

    def to_dict(self) -> dict[str, Any]:
        """Plain data (the JSON of ``navlog check --json``)."""
        out = asdict(self)
        out["status"] = str(self.status)
        out["duration_s"] = round(max(0, self.end_ns - self.start_ns) / 1e9, 9)
        out["counts"] = {str(s): sum(c.status is s for c in self.checks) for s in Status}
        return _plain(out)

    def to_json(self) -> str:
        """``to_dict`` as JSON: the same result gives the same bytes (sorted keys, fixed rounding)."""
        return json_text.dumps(self.to_dict(), indent=2, sort_keys=True) + "\n"


def _plain(value: Any) -> Any:
    """Statuses as strings, floats rounded to 9 digits (no NaN in JSON)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, StrEnum):
        return str(value)
    if isinstance(value, float):
        return round(value, 9) if value == value and abs(value) != float("inf") else None
    return value


def _num(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def format_check(result: LogCheck) -> str:
    """A ``LogCheck`` as text: the log, its topics' figures, every check, and the verdict."""
    from navlog.analysis.tables import grid, indented, render, table

    head = grid(
        [
            ("Log:", result.path),
            ("Format:", result.format),
            ("Span:", f"{(result.end_ns - result.start_ns) / 1e9:.3f} s ({result.messages} messages read)"),
        ]
    )
    topics = table(
        ("Topic", "Type", "Count", "Rate (Hz)", "Median (Hz)", "Max gap (s)", "Back (log)", "Back (stamp)"),
        (
            (
                t.topic,
                t.typename,
                str(t.count),
                _num(t.rate_hz, 2),
                _num(t.median_rate_hz, 2),
                _num(t.max_gap_s, 3),
                str(t.log_time_backward),
                "-" if t.stamp_backward is None else str(t.stamp_backward),
            )
            for t in result.topics
        ),
        right=(2, 3, 4, 5, 6, 7),
    )
    checks = table(
        ("Status", "Check", "Subject", "Message"),
        ((str(c.status), c.name, c.subject, c.message) for c in result.checks),
    )
    counts = ", ".join(f"{sum(c.status is s for c in result.checks)} {s}" for s in Status)
    verdict = "not fit to replay" if result.failed else "fit to replay"
    return render(
        head,
        "Topics:",
        indented(topics),
        "Checks:",
        indented(checks),
        f"Result: {result.status} ({counts}): {verdict}",
    )
