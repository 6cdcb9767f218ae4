"""The costmap's hot loops, compiled: inflation (exact distances, costs, merge) and clearing along rays.

``inflate_window`` inflates a window of the master grid in one pass over a region around it: the
sources are the region's lethal cells (and unknown ones with ``inflate_around_unknown``); their exact
squared Euclidean distance in cells is computed with Meijster, Roerdink and Hesselink's two-pass
algorithm in integers (a column scan, then the lower envelope of parabolas per row), so it equals an
exact Euclidean distance transform's to the last bit; each cell of
the window takes the cost table's entry for it (the last entry for every distance beyond the table)
and merges it into the master as the layer does (maximum; an unknown cell takes the cost only if it
is inscribed or above, or any cost with ``inflate_unknown``).

``clear_rays`` sets the cells of Nav2's ``raytraceLine`` rays inside the grid (as ``raytrace.ray_steps``
describes them) and returns their count and bounds.

The layers call them compiled: ``kernels()`` compiles them with numba on first use, cached on disk
(``cache=True``, in ``__pycache__`` beside this file or numba's user cache directory; where none is
writable it compiles in every process). Plain Python runs the same functions, slowly (tests on small
grids).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from navlog.replay.compiled import compile_together
from navlog.replay.nav2.costmap.cost_values import FREE_SPACE, INSCRIBED, LETHAL, NO_INFORMATION


def _envelope(g2: np.ndarray, s: np.ndarray, t: np.ndarray, d2: np.ndarray) -> None:
    """d2[u] = min over i of (u - i)^2 + g2[i]: the lower envelope of the row's parabolas (Meijster's second pass).

    ``s`` and ``t`` are work arrays as long as the row: the envelope's columns and where each takes over.
    """
    w = len(g2)
    q = 0
    s[0] = 0
    t[0] = 0
    for u in range(1, w):
        while q >= 0:
            tq, sq = t[q], s[q]
            if (tq - sq) * (tq - sq) + g2[sq] <= (tq - u) * (tq - u) + g2[u]:
                break
            q -= 1
        if q < 0:
            q = 0
            s[0] = u
        else:
            sq = s[q]
            sep = (u * u - sq * sq + g2[u] - g2[sq]) // (2 * (u - sq))
            if sep + 1 < w:
                q += 1
                s[q] = u
                t[q] = sep + 1
    for u in range(w - 1, -1, -1):
        sq = s[q]
        d2[u] = (u - sq) * (u - sq) + g2[sq]
        if u == t[q]:
            q -= 1


def inflate_window(
    region: np.ndarray,
    row0: int,
    row1: int,
    col0: int,
    col1: int,
    table: np.ndarray,
    around_unknown: bool,
    inflate_unknown: bool,
) -> None:
    """Inflate ``region[row0:row1, col0:col1]`` (uint8, in place) from the sources of all of ``region``."""
    h, w = region.shape
    inf = h + w  # beyond every distance inside the region
    g = np.empty((h, w), dtype=np.int32)  # vertical distance to the nearest source in the column
    found = False
    for y in range(h):
        for x in range(w):
            v = region[y, x]
            if v == LETHAL or (around_unknown and v == NO_INFORMATION):
                g[y, x] = 0
                found = True
            elif y == 0:
                g[y, x] = inf
            else:
                g[y, x] = g[y - 1, x] + 1
    if not found:
        return
    for y in range(h - 2, -1, -1):
        for x in range(w):
            if g[y + 1, x] < g[y, x]:
                g[y, x] = g[y + 1, x] + 1
    last = len(table) - 1
    g2 = np.empty(w, dtype=np.int64)  # one row's g squared
    s = np.empty(w, dtype=np.int64)  # the columns whose parabolas form the lower envelope
    t = np.empty(w, dtype=np.int64)  # where each takes over
    d2 = np.empty(w, dtype=np.int64)
    for y in range(row0, row1):
        nearest = np.int64(inf) * inf
        for x in range(w):
            g2[x] = np.int64(g[y, x]) * g[y, x]
            nearest = min(nearest, g2[x])
        if nearest >= last:  # every cell of the row is beyond the table: one cost for the row
            d2[:] = last
        else:
            _envelope(g2, s, t, d2)
        for x in range(col0, col1):
            new = table[min(d2[x], last)]
            old = region[y, x]
            if old == NO_INFORMATION:
                if (new > FREE_SPACE) if inflate_unknown else (new >= INSCRIBED):
                    region[y, x] = new
            elif new > old:
                region[y, x] = new


def clear_rays(
    grid: np.ndarray,
    sx: np.ndarray,
    sy: np.ndarray,
    ax: np.ndarray,
    ay: np.ndarray,
    bx: np.ndarray,
    by: np.ndarray,
    counts: np.ndarray,
    da: np.ndarray,
    db: np.ndarray,
    value: int,
) -> tuple[int, int, int, int, int]:
    """The rays' cells (``raytrace.ray_steps``' arrays) inside ``grid`` (rows y, columns x) set to ``value``.

    Returns how many ray cells lie inside and their bounds (xmin, ymin, xmax, ymax, inclusive; zeros
    when none does).
    """
    h, w = grid.shape
    n = 0
    xmin, ymin, xmax, ymax = w, h, -1, -1
    for k in range(len(counts)):
        half, step, div = da[k] // 2, db[k], max(da[k], 1)
        for i in range(counts[k]):
            minor = (half + i * step) // div
            x = sx[k] + i * ax[k] + minor * bx[k]
            y = sy[k] + i * ay[k] + minor * by[k]
            if 0 <= x < w and 0 <= y < h:
                grid[y, x] = value
                n += 1
                xmin, xmax = min(xmin, x), max(xmax, x)
                ymin, ymax = min(ymin, y), max(ymax, y)
    if n == 0:
        return 0, 0, 0, 0, 0
    return n, xmin, ymin, xmax, ymax


class Kernels(NamedTuple):
    """The compiled functions the costmap layers call."""

    inflate_window: Callable[..., None]
    clear_rays: Callable[..., tuple[int, int, int, int, int]]


@functools.cache
def kernels() -> Kernels:
    """The kernels compiled by numba (on first use; cached on disk)."""
    compiled = compile_together(globals(), (_envelope, inflate_window, clear_rays))
    return Kernels(compiled["inflate_window"], compiled["clear_rays"])
