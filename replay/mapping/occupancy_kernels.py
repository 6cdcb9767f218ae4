"""The occupancy grid's ray update, compiled: the cells a scan's beams cross and end in, and their log-odds.

``scan_update`` does beam by beam what ``OccupancyGrid2D.insert_scan`` does with (beams x samples)
NumPy arrays, in the same float32 arithmetic: sample j of a beam lies at ``g0 + direction * t[j]``
(cells; each product and sum rounded to float32, the cell by truncation), samples beyond the beam's
free part (``t > last``, the sensor's own sample excepted) are not used; each crossed cell is updated
once with the miss log-odds (clamped below), each end cell once with the hit log-odds (clamped above),
an end cell never counting as crossed, and all of them marked seen.

Plain Python runs the same function (slowly); ``kernels()`` compiles it with numba, cached on disk
(``cache=True``; where no cache directory is writable it compiles in every process), or returns None
without numba, and the grid keeps its NumPy path.

``scan_kernel()`` is what the grid asks for each scan. Loading numba and the cached kernel costs a
process about 0.4-0.6 s, and the kernel saves about 0.3 ms per 720-beam scan against the NumPy path
(2-core machine, the mapping tour's scans: 0.75 against 1.05 ms per ``insert_scan``, the NumPy path
taking the beams in groups of similar length), so it pays for itself only after some 1500 scans: a
2D replay of the 138 s mapping tour inserts 356. The grid therefore takes the NumPy path for the
first ``NUMPY_SCANS`` scans of a process and the compiled kernel after them (at most twice the
better choice's time, whatever the length); both give the same bits.

A process whose scans run beside the replay (the grid's child process, ``grid_process``) calls
``numpy_only()``: there the kernel's time is hidden behind the replay's while its memory is not
(loading numba and LLVM took the child from 38 to 166 MiB resident, 2-core machine). On a 10-minute
patrol log's full mapping replay the NumPy path was no slower as a whole (46.3 and 49.0 s against
47.9 and 50.0 s with the kernel, the same output bytes).
"""

from __future__ import annotations

import functools
import itertools
import sys
from collections.abc import Callable

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
def kernels() -> Callable[..., None] | None:
    """``scan_update`` compiled by numba (cached on disk), or None where numba is missing."""
    compiled = compile_together(globals(), (scan_update,))
    return None if compiled is None else compiled["scan_update"]


NUMPY_SCANS = 500  # scans per process on the NumPy path before the compiled kernel is loaded (see above)
_scans = itertools.count()  # scans asked for in this process (``next`` is atomic under the GIL)


def scan_kernel() -> Callable[..., None] | None:
    """The kernel for this scan: None (the NumPy path) for the first ``NUMPY_SCANS`` scans of the
    process, then ``kernels()`` (None without numba)."""
    if next(_scans) < NUMPY_SCANS:
        return None
    return kernels()


def numpy_only() -> None:
    """Every later scan of this process takes the NumPy path: the kernel is never loaded (see above)."""
    global NUMPY_SCANS
    NUMPY_SCANS = sys.maxsize
