"""Replay output files compared by kind: map_server maps, PCD maps, TUM trajectories, plans.json,
metrics.json. Each function reads two files (errors name the file) and returns its checks."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from navlog.analysis.diff.grids import compare_grids
from navlog.analysis.diff.metric_values import compare_metric_values
from navlog.analysis.diff.paths import PlanPair, compare_plan_streams, plan_pair
from navlog.analysis.diff.points import compare_points
from navlog.analysis.diff.result import Check
from navlog.analysis.diff.tolerances import DiffTolerances
from navlog.analysis.diff.trajectories import compare_trajectories
from navlog.analysis.metrics.trajectory import Trajectory
from navlog.errors import NavlogError

__all__ = [
    "compare_files",
    "compare_map_files",
    "compare_metrics_files",
    "compare_pcd_files",
    "compare_plans_files",
    "compare_tum_files",
    "file_kind",
]


def read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise NavlogError(f"{path}: cannot read: {exc.strerror}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise NavlogError(f"{path}: not valid JSON: {exc}") from None


def compare_map_files(name: str, a: Path, b: Path, tol: DiffTolerances) -> list[Check]:
    from navlog.replay.io.map_server import load_map

    return [compare_grids(name, load_map(a), load_map(b), tol.grid)]


def compare_pcd_files(name: str, a: Path, b: Path, tol: DiffTolerances) -> list[Check]:
    from navlog.replay.io.pcd import read_pcd

    for p in (a, b):
        if not p.is_file():
            raise NavlogError(f"{p}: no such PCD file")
    return [compare_points(name, read_pcd(a), read_pcd(b), tol.points)]


def compare_tum_files(name: str, a: Path, b: Path, tol: DiffTolerances) -> list[Check]:
    return [compare_trajectories(name, Trajectory.from_tum(a), Trajectory.from_tum(b), tol.trajectory)]


def _plans_by_time(path: Path) -> dict[int, dict[str, Any] | None]:
    """time_ns -> plan row (None for a failure) of a plans.json."""
    data = read_json(path)
    if not (isinstance(data, dict) and isinstance(data.get("plans"), list)):
        raise NavlogError(f"{path}: not a plans.json (expected an object with a 'plans' list)")
    out: dict[int, dict[str, Any] | None] = {}
    try:
        for row in data["plans"]:
            out[int(row["time_ns"])] = row
        for row in data.get("failures", []):
            out.setdefault(int(row["time_ns"]), None)
    except (KeyError, TypeError, ValueError) as exc:
        raise NavlogError(f"{path}: malformed plan entry ({exc})") from None
    return out


def compare_plans_files(name: str, a: Path, b: Path, tol: DiffTolerances) -> list[Check]:
    """Plans paired by their time; a plan in A that fails in B (or the reverse) changes success. The
    length, the cost and the goal used (the endpoint) are compared; plans.json holds no poses, so the
    Hausdorff distance comes from the /plan topic of replay.mcap."""
    pa, pb = _plans_by_time(a), _plans_by_time(b)
    pairs: list[PlanPair] = []
    for t in sorted(pa.keys() & pb.keys()):
        ra, rb = pa[t], pb[t]
        pairs.append(
            plan_pair(
                [],
                [],
                length_a=None if ra is None else float(ra["length_m"]),
                length_b=None if rb is None else float(rb["length_m"]),
                cost_a=None if ra is None else float(ra["cost"]),
                cost_b=None if rb is None else float(rb["cost"]),
                goal_a=None if ra is None else ra["goal"],
                goal_b=None if rb is None else rb["goal"],
            )
        )
    check = compare_plan_streams(name, pairs, len(pa), len(pb), tol.path)
    unpaired = len(pa.keys() ^ pb.keys())
    if unpaired:
        values = {**check.values, "unpaired_times": unpaired}
        detail = check.detail + f"; {unpaired} plan times on one side only"
        check = replace(check, values=values, detail=detail)
    return [check]


def compare_metrics_files(name: str, a: Path, b: Path, tol: DiffTolerances) -> list[Check]:
    da, db = read_json(a), read_json(b)
    for p, d in ((a, da), (b, db)):
        if not isinstance(d, dict):
            raise NavlogError(f"{p}: not a metrics file (expected a JSON object)")
    return compare_metric_values(name, da, db, tol.metric)


COMPARE_BY_KIND = {
    "map": compare_map_files,
    "pcd": compare_pcd_files,
    "tum": compare_tum_files,
    "plans": compare_plans_files,
    "metrics": compare_metrics_files,
}


def file_kind(path: Path) -> str | None:
    """Which comparator reads a file, by its name: map (map_server .yaml), pcd, tum, plans, metrics."""
    suffix = path.suffix.lower()
    if suffix == ".yaml":
        return "map"
    if suffix == ".pcd":
        return "pcd"
    if suffix == ".tum":
        return "tum"
    if path.name == "plans.json":
        return "plans"
    if suffix == ".json":
        return "metrics"
    return None


def compare_files(name: str, a: Path, b: Path, tol: DiffTolerances) -> list[Check] | None:
    """The checks of two files of a kind ``file_kind`` knows; None for other files."""
    kind = file_kind(a)
    return None if kind is None else COMPARE_BY_KIND[kind](name, a, b, tol)
