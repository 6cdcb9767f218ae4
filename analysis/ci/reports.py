"""A suite's result for people and machines, all from one run: text, JSON, JUnit XML, Markdown.

- JSON (``navlog-ci/1``): sorted keys, two-space indent, floats with 9 significant digits, no wall
  times or cache states: the same results give the same bytes.
- JUnit XML: a ``testsuite`` per case, a ``testcase`` per check; FAIL, NEW and NONDETERMINISTIC are
  ``failure``s, INVALID_INPUT and ERROR ``error``s (an invalid input also adds a skipped ``replay``
  test case: the case was not replayed); the case's numeric facts (metrics, plans, safety) and its
  pipeline and log are ``property`` elements.
- Markdown, for a pull-request comment or ``$GITHUB_STEP_SUMMARY``: the verdict, a table of the cases
  (regressions first), then the checks that did not pass per case; under 65,536 characters.
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from navlog.analysis.ci.result import ORDER, CaseResult, CheckResult, Status, SuiteResult
from navlog.analysis.tables import figure
from navlog.replay.io import json_text
from navlog.replay.io.atomic import WriteError, write_file

__all__ = ["format_result", "grouped", "to_json", "to_junit", "to_markdown", "write_reports"]

MARKDOWN_LIMIT = 60_000  # characters, below GitHub's 65,536 per comment or summary
FAILURE = {Status.FAIL, Status.NEW, Status.NONDETERMINISTIC}
ERROR = {Status.INVALID_INPUT, Status.ERROR}


def _plain(v: Any) -> Any:
    if isinstance(v, bool) or v is None or isinstance(v, str | int):
        return v
    if isinstance(v, float):
        return float(f"{v:.9g}") if math.isfinite(v) else v  # non-finite: null, named (json_text)
    if isinstance(v, Mapping):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    if hasattr(v, "item"):  # numpy scalars
        return _plain(v.item())
    return str(v)


def to_json(result: SuiteResult) -> str:
    return json_text.dumps(_plain(result.to_dict()), indent=2, sort_keys=True) + "\n"


def _worst_first(result: SuiteResult) -> list[CaseResult]:
    return sorted(result.cases, key=lambda c: -ORDER.index(c.status))


def _summary(result: SuiteResult) -> str:
    counts = ", ".join(f"{n} {s}" for s, n in result.counts().items() if n)
    return f"{result.status}: suite {result.suite}, {len(result.cases)} cases ({counts}), exit {result.exit_code}"


SHOWN_NAMES = 6  # the names a grouped line lists before "and N more"


def _cause(check: CheckResult) -> str:
    """What a check's change comes from: its output file (``metrics.json`` for ``metrics.json:map_2d.iou``;
    ``map.yaml`` for ``map.pgm`` judged with it)."""
    judged = re.search(r"\(judged with ([^)]+)\)", check.message)
    return judged.group(1) if judged else check.name.split(":", 1)[0]


def grouped(checks: Sequence[CheckResult]) -> list[tuple[Status, str, str, int]]:
    """The checks that did not pass, one row per cause: (status, what, message, count). Checks of one
    status from one output (every moved metric of metrics.json; map.yaml and the map.pgm judged with
    it) share a row that gives the first one's message and names the others."""
    groups: dict[tuple[Status, str], list[CheckResult]] = {}
    for c in checks:
        if c.status is not Status.PASS:
            groups.setdefault((c.status, _cause(c)), []).append(c)
    rows = []
    for (status, cause), members in groups.items():
        first = members[0]
        if len(members) == 1:
            rows.append((status, first.name, first.message, 1))
            continue
        parts = [m.name.split(":", 1)[1] if ":" in m.name else m.name for m in members]
        unit = "metrics" if all(":" in m.name for m in members) else "checks"
        rest = parts[1:]
        listed = ", ".join(rest[:SHOWN_NAMES]) + (
            f" and {len(rest) - SHOWN_NAMES} more" if len(rest) > SHOWN_NAMES else ""
        )
        rows.append(
            (status, f"{cause} ({len(members)} {unit})", f"{parts[0]}: {first.message}; also {listed}", len(members))
        )
    return rows


def format_result(result: SuiteResult) -> str:
    """The cases as a table, then every check that did not pass, the notes and unused baselines."""
    from navlog.analysis.tables import indented, render, table

    cases = table(
        ("Status", "Case", "Pipeline", "Log", "Checks"),
        (
            (
                str(c.status),
                c.name,
                c.pipeline,
                c.source,
                f"{sum(not k.status.failed for k in c.checks)}/{len(c.checks)}",
            )
            for c in result.cases
        ),
    )
    parts: list[Any] = [_summary(result), *[f"note: {n}" for n in result.notes], indented(cases)]
    for c in _worst_first(result):
        shown = grouped(c.checks)
        if shown:
            parts.append(f"{c.name}:")
            parts.append(indented(table(("Status", "Check", "What"), ((str(s), name, m) for s, name, m, _ in shown))))
        parts += [f"{c.name}: note: {n}" for n in c.notes]
    if result.unused_baselines:
        parts.append("unused baselines (no case of that name): " + ", ".join(result.unused_baselines))
    return render(*parts)


