"""A per-beam formulation of the occupancy grid's ray update: a reference oracle for the grid's NumPy path.

``scan_update`` walks beam by beam in float32 arithmetic what ``OccupancyGrid2D._update`` does with
(beams x samples) arrays; ``reference_update`` runs it (compiled by numba, for speed) in place of the
grid's own update, so a test can compare the two grids bit for bit; ``benchmarks/bench_occupancy.py`` times the
grid's update against it.
"""

from __future__ import annotations

import functools

import numba
import numpy as np

from navlog.replay.mapping.occupancy import OccupancyGrid2D


def scan_update(
    logodds: np.ndarray,
    seen: np.ndarray,
    mask: np.ndarray,
    nx: int,
    g0: np.ndarray,
    directions: np.ndarray,
    t: np.ndarray,
    last: np.ndarray,
    end_cells: np.ndarray,
    l_miss: np.float32,
    l_min: np.float32,
    l_hit: np.float32,
    l_max: np.float32,
) -> None:
    """Update the flat float32 ``logodds`` and bool ``seen`` from one scan.

    ``mask``: int8 per cell, all zero on entry and on return (a work array kept between scans).
    ``g0``: the sensor in cells (float32, 2); ``directions``: per beam (float32, n x 2); ``t``: the
    sample positions along a beam (float32, increasing, from 0); ``last``: per beam, the last free
    sample position (float32); ``end_cells``: flat indices of the end cells of beams with a return.
    """
    ncell = len(logodds)
    touched = np.empty(min(ncell, len(directions) * len(t) + len(end_cells)), dtype=np.int64)
    n = 0
    bad = False
    for b in range(len(directions)):
        dx, dy = directions[b, 0], directions[b, 1]
        for j in range(len(t)):
            if j > 0 and t[j] > last[b]:  # t increases: every later sample is past too
                break
            x = g0[0] + dx * t[j]
            y = g0[1] + dy * t[j]
            cell = np.int64(y) * nx + np.int64(x)
            if cell < 0 or cell >= ncell:
                bad = True
                break
            if mask[cell] == 0:
                mask[cell] = 1
                touched[n] = cell
                n += 1
        if bad:
            break
    if not bad:
        for cell in end_cells:
            if cell < 0 or cell >= ncell:
                bad = True
                break
            if mask[cell] == 0:
                touched[n] = cell
                n += 1
            mask[cell] = 2
    if bad:
        for k in range(n):
            mask[touched[k]] = 0
        raise IndexError("a beam leaves the occupancy grid")
    for k in range(n):
        cell = touched[k]
        if mask[cell] == 1:
            logodds[cell] = max(logodds[cell] + l_miss, l_min)
        else:
            logodds[cell] = min(logodds[cell] + l_hit, l_max)
        seen[cell] = True
        mask[cell] = 0


@functools.cache
def compiled_scan_update():
    """``scan_update`` compiled by numba (the oracle is slow in plain Python on 720-beam scans)."""
    return numba.njit(cache=False)(scan_update)


def per_beam_update(
    grid: OccupancyGrid2D,
    mask: np.ndarray,
    t: np.ndarray,
    last: np.ndarray,
    d2c: np.ndarray,
    g0: np.ndarray,
    end_cells: np.ndarray,
) -> None:
    """The grid's update computed by ``scan_update`` (compiled) with the int8 work array ``mask`` (one a cell, all
    zero; zero again after)."""
    f32 = np.float32
    compiled_scan_update()(
        grid.logodds.reshape(-1),
        grid.seen.reshape(-1),
        mask,
        grid.logodds.shape[1],
        g0,
        d2c,
        t,
        last,
        end_cells,
        *(f32(grid.l_miss), f32(grid.l_min), f32(grid.l_hit), f32(grid.l_max)),
    )


def reference_update(
    grid: OccupancyGrid2D,
    t: np.ndarray,
    last: np.ndarray,
    d2c: np.ndarray,
    g0: np.ndarray,
    end_cells: np.ndarray,
    box: tuple[slice, slice],
) -> None:
    """``OccupancyGrid2D._update``'s contract, computed by ``scan_update``; it also checks that every cell the
    scan changes lies in ``box``, where the grid's own update looks for them."""
    before = grid.logodds.copy(), grid.seen.copy()
    per_beam_update(grid, np.zeros(grid.logodds.size, dtype=np.int8), t, last, d2c, g0, end_cells)
    changed = (grid.logodds != before[0]) | (grid.seen != before[1])
    changed[box] = False
    assert not changed.any(), f"the scan changed cells outside its box {box}"
