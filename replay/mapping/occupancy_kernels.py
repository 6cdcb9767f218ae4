"""The occupancy grid's ray update, compiled: the cells a scan's beams cross and end in, and their log-odds.

``scan_update`` works beam by beam in float32 arithmetic: sample j of a beam lies at
``g0 + direction * t[j]`` (cells; each product and sum rounded to float32, the cell by truncation),
samples beyond the beam's free part (``t > last``, the sensor's own sample excepted) are not used;
each crossed cell is updated once with the miss log-odds (clamped below), each end cell once with the
hit log-odds (clamped above), an end cell never counting as crossed, and all of them marked seen.

``compiled_scan_update()`` is the one path the grid takes: ``scan_update`` compiled by numba, cached
on disk (``navlog.replay.compiled``). The plain-Python function is the same computation, slowly; the
tests hold it, and a NumPy formulation of it, as reference oracles.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import cast

import numpy as np

from navlog.replay.compiled import compile_together


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
def compiled_scan_update() -> Callable[..., None]:
    """``scan_update`` compiled by numba (cached on disk; compiled once per process)."""
    compiled = compile_together(globals(), (scan_update,))
    assert compiled is not None, "numba is a dependency of navlog"
    return cast(Callable[..., None], compiled["scan_update"])
