"""A campaign's reports: ``campaign.json`` (summary and rows), ``campaign.csv`` (one row per run),
``campaign.md`` (the summary as tables), ``campaign.png`` (success by difficulty, time per variant),
``campaign_failures.png`` (the contact sheet: a top-down view of each run that did not succeed) and
``campaign_timing.csv`` / ``campaign_timing.md`` (the machine's figures: wall time per run and the
controller's cycle time, mean and 95th percentile in ms).

Every file is written whole (a temporary file renamed into place). The deterministic reports leave
out the machine's figures (``MACHINE``: wall times vary run to run and machine to machine), so the
same campaign gives the same ``campaign.json``/``.csv``/``.md`` bytes whichever executor ran it.
"""

from __future__ import annotations

import csv
import io
import textwrap
from pathlib import Path
from typing import Any

from navlog.errors import ConfigError

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
MACHINE = ("wall_s", "cycle_ms_mean", "cycle_ms_p95")  # wall-clock figures: campaign_timing.*, never the rows
VOLATILE = (*MACHINE, "key", "log", "cached", "track")  # not part of a row's report (the track: runs/RUN.json)
TIMING_FIELDS = ["run_id", "variant", "result", "cycles", "cycle_ms_mean", "cycle_ms_p95", "wall_s"]
SHEET_MAX = 24  # panels on the contact sheet (the first by run id)


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
        "campaign_failures.png": contact_sheet_png(rows, summary, out),
        "campaign_timing.csv": _csv([r for r in rows if r["result"] != "infeasible"], TIMING_FIELDS).encode(),
        "campaign_timing.md": timing_markdown(rows, summary).encode(),
    }
    paths = []
    for name, data in files.items():
        write_file(out / name, data)
        paths.append(out / name)
    return paths


def _csv(rows: list[dict[str, Any]], fields: list[str] = CSV_FIELDS) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fields, extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in fields})
    return buf.getvalue()


def timing_summary(rows: list[dict[str, Any]], variants: list[str]) -> dict[str, dict[str, Any]]:
    """Per variant: runs timed, cycles, the mean of the runs' mean cycle times and of their 95th
    percentiles, the largest 95th percentile (ms), and the mean wall time of a run (s)."""
    import numpy as np

    out: dict[str, dict[str, Any]] = {}
    for v in variants:
        timed = [r for r in rows if r["variant"] == v and r.get("cycle_ms_mean") is not None]
        if not timed:
            continue
        means = np.array([r["cycle_ms_mean"] for r in timed], dtype=float)
        p95 = np.array([r["cycle_ms_p95"] for r in timed], dtype=float)
        out[v] = {
            "runs": len(timed),
            "cycles": int(sum(r.get("cycles", 0) for r in timed)),
            "cycle_ms_mean": round(float(means.mean()), 3),
            "cycle_ms_p95": round(float(p95.mean()), 3),
            "cycle_ms_p95_max": round(float(p95.max()), 3),
            "wall_s": round(float(np.mean([r.get("wall_s", 0.0) for r in timed])), 2),
        }
    return out


