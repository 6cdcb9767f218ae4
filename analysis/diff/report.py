"""A ``DiffReport`` for people and machines: a text table, deterministic JSON, Markdown.

JSON: sorted keys, two-space indent, floats written with 9 significant digits, NaN and infinities as
null, each named under ``non_finite_values`` (``navlog.replay.io.json_text``): the same report gives the
same bytes. Markdown: a
one-line verdict, then the checks that failed (REGRESSED, CHANGED), the improvements, the checks
within tolerance, and a count of the equal ones; kept under GitHub's 65,536-character comment limit.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from navlog.analysis.diff.result import Check, DiffReport, Verdict
from navlog.replay.io import json_text
from navlog.replay.io.atomic import write_file

__all__ = ["format_report", "to_json", "to_markdown", "write_text"]

ORDER = (Verdict.REGRESSED, Verdict.CHANGED, Verdict.IMPROVED, Verdict.WITHIN, Verdict.EQUAL)
MARKDOWN_LIMIT = 60_000  # characters, below GitHub's 65,536 per comment


def _canonical(v: Any) -> Any:
    if isinstance(v, float):
        return float(f"{v:.9g}") if math.isfinite(v) else v  # non-finite: null, named (json_text)
    if isinstance(v, dict):
        return {str(k): _canonical(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_canonical(x) for x in v]
    if hasattr(v, "item"):  # numpy scalars
        return _canonical(v.item())
    return v


def to_json(report: DiffReport) -> str:
    return json_text.dumps(_canonical(report.to_dict()), indent=2, sort_keys=True) + "\n"


def _summary(report: DiffReport) -> str:
    counts = ", ".join(f"{n} {v.lower()}" for v, n in report.counts().items() if n)
    verdict = "PASS" if report.passed else "FAIL"
    return f"{verdict}: {report.b} against {report.a} ({counts or 'nothing compared'})"


def format_report(report: DiffReport) -> str:
    """The checks as a table (in name order), the first divergence and the notes."""
    from navlog.replay.runtime.progress import format_table

    rows = [(c.verdict.value, c.name, c.kind, c.detail) for c in report.checks]
    parts = [_summary(report), format_table(("verdict", "name", "comparator", "what moved"), rows)]
    if report.first_divergence is not None:
        parts.append(f"first divergence: {report.first_divergence.describe()}")
    if report.ignored:
        parts.append("ignored: " + ", ".join(report.ignored))
    if report.notes:
        parts.append("notes:\n" + "\n".join(f"  {n}" for n in report.notes))
    return "\n\n".join(parts)


def _md(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _rows(checks: list[Check]) -> list[str]:
    out = ["| verdict | name | comparator | what moved |", "|---|---|---|---|"]
    out += [f"| {c.verdict.value} | `{_md(c.name)}` | {c.kind} | {_md(c.detail)} |" for c in checks]
    return out


def to_markdown(report: DiffReport) -> str:
    """Markdown for a pull-request comment: regressions first, equal checks only counted."""
    lines = [f"### navlog diff: {_summary(report)}", ""]
    if report.first_divergence is not None:
        lines += [f"First divergence: `{_md(report.first_divergence.describe())}`", ""]
    shown = sorted((c for c in report.checks if c.verdict is not Verdict.EQUAL), key=lambda c: ORDER.index(c.verdict))
    if shown:
        lines += _rows(shown) + [""]
    equal = sum(c.verdict is Verdict.EQUAL for c in report.checks)
    if equal:
        lines += [f"{equal} equal (same bytes or values).", ""]
    if report.notes:
        lines += ["<details><summary>notes</summary>", ""] + [f"- {_md(n)}" for n in report.notes]
        lines += ["", "</details>", ""]
    text = "\n".join(lines)
    if len(text) > MARKDOWN_LIMIT:
        cut = text.rfind("\n", 0, MARKDOWN_LIMIT)
        text = text[:cut] + "\n\n(cut to fit a comment; the JSON report has every check)\n"
    return text


def write_text(text: str, path: str | Path) -> Path:
    """Write a report file (parent folders created); errors name the file."""
    return write_file(Path(path), text)
