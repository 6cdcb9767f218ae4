"""Occupancy grids compared: cells that changed class, IoU and Hausdorff distance of the occupied cells.

Both grids are sampled on one canvas: A's lattice (resolution and cell phase) extended to cover both
maps, each canvas cell taking the value of the cell of each map that holds its centre (unknown
outside a map). Grids of equal resolution and origin are thus compared cell for cell; grids of
different resolutions or origins are compared at A's resolution. Cells are classified with
map_server's thresholds (occupied > 0.65, free < 0.196, else unknown) by
``navlog.analysis.metrics.maps.classify``; IoU and the Hausdorff distance (metres) of the occupied
sets come from ``navlog.analysis.metrics.maps.grid_metrics`` on that canvas.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from navlog.analysis.diff.result import Check, Verdict
from navlog.analysis.diff.tolerances import GridTolerance, as_dict, within
from navlog.analysis.metrics.maps import classify, grid_metrics
from navlog.replay.occupancy_map import UNKNOWN, OccupancyMap

__all__ = ["GridDiff", "common_canvas", "compare_grids", "grid_diff", "judge_grid"]


@dataclass(frozen=True)
class GridDiff:
    cells: int  # canvas cells
    changed_cells: int  # cells whose class (free / occupied / unknown) differs
    changed_share: float
    iou: float  # of the occupied cells; nan when neither map has one
    hausdorff_m: float  # between the occupied sets; inf when only one map has occupied cells
    occupied_a: int
    occupied_b: int
    resolution_a: float
    resolution_b: float

    def values(self) -> dict[str, Any]:
        return {
            "cells": self.cells,
            "changed_cells": self.changed_cells,
            "changed_share": self.changed_share,
            "iou": self.iou,
            "hausdorff_m": self.hausdorff_m,
            "occupied_a": self.occupied_a,
            "occupied_b": self.occupied_b,
            "resolution_a": self.resolution_a,
            "resolution_b": self.resolution_b,
        }


def _sample(grid: OccupancyMap, canvas_origin: tuple[float, float], res: float, shape: tuple[int, int]) -> np.ndarray:
    """``grid``'s values at the centres of a canvas of ``shape`` cells of ``res`` from ``canvas_origin``."""
    xs = canvas_origin[0] + (np.arange(shape[1]) + 0.5) * res
    ys = canvas_origin[1] + (np.arange(shape[0]) + 0.5) * res
    mx, _ = grid.world_to_cell(xs, np.zeros_like(xs))
    _, my = grid.world_to_cell(np.zeros_like(ys), ys)
    cols_ok = (mx >= 0) & (mx < grid.width)
    rows_ok = (my >= 0) & (my < grid.height)
    out = np.full(shape, UNKNOWN, dtype=np.int8)
    out[np.ix_(rows_ok, cols_ok)] = grid.data[np.ix_(my[rows_ok], mx[cols_ok])]
    return out


def _canvas(a: OccupancyMap, b: OccupancyMap) -> tuple[tuple[float, float], tuple[int, int]]:
    """Origin and shape of A's lattice covering both grids."""
    res = a.resolution
    lo_x = min(a.origin[0], b.origin[0])
    lo_y = min(a.origin[1], b.origin[1])
    hi_x = max(a.origin[0] + a.width * res, b.origin[0] + b.width * b.resolution)
    hi_y = max(a.origin[1] + a.height * res, b.origin[1] + b.height * b.resolution)
    c0 = math.floor((lo_x - a.origin[0]) / res + 1e-9)
    r0 = math.floor((lo_y - a.origin[1]) / res + 1e-9)
    c1 = math.ceil((hi_x - a.origin[0]) / res - 1e-9)
    r1 = math.ceil((hi_y - a.origin[1]) / res - 1e-9)
    return (a.origin[0] + c0 * res, a.origin[1] + r0 * res), (r1 - r0, c1 - c0)


def common_canvas(a: OccupancyMap, b: OccupancyMap) -> tuple[OccupancyMap, OccupancyMap]:
    """A and B sampled on A's lattice extended over both (same origin, resolution and shape)."""
    origin, shape = _canvas(a, b)
    res = a.resolution
    at = (origin[0], origin[1], 0.0)
    return (
        OccupancyMap(_sample(a, origin, res, shape), res, at, a.frame_id),
        OccupancyMap(_sample(b, origin, res, shape), res, at, a.frame_id),
    )


def grid_diff(a: OccupancyMap, b: OccupancyMap) -> GridDiff:
    """The figures of B against A (see the module docstring)."""
    ca, cb = common_canvas(a, b)
    va, vb = ca.data, cb.data
    shape = va.shape
    occ_a, free_a = classify(va)
    occ_b, free_b = classify(vb)
    class_a = np.where(occ_a, 2, np.where(free_a, 1, 0))
    class_b = np.where(occ_b, 2, np.where(free_b, 1, 0))
    changed = int(np.count_nonzero(class_a != class_b))
    n_a, n_b = int(occ_a.sum()), int(occ_b.sum())
    if n_a and n_b:
        gm = grid_metrics(cb, ca, tau=0.0)
        iou, hausdorff = gm.iou, gm.hausdorff_m
    else:
        iou = float("nan") if n_a == n_b == 0 else 0.0
        hausdorff = 0.0 if n_a == n_b == 0 else float("inf")
    cells = shape[0] * shape[1]
    return GridDiff(
        cells=cells,
        changed_cells=changed,
        changed_share=changed / cells if cells else 0.0,
        iou=float(iou),
        hausdorff_m=float(hausdorff),
        occupied_a=n_a,
        occupied_b=n_b,
        resolution_a=a.resolution,
        resolution_b=b.resolution,
    )


def judge_grid(d: GridDiff, tol: GridTolerance) -> Verdict:
    """WITHIN when the changed share and the Hausdorff distance are within ``tol``, else CHANGED."""
    ok = within(d.changed_share, tol.changed_share) and within(d.hausdorff_m, tol.hausdorff_m)
    return Verdict.WITHIN if ok else Verdict.CHANGED


def compare_grids(name: str, a: OccupancyMap, b: OccupancyMap, tol: GridTolerance) -> Check:
    """One check of two grids: EQUAL when every cell keeps its class at the same resolution, WITHIN
    when the changed share and the Hausdorff distance are within ``tol``, else CHANGED."""
    d = grid_diff(a, b)
    detail = f"{d.changed_cells}/{d.cells} cells changed class ({100 * d.changed_share:.3f} %)"
    if d.resolution_a != d.resolution_b:
        detail += f"; resolution {d.resolution_a:g} -> {d.resolution_b:g} m (compared at {d.resolution_a:g} m)"
    same = a.resolution == b.resolution and a.origin[:2] == b.origin[:2] and np.array_equal(a.data, b.data)
    return Check(name, "grid", Verdict.EQUAL if same else judge_grid(d, tol), d.values(), as_dict(tol), detail)