def timing_markdown(rows: list[dict[str, Any]], summary: dict[str, Any]) -> str:
    """The machine's figures per variant (``timing_summary``) as a table, with this machine's load."""
    import os

    load = ", ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "-"
    lines = [
        f"# Campaign `{summary['campaign']}`: controller cycle time (wall clock, this machine)",
        "",
        "Each run times every controller-server cycle (goal and progress checks and the controller's "
        "computeVelocityCommands) in wall-clock time: figures of the machine and its load, not of the "
        f"stack alone, so they are kept out of campaign.json. Load average when written: {load}.",
        "",
        "| variant | runs | cycles | cycle ms mean | cycle ms p95 (mean of runs) | p95 max | wall s per run |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, t in timing_summary(rows, list(summary["variants"])).items():
        lines.append(
            f"| {name} | {t['runs']} | {t['cycles']} | {t['cycle_ms_mean']:.2f} | {t['cycle_ms_p95']:.2f} | "
            f"{t['cycle_ms_p95_max']:.2f} | {t['wall_s']:.1f} |"
        )
    return "\n".join(lines) + "\n"


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
    bins = len(edges) - 1
    width = 0.8 / max(1, len(variants))
    counts = np.zeros(bins, dtype=int)
    labels = []
    for i, v in enumerate(variants):
        rs = [r for r in runs if r["variant"] == v]
        dv = np.array([r["difficulty"] for r in rs], dtype=float)
        ok = np.array([r["result"] == "succeeded" for r in rs])
        idx = np.clip(np.searchsorted(edges, dv, side="right") - 1, 0, bins - 1)
        counts = np.maximum(counts, np.bincount(idx, minlength=bins))
        rate = [ok[idx == b].mean() if (idx == b).any() else np.nan for b in range(bins)]
        ax1.bar(np.arange(bins) - 0.4 + width * (i + 0.5), rate, width, label=v)
        times = [r["time_s"] for r in rs if r["result"] == "succeeded"]
        labels.append(f"{v}\n({len(times)} succeeded)")
        if times:
            ax2.boxplot([times], positions=[i], widths=0.5)
    ax1.set_xticks(range(bins), [f"{edges[b]:.2f}-{edges[b + 1]:.2f}\n{counts[b]} runs" for b in range(bins)])
    ax1.tick_params(axis="x", labelsize=8)
    ax1.set_xlabel("difficulty quartile (mean robot radius / clearance along the optimal path)")
    ax1.set_ylabel("success rate")
    ax1.set_ylim(0, 1.05)
    ax1.legend(fontsize=8)
    ax1.set_title("success by difficulty")
    ax2.set_xticks(range(len(variants)), labels)
    ax2.set_ylabel("time to goal (s), succeeded runs")
    ax2.set_title("time per variant")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def contact_sheet_png(rows: list[dict[str, Any]], summary: dict[str, Any], out: Path | None = None) -> bytes:
    """A grid of top-down views of the runs that did not succeed (the first ``SHEET_MAX`` by run id): the
    world's obstacles, the optimal path (NavFn on the true grid, as planned), the trajectory driven
    (ground truth every 0.25 s), start and goal; the title names world, seed, route, variant and result.
    ``out``: the campaign's folder, where the summary's relative world paths (generated worlds) start."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bad = [r for r in rows if r["result"] not in ("succeeded", "infeasible")]
    shown = bad[:SHEET_MAX]
    cols = min(4, max(1, len(shown)))
    nrows = max(1, -(-len(shown) // cols))
    fig, axes = plt.subplots(nrows, cols, figsize=(3.4 * cols, 3.6 * nrows), dpi=90, squeeze=False)
    grids: dict[str, Any] = {}
    for ax, row in zip(axes.flat, shown):
        _draw_run(ax, row, summary["worlds"].get(row["world"], {}), grids, out)
    for ax in axes.flat[len(shown) :]:
        ax.axis("off")
    if not shown:
        axes[0, 0].text(0.5, 0.5, "every run succeeded", ha="center", va="center")
    more = f" (the first {SHEET_MAX})" if len(bad) > SHEET_MAX else ""
    title = textwrap.wrap(f"campaign {summary['campaign']}: {len(bad)} run(s) that did not succeed{more}", 32 * cols)
    fig.suptitle("\n".join(title), fontsize=11)
    fig.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - 0.2 * (len(title) + 1) / fig.get_figheight()))  # room for the title
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def _draw_run(ax: Any, row: dict[str, Any], world: dict[str, Any], grids: dict[str, Any], out: Path | None) -> None:
    import numpy as np

    from navlog.recorder.description import load_robot
    from navlog.recorder.routes import optimal_path, true_grid
    from navlog.recorder.world import load_world

    path = world.get("path")
    if path and out is not None and not Path(path).is_absolute() and (out / path).is_file():
        path = str(out / path)  # a generated world, by its place in OUT; others by their name or path as given
    if path and path not in grids:
        try:
            grids[path] = true_grid(load_world(path))
        except ConfigError:  # a world moved or renamed since: the run is drawn without it, the reports still written
            grids[path] = None
    grid = grids.get(path) if path else None
    if grid is not None:
        ny, nx = grid.occupied.shape
        x0, y0 = grid.origin
        extent = (x0, x0 + nx * grid.resolution, y0, y0 + ny * grid.resolution)
        ax.imshow(grid.occupied, origin="lower", extent=extent, cmap="Greys", vmin=0, vmax=1.4, interpolation="none")
        best = optimal_path(grid, tuple(row["start"]), tuple(row["goal"]), load_robot(row["robot"]).radius)
        if best is not None:
            ax.plot(best.poses[:, 0], best.poses[:, 1], "--", color="tab:green", lw=1.2, label="optimal")
    track = np.asarray(row.get("track") or np.zeros((0, 2)), dtype=float).reshape(-1, 2)
    if len(track):
        ax.plot(track[:, 0], track[:, 1], "-", color="tab:red", lw=1.4, label="driven")
        ax.plot(track[-1, 0], track[-1, 1], "x", color="tab:red", ms=7)
    ax.plot(*row["start"][:2], "o", color="tab:blue", ms=6, label="start")
    ax.plot(*row["goal"][:2], "*", color="gold", mec="k", ms=11, label="goal")
    t = row.get("time_s")
    when = f" at {t:g} s" if t is not None else ""
    ax.set_title(
        f"{row['world']} seed {row['seed']} route {row['route']}\n{row['variant']}: {row['result']}{when}", fontsize=8
    )
    ax.set_aspect("equal")
    ax.tick_params(labelsize=6)
    ax.legend(fontsize=5, loc="lower right")
