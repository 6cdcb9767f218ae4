"""A fleet's summary: one row per log and a totals row, as JSON (machines), CSV (spreadsheets) and
Markdown (people, PR comments).

A row holds the log, its output folder, its status (``ok`` or ``failed``, and why), whether an
up-to-date replay was reused (``cached``) and how many attempts it took, the log's duration (sim
time), the messages read, the messages the pipeline published, the inputs it skipped (the JSON has
each reason), and the pipeline's metrics (mapping: trajectory errors against the log's ground
truth). Nothing in it depends on the machine, the executor or the wall clock, so the same fleet
gives the same bytes whichever executor ran it.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from typing import Any

from navlog.analysis.fleet.worker import LogResult
from navlog.replay.io import json_text

__all__ = [
    "HEADLINE_METRICS",
    "NUMERIC_COLUMNS",
    "SUMMARY_FILES",
    "summary_document",
    "summary_table",
    "to_csv",
    "to_json",
    "to_markdown",
]

SUMMARY_FILES = {"json": "fleet-summary.json", "csv": "fleet-summary.csv", "md": "fleet-summary.md"}
# the metrics the Markdown and console tables show (the JSON and CSV have every one)
HEADLINE_METRICS = {
    "trajectory.ate.translation_m.rmse": "ATE rmse m",
    "trajectory.rpe.translation_m.rmse": "RPE rmse m",
}
# the table's columns of numbers (right-aligned)
NUMERIC_COLUMNS = ("duration s", "messages", "published", "skipped", *HEADLINE_METRICS.values())


def _row(r: LogResult) -> dict[str, Any]:
    return {
        "log": r.log,
        "output": r.name,
        "status": r.status,
        "reason": r.reason,
        "cached": r.cached,
        "attempts": r.attempts,
        "duration_s": r.duration_s,
        "messages": r.messages,
        "published": sum(r.published.values()),
        "skipped": sum(r.skipped.values()),
        "truncated": r.truncated,
        "published_by_topic": dict(sorted(r.published.items())),
        "skipped_by_reason": dict(sorted(r.skipped.items())),
        "outputs": dict(sorted(r.outputs.items())),
        "metrics": dict(sorted(r.metrics.items())),
        "metrics_error": r.metrics_error,
    }


def _totals(results: Sequence[LogResult]) -> dict[str, Any]:
    return {
        "logs": len(results),
        "ok": sum(r.ok for r in results),
        "failed": sum(not r.ok for r in results),
        "cached": sum(r.cached for r in results),
        "duration_s": sum(r.duration_s for r in results),
        "messages": sum(r.messages for r in results),
        "published": sum(sum(r.published.values()) for r in results),
        "skipped": sum(sum(r.skipped.values()) for r in results),
    }


def summary_document(pipeline: str, results: Sequence[LogResult], *, version: str) -> dict[str, Any]:
    """The summary as one JSON-ready document: ``logs`` (one row each) and ``totals``."""
    return {
        "navlog_version": version,
        "pipeline": pipeline,
        "logs": [_row(r) for r in results],
        "totals": _totals(results),
    }


def to_json(document: dict[str, Any]) -> str:
    return json_text.dumps(document, indent=2, sort_keys=True) + "\n"


SCALARS = (
    "log",
    "output",
    "status",
    "cached",
    "attempts",
    "duration_s",
    "messages",
    "published",
    "skipped",
    "truncated",
)


def to_csv(document: dict[str, Any]) -> str:
    """One line per log (every metric a column) and a ``TOTAL`` line; the reason last."""
    metrics = sorted({k for row in document["logs"] for k in row["metrics"]})
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([*SCALARS, *metrics, "reason"])
    for row in document["logs"]:
        writer.writerow([*(row[k] for k in SCALARS), *(row["metrics"].get(m, "") for m in metrics), row["reason"]])
    t = document["totals"]
    status = f"{t['ok']} ok, {t['failed']} failed"
    total = ["TOTAL", f"{t['logs']} logs", status, t["cached"], "", t["duration_s"], t["messages"], t["published"]]
    writer.writerow([*total, t["skipped"], "", *([""] * len(metrics)), ""])
    return buf.getvalue()


def summary_table(document: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Headers and cells of the table people read (Markdown, the console): the headline metrics only."""
    shown = [m for m in HEADLINE_METRICS if any(m in row["metrics"] for row in document["logs"])]
    headers = ["log", "status", "duration s", "messages", "published", "skipped", *(HEADLINE_METRICS[m] for m in shown)]
    headers.append("reason")
    cells = []
    for row in document["logs"]:
        status = row["status"] + (" (cached)" if row["cached"] else "")
        metrics = [f"{row['metrics'][m]:.4g}" if m in row["metrics"] else "" for m in shown]
        counts = [f"{row['duration_s']:.2f}", str(row["messages"]), str(row["published"]), str(row["skipped"])]
        cells.append([row["output"], status, *counts, *metrics, " ".join(row["reason"].split())])
    t = document["totals"]
    counts = [f"{t['duration_s']:.2f}", str(t["messages"]), str(t["published"]), str(t["skipped"])]
    cells.append([f"total ({t['logs']} logs)", f"{t['ok']} ok, {t['failed']} failed", *counts, *[""] * len(shown), ""])
    return headers, cells


def to_markdown(document: dict[str, Any]) -> str:
    headers, cells = summary_table(document)

    def line(values: Sequence[str]) -> str:
        return "| " + " | ".join(v.replace("|", "\\|") for v in values) + " |"

    rule = ["---:" if h in NUMERIC_COLUMNS else "---" for h in headers]
    title = f"# Fleet replay: {document['totals']['logs']} logs through '{document['pipeline']}'\n\n"
    return title + "\n".join([line(headers), line(rule), *(line(c) for c in cells)]) + "\n"
