"""A and B overlaid in one Rerun file (``navlog diff --rrd``), for looking at what moved.

Drawn, all static, in the ``map`` frame: the 2D maps of A and B as occupied cells (``a/map`` blue,
``b/map`` orange) on their common canvas and the cells whose class changed (``diff/map_changed``,
red); the point maps (``a/map_pcd``, ``b/map_pcd``); the trajectories (``a/trajectory``,
``b/trajectory``); the report as text (``diff/report``). Replay output folders and single map/PCD/TUM
files are drawn; logs are not (``navlog view`` draws a log).
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

import numpy as np

from navlog.analysis.diff.core import input_kind
from navlog.analysis.diff.grids import common_canvas
from navlog.analysis.diff.report import format_report
from navlog.analysis.diff.result import DiffReport
from navlog.analysis.metrics.maps import classify
from navlog.errors import NavlogError
from navlog.replay.occupancy_map import OccupancyMap

__all__ = ["save_overlay"]

COLORS = {"a": (60, 120, 255), "b": (255, 150, 40), "changed": (230, 30, 30)}


def _files(path: Path, suffix: str) -> Path | None:
    if path.is_file():
        return path if path.suffix == suffix else None
    found = sorted(path.glob(f"*{suffix}"))
    return found[0] if found else None


def _cells(grid: OccupancyMap, mask: np.ndarray) -> np.ndarray:
    rows, cols = np.nonzero(mask)
    x, y = grid.cell_to_world(cols, rows)
    return np.stack([x, y, np.zeros_like(x)], axis=1).reshape(-1, 3)


def _draw_maps(rec: Any, a: Path, b: Path) -> None:
    import rerun as rr

    from navlog.replay.io.map_server import load_map

    ca, cb = common_canvas(load_map(a), load_map(b))
    occ_a, free_a = classify(ca.data)
    occ_b, free_b = classify(cb.data)
    changed = (occ_a != occ_b) | (free_a != free_b)
    radius = ca.resolution / 2
    for name, pts, color in (
        ("a/map", _cells(ca, occ_a), COLORS["a"]),
        ("b/map", _cells(cb, occ_b), COLORS["b"]),
        ("diff/map_changed", _cells(ca, changed), COLORS["changed"]),
    ):
        rec.log(name, rr.Points3D(pts, colors=[color], radii=radius), static=True)


def _draw_pcds(rec: Any, a: Path, b: Path) -> None:
    import rerun as rr

    from navlog.replay.io.pcd import read_pcd

    for side, path in (("a", a), ("b", b)):
        rec.log(f"{side}/map_pcd", rr.Points3D(read_pcd(path), colors=[COLORS[side]], radii=0.01), static=True)


def _draw_tums(rec: Any, a: Path, b: Path) -> None:
    import rerun as rr

    from navlog.replay.io.tum import read_tum

    for side, path in (("a", a), ("b", b)):
        positions = read_tum(path)[1]
        rec.log(f"{side}/trajectory", rr.LineStrips3D([positions], colors=[COLORS[side]]), static=True)


def save_overlay(report: DiffReport, out: Path | str) -> Path:
    """Write the overlay of the report's A and B to ``out`` (.rrd); the file appears when complete."""
    import rerun as rr

    out = Path(out)
    if out.suffix != ".rrd":
        raise NavlogError(f"{out}: the Rerun file must end in .rrd")
    a, b = Path(report.a), Path(report.b)
    if input_kind(a) == "log":
        raise NavlogError(f"{a}: --rrd draws replay output folders and map/PCD/TUM files; draw a log with navlog view")
    tmp = out.with_name(f".{out.name}.{os.getpid()}.part")
    out.parent.mkdir(parents=True, exist_ok=True)
    key = hashlib.sha256(f"{report.a}\n{report.b}".encode()).hexdigest()[:16]
    rec = rr.RecordingStream("navlog_diff", recording_id=f"navlog-diff-{key}")
    try:
        rec.save(str(tmp))
        rec.log("diff/report", rr.TextDocument(format_report(report)), static=True)
        for suffix, draw in ((".yaml", _draw_maps), (".pcd", _draw_pcds), (".tum", _draw_tums)):
            fa, fb = _files(a, suffix), _files(b, suffix)
            if fa is not None and fb is not None:
                draw(rec, fa, fb)
        rec.flush()
        rec.disconnect()
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return out
