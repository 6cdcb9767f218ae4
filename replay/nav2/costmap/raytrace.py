"""Cells along rays and inside polygons, as Nav2's costmap visits them (``raytraceLine``, ``convexFillCells``).

All in cells: integer start and end cells, lengths in cells. Vectorised over rays.
"""

from __future__ import annotations

import math

import numpy as np

from navlog.replay.geometry import world_to_cell


def ray_steps(x0, y0, x1, y1, max_length: float, min_length: float):
    """Per ray of Nav2's ``raytraceLine`` (x0, y0) -> (x1, y1) (cells; starts may be one cell or one per ray).

    Rays shorter than ``min_length`` are dropped, the others start ``min_length`` cells out and are
    cut at ``max_length`` cells. Returns int64 arrays, one entry per kept ray: start (sx, sy), major
    and minor unit steps (ax, ay, bx, by), the cell count, and the major and minor extents (da, db):
    cell i of a ray is start + i * major + ((da // 2 + i * db) // max(da, 1)) * minor.
    """
    x1 = np.asarray(x1, dtype=np.int64)
    y1 = np.asarray(y1, dtype=np.int64)
    x0 = np.broadcast_to(np.asarray(x0, dtype=np.int64), x1.shape)
    y0 = np.broadcast_to(np.asarray(y0, dtype=np.int64), y1.shape)
    dxf = (x1 - x0).astype(np.float64)
    dyf = (y1 - y0).astype(np.float64)
    dist = np.hypot(dxf, dyf)
    keep = dist >= min_length
    x0, y0, x1, y1, dxf, dyf, dist = x0[keep], y0[keep], x1[keep], y1[keep], dxf[keep], dyf[keep], dist[keep]
    safe = np.where(dist > 0, dist, 1.0)
    sx = np.where(dist > 0, (x0 + dxf / safe * min_length).astype(np.int64), x0)
    sy = np.where(dist > 0, (y0 + dyf / safe * min_length).astype(np.int64), y0)
    dx, dy = x1 - sx, y1 - sy
    adx, ady = np.abs(dx), np.abs(dy)
    scale = np.where(dist > 0, np.minimum(1.0, max_length / safe), 1.0)
    x_major = adx >= ady
    da = np.where(x_major, adx, ady)
    db = np.where(x_major, ady, adx)
    counts = np.minimum((scale * da).astype(np.int64), da) + 1
    sgx, sgy = np.sign(dx), np.sign(dy)
    ax, ay = np.where(x_major, sgx, 0), np.where(x_major, 0, sgy)
    bx, by = sgx - ax, sgy - ay
    return sx, sy, ax, ay, bx, by, counts, da, db


def bresenham_rays(x0, y0, x1, y1, max_length: float, min_length: float):
    """Nav2's ``raytraceLine`` for each ray, as ``ray_steps`` with the cells spelled out.

    Returns per ray: start (sx, sy), major and minor unit steps ((ax, ay), (bx, by)), the cell count,
    and per cell the step index i and the minor offset.
    """
    sx, sy, ax, ay, bx, by, counts, da, db = ray_steps(x0, y0, x1, y1, max_length, min_length)
    i, minor = cell_steps(counts, da, db)
    return sx, sy, (ax, ay), (bx, by), counts, i, minor


def cell_steps(counts: np.ndarray, da: np.ndarray, db: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per cell of the rays, one ray after the other: its step index and its minor offset."""
    total = int(counts.sum())
    first = np.cumsum(counts) - counts
    i = np.arange(total, dtype=np.int64) - first.repeat(counts)
    minor = ((da // 2).repeat(counts) + i * db.repeat(counts)) // np.maximum(da, 1).repeat(counts)
    return i, minor


def bresenham_cells(x0, y0, x1, y1, max_length, min_length):
    """Cells Nav2's ``raytraceLine`` visits for each ray, vectorised over rays.

    x0, y0: start cell (ints, or one per ray); x1, y1: end cells (int arrays); lengths in cells.
    Returns (mx, my).
    """
    sx, sy, (ax, ay), (bx, by), counts, i, minor = bresenham_rays(x0, y0, x1, y1, max_length, min_length)
    mx = sx.repeat(counts) + i * ax.repeat(counts) + minor * bx.repeat(counts)
    my = sy.repeat(counts) + i * ay.repeat(counts) + minor * by.repeat(counts)
    return mx, my


def polygon_cells(poly: np.ndarray, ox: float, oy: float, res: float, nx: int, ny: int):
    """Cells covered by a polygon (centres inside, plus the outline), clipped to the grid."""
    xs, ys = poly[:, 0], poly[:, 1]
    x0 = max(int(math.floor((xs.min() - ox) / res)), 0)
    x1 = min(int(math.floor((xs.max() - ox) / res)), nx - 1)
    y0 = max(int(math.floor((ys.min() - oy) / res)), 0)
    y1 = min(int(math.floor((ys.max() - oy) / res)), ny - 1)
    if x1 < x0 or y1 < y0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    gx, gy = np.meshgrid(np.arange(x0, x1 + 1), np.arange(y0, y1 + 1))
    cx = ox + (gx + 0.5) * res
    cy = oy + (gy + 0.5) * res
    # ray crossing, all edges at once: edge k runs from vertex k to vertex k + 1
    following = np.arange(1, len(poly) + 1) % len(poly)
    ax, ay = xs[:, None, None], ys[:, None, None]
    bx, by = xs[following][:, None, None], ys[following][:, None, None]
    cond = (ay > cy) != (by > cy)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = ax + (cy - ay) * (bx - ax) / (by - ay)
    inside = np.logical_xor.reduce(cond & (cx < xint), axis=0)
    vx = world_to_cell(xs, ox, res)
    vy = world_to_cell(ys, oy, res)
    ex, ey = bresenham_cells(vx, vy, vx[following], vy[following], 1e9, 0.0)
    mx = np.concatenate([gx[inside], ex])
    my = np.concatenate([gy[inside], ey])
    ok = (mx >= 0) & (mx < nx) & (my >= 0) & (my < ny)
    return mx[ok], my[ok]