def to_junit(result: SuiteResult) -> str:
    root = ET.Element("testsuites", name=f"navlog ci: {result.suite}")
    totals = {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}
    for case in result.cases:
        suite = ET.SubElement(root, "testsuite", name=f"{result.suite}.{case.name}")
        props = ET.SubElement(suite, "properties")
        ET.SubElement(props, "property", name="pipeline", value=case.pipeline)
        ET.SubElement(props, "property", name="log", value=case.source)
        ET.SubElement(props, "property", name="status", value=str(case.status))
        for key, value in sorted(case.facts.items()):
            ET.SubElement(props, "property", name=key, value=figure(value, ".9g"))
        counts = {"tests": 0, "failures": 0, "errors": 0, "skipped": 0}
        for check in case.checks:
            test = ET.SubElement(
                suite, "testcase", classname=f"{result.suite}.{case.name}", name=f"{check.kind} {check.name}"
            )
            counts["tests"] += 1
            if check.status in FAILURE:
                counts["failures"] += 1
                ET.SubElement(test, "failure", type=str(check.status), message=check.message).text = check.message
            elif check.status in ERROR:
                counts["errors"] += 1
                ET.SubElement(test, "error", type=str(check.status), message=check.message).text = check.message
            elif check.status is Status.IMPROVED:
                ET.SubElement(test, "system-out").text = f"IMPROVED: {check.message}"
        if case.status is Status.INVALID_INPUT:
            test = ET.SubElement(suite, "testcase", classname=f"{result.suite}.{case.name}", name="replay")
            ET.SubElement(test, "skipped", message="not replayed: the log fails its input checks")
            counts["tests"] += 1
            counts["skipped"] += 1
        for k, n in counts.items():
            suite.set(k, str(n))
            totals[k] += n
    for k, n in totals.items():
        root.set(k, str(n))
    ET.indent(root)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _md(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def to_markdown(result: SuiteResult) -> str:
    """Markdown for a pull request: the verdict, the cases (worst first), the checks that did not pass."""
    icon = "✅" if result.exit_code == 0 else "❌"
    lines = [f"### {icon} navlog ci: {_summary(result)}", ""]
    lines += [f"- {_md(n)}" for n in result.notes] + ([""] if result.notes else [])
    lines += ["| status | case | pipeline | log | not passed |", "|---|---|---|---|---|"]
    for c in _worst_first(result):
        bad = [k.name for k in c.checks if k.status is not Status.PASS]
        lines.append(
            f"| {c.status} | `{_md(c.name)}` | {c.pipeline} | {_md(c.source)} | {_md(', '.join(bad)) or '-'} |"
        )
    lines.append("")
    for c in _worst_first(result):
        shown = [k for k in c.checks if k.status is not Status.PASS]
        if not shown and not c.notes:
            continue
        lines += [f"#### {c.status}: `{_md(c.name)}`", ""]
        if shown:
            rows = sorted(grouped(shown), key=lambda row: -ORDER.index(row[0]))
            lines += ["| status | check | what |", "|---|---|---|"]
            lines += [f"| {status} | `{_md(name)}` | {_md(message)} |" for status, name, message, _ in rows]
            lines.append("")
        lines += [f"- {_md(n)}" for n in c.notes]
        if c.notes:
            lines.append("")
    if result.unused_baselines:
        lines += [
            "Unused baselines (no case of that name): " + ", ".join(f"`{n}`" for n in result.unused_baselines),
            "",
        ]
    text = "\n".join(lines)
    if len(text) > MARKDOWN_LIMIT:
        cut = text.rfind("\n", 0, MARKDOWN_LIMIT)
        text = text[:cut] + "\n\n(cut to fit; the JSON report has every check)\n"
    return text


def _write(path: Path, text: str, *, append: bool = False) -> Path:
    """A report file, whole or not at all (``write_file``); appended to (the CI's step summary) in place."""
    if not append:
        return write_file(path, text)
    try:
        with open(path, "a", encoding="utf-8") as f:
            f.write(text)
    except OSError as exc:
        raise WriteError(path, f"cannot write the report: {exc.strerror}") from None
    return path


def write_reports(
    result: SuiteResult,
    *,
    json_path: Path | str | None = None,
    junit_path: Path | str | None = None,
    markdown_path: Path | str | None = None,
    environ: Mapping[str, str] | None = None,
) -> list[Path]:
    """Write the asked-for reports; the Markdown is also appended to the file GitHub Actions names in
    ``$GITHUB_STEP_SUMMARY`` when ``environ`` (default ``os.environ``) sets it. The files written."""
    step_summary = (os.environ if environ is None else environ).get("GITHUB_STEP_SUMMARY")
    written = []
    if json_path:
        written.append(_write(Path(json_path), to_json(result)))
    if junit_path:
        written.append(_write(Path(junit_path), to_junit(result)))
    if markdown_path:
        written.append(_write(Path(markdown_path), to_markdown(result)))
    if step_summary:
        written.append(_write(Path(step_summary), to_markdown(result) + "\n", append=True))
    return written
