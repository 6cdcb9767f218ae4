"""A campaign's reports: ``campaign.json`` (summary and rows), ``campaign.csv`` (one row per run),
``campaign.md`` (the summary as tables) and ``campaign.png`` (success by difficulty, time per variant).

Every file is written whole (a temporary file renamed into place). Rows leave out the wall time (it
varies run to run), so the same campaign gives the same bytes whichever executor ran it.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

CSV_FIELDS = [
    "run_id",
    "world",
    "robot",
    "variant",
    "seed",
    "route",
    "result",
    "code",
    "time_s",
    "path_length_m",
    "optimal_path_m",
    "optimal_time_s",
    "barn_metric",
    "difficulty",
    "min_clearance_m",
    "collisions",
    "recoveries",
    "speed_mean",
    "speed_max",
    "accel_mean",
    "accel_max",
    "jerk_mean",
    "jerk_max",
    "sim_s",
    "message",
]
VOLATILE = ("wall_s", "key", "log", "cached")  # not part of a row's report: they vary run to run


def report_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k not in VOLATILE} for r in rows]


def write_reports(out: Path, rows: list[dict[str, Any]], summary: dict[str, Any]) -> list[Path]:
    from navlog.replay.io import json_text
    from navlog.replay.io.atomic import write_file

    clean = report_rows(rows)
    files = {
        "campaign.json": (
            json_text.dumps({"summary": summary, "rows": clean}, indent=1, sort_keys=True) + "\n"
        ).encode(),
        "campaign.csv": _csv(clean).encode(),
        "campaign.md": markdown(summary).encode(),
        "campaign.png": plot_png(clean, summary),
    }
    paths = []
    for name, data in files.items():
        write_file(out / name, data)
        paths.append(out / name)
    return paths


def _csv(rows: list[dict[str, Any]]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, CSV_FIELDS, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in CSV_FIELDS})
    return buf.getvalue()


def _ci(stat: dict[str, Any] | None, digits: int = 2) -> str:
    if not stat:
        return "-"
    lo, hi = stat["ci"]
    return f"{stat['mean']:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def markdown(summary: dict[str, Any]) -> str:
    lines = [
        f"# Campaign `{summary['campaign']}`",
        "",
        f"{summary['runs']} rows; intervals are 95 % (success: Wilson; means: bootstrap).",
        "",
        "| variant | runs | success [95 % CI] | collision | timeout | aborted | failed | infeasible | "
        "BARN metric | time s (succeeded) | path m | min clearance m |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, v in summary["variants"].items():
        rate = (
            "-"
            if v["success_rate"] is None
            else f"{v['success_rate']:.3f} [{v['success_ci'][0]:.3f}, {v['success_ci'][1]:.3f}]"
        )
        lines.append(
            f"| {name} | {v['runs']} | {rate} | {v['collision']} | {v['timeout']} | {v['aborted']} | {v['failed']} | "
            f"{v['infeasible']} | {_ci(v['barn_metric'], 3)} | {_ci(v['time_s'])} | {_ci(v['path_length_m'])} | "
            f"{_ci(v['min_clearance_m'])} |"
        )
    if summary["comparisons"]:
        lines += [
            "",
            f"## Against `{summary['baseline']}` (paired, level {summary['alpha']})",
            "",
            "| variant | pairs | successes lost / gained (McNemar p) | time median diff s (Wilcoxon p) | "
            "path median diff m (Wilcoxon p) | verdict |",
            "|---|---|---|---|---|---|",
        ]
        for name, c in summary["comparisons"].items():
            s, t, p = c["success"], c["time_s"], c["path_length_m"]
            lines.append(
                f"| {name} | {c['pairs']} | {s['lost']} / {s['gained']} ({s['p_value']:.3g}) | "
                f"{t['median_difference']:+.2f} ({t['p_value']:.3g}) | {p['median_difference']:+.2f} "
                f"({p['p_value']:.3g}) | **{c['verdict']}** |"
            )
    return "\n".join(lines) + "\n"


def plot_png(rows: list[dict[str, Any]], summary: dict[str, Any]) -> bytes:
    """Success rate by difficulty (quartile bins) and the time of succeeded runs, per variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    matplotlib.rcParams["svg.hashsalt"] = "navlog"
    variants = list(summary["variants"])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), dpi=100)
    runs = [r for r in rows if r["result"] != "infeasible"]
    d = np.array([r["difficulty"] for r in runs], dtype=float)
    edges = np.unique(np.quantile(d, [0, 0.25, 0.5, 0.75, 1.0])) if len(d) else np.array([0.0, 1.0])
    if len(edges) < 2:
        edges = np.array([edges[0] - 0.05, edges[0] + 0.05])
    centres = (edges[:-1] + edges[1:]) / 2
    width = (edges[1:] - edges[:-1]) / (len(variants) + 1)
    for i, v in enumerate(variants):
        rs = [r for r in runs if r["variant"] == v]
        dv = np.array([r["difficulty"] for r in rs], dtype=float)
        ok = np.array([r["result"] == "succeeded" for r in rs])
        idx = np.clip(np.searchsorted(edges, dv, side="right") - 1, 0, len(centres) - 1)
        rate = [ok[idx == b].mean() if (idx == b).any() else np.nan for b in range(len(centres))]
        ax1.bar(edges[:-1] + width * (i + 0.5), rate, width, align="edge", label=v)
        times = [r["time_s"] for r in rs if r["result"] == "succeeded"]
        if times:
            ax2.boxplot([times], positions=[i], widths=0.5)
    ax1.set_xlabel("difficulty (mean robot radius / clearance along the optimal path)")
    ax1.set_ylabel("success rate")
    ax1.set_ylim(0, 1.05)
    ax1.legend(fontsize=8)
    ax1.set_title("success by difficulty")
    ax2.set_xticks(range(len(variants)), variants)
    ax2.set_ylabel("time to goal (s), succeeded runs")
    ax2.set_title("time per variant")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()
