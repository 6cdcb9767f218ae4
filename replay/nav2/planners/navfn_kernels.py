"""NavFn's two hot loops, in NavFn's own float32 arithmetic: the potential and the gradient path.

``propagate`` grows the potential from a seed cell with NavFn's three priority buffers (current, next,
overflow; 10000 cells each, a push into a full buffer is dropped as NavFn drops it), the threshold
raised by 100 each time the current band empties, and its quadratic two-neighbour update; with A* the
priority adds the distance to the target cell times 50. ``trace_path`` descends that potential from a
cell in 0.5-cell steps along the bilinearly interpolated, normalised gradient, with NavFn's float32
step offsets, its exact oscillation test (the point two steps back) and its jump to the lowest of the
8 neighbours (compared against the integer part of the current potential, as NavFn does).

Every constant carries its type, so the same functions give the same bits run as plain Python (on
NumPy float32 scalars: slow, ``PYTHON``, the planner's ``potential="python"``) and compiled by numba
(``kernels()``, on first use: fast). The compiled code is cached on disk (numba ``cache=True``, in
``__pycache__`` beside this file or numba's user cache directory); where no cache directory is
writable the functions are compiled in every process.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from navlog.replay.compiled import compile_together

POT_HIGH = np.float32(1.0e10)  # an unassigned cell's potential
COST_OBS = 254  # NavFn cost of a blocked cell
COST_NEUTRAL = np.float32(50.0)  # NavFn cost of a free cell
PRIORITY_INCREMENT = np.float32(100.0)  # the threshold step: 2 * COST_NEUTRAL
BUFFER_SIZE = 10000  # cells per priority buffer
INVSQRT2 = 0.707106781  # a double, multiplied by the float cost and stored as a float
PATH_STEP = np.float32(0.5)  # cells per path step
# a queued neighbour's margin, 0.7071 * its cost, as NavFn computes it (double product stored as float)
EDGE_MARGIN = np.array([INVSQRT2 * float(c) for c in range(256)], dtype=np.float32)

# trace_path outcomes
PATH_FOUND = 0
PATH_OUT_OF_CYCLES = 1  # the step limit ran out before the potential fell below 50
PATH_STUCK = 2  # out of the grid, in a cell without potential, or a zero gradient


def propagate(
    cost: np.ndarray, nx: int, ny: int, seed: int, target_x: int, target_y: int, use_astar: bool, cycles: int
) -> np.ndarray:
    """NavFn's potential (float32, flat) grown from ``seed`` (flat index, potential 0).

    ``cost``: NavFn costs (uint8, flat, border 254). It stops after ``cycles`` cycles, when the buffers
    empty, or when the target cell (``target_y * nx + target_x``, ignored outside the grid) has a
    potential. ``target_x`` may be ``nx`` (a goal in the map's last half cell): NavFn's flat index then
    wraps, as NavFn's does.
    """
    ns = nx * ny
    pot = np.full(ns, POT_HIGH, dtype=np.float32)
    pending = np.zeros(ns, dtype=np.bool_)
    buffers = np.empty((3, BUFFER_SIZE), dtype=np.int64)
    counts = np.zeros(3, dtype=np.int64)
    cur, nxt, over = 0, 1, 2
    target = target_y * nx + target_x
    pot[seed] = np.float32(0.0)
    for n in (seed + 1, seed - 1, seed - nx, seed + nx):
        if 0 <= n < ns and not pending[n] and cost[n] < COST_OBS and counts[cur] < BUFFER_SIZE:
            buffers[cur, counts[cur]] = n
            counts[cur] += 1
            pending[n] = True
    threshold = np.float32(COST_OBS)
    if use_astar:
        sx, sy = seed % nx - target_x, seed // nx - target_y
        threshold = np.float32(np.float64(np.sqrt(np.float64(sx * sx + sy * sy))) * 50.0) + threshold
    for _ in range(cycles):
        if counts[cur] == 0 and counts[nxt] == 0:
            break
        for i in range(counts[cur]):
            pending[buffers[cur, i]] = False
        for i in range(counts[cur]):
            n = buffers[cur, i]
            hf = np.float32(cost[n])
            if cost[n] >= COST_OBS:
                continue
            left, right, up, down = pot[n - 1], pot[n + 1], pot[n - nx], pot[n + nx]
            tc = left if left < right else right
            ta = up if up < down else down
            dc = tc - ta
            if dc < np.float32(0.0):
                dc = -dc
                ta = tc
            if dc >= hf:
                p = ta + hf
            else:
                r = np.float64(dc / hf)
                v = np.float32(-0.2301 * r * r + 0.5307 * r + 0.7040)
                p = ta + hf * v
            if not p < pot[n]:
                continue
            pot[n] = p
            priority = p
            if use_astar:
                dx, dy = n % nx - target_x, n // nx - target_y
                priority = p + np.float32(np.float64(np.sqrt(np.float64(dx * dx + dy * dy))) * 50.0)
            band = nxt if priority < threshold else over
            for m, pm in ((n - 1, left), (n + 1, right), (n - nx, up), (n + nx, down)):
                if (
                    pm > priority + EDGE_MARGIN[cost[m]]
                    and not pending[m]
                    and cost[m] < COST_OBS
                    and counts[band] < BUFFER_SIZE
                ):
                    buffers[band, counts[band]] = m
                    counts[band] += 1
                    pending[m] = True
        counts[cur] = 0
        cur, nxt = nxt, cur
        if counts[cur] == 0:
            threshold = threshold + PRIORITY_INCREMENT
            cur, over = over, cur
        if 0 <= target < ns and pot[target] < POT_HIGH:
            break
    return pot


def _round_half_away(v: np.float32) -> int:
    """C's round(): halves away from zero."""
    d = np.float64(v)
    return int(math.floor(d + 0.5)) if d >= 0.0 else -int(math.floor(-d + 0.5))


def _hypotf(x: np.float32, y: np.float32) -> np.float32:
    """hypotf: the float32 result of the exact-in-double sum of squares."""
    xd, yd = np.float64(x), np.float64(y)
    return np.float32(np.sqrt(xd * xd + yd * yd))


def _gradient(pot: np.ndarray, n: int, nx: int, ns: int) -> tuple[np.float32, np.float32]:
    """NavFn's normalised potential gradient at cell ``n``; zero on the first and last rows."""
    zero = np.float32(0.0)
    if n < nx or n > ns - nx:
        return zero, zero
    cv = pot[n]
    left = pot[n - 1]
    right = pot[n + 1]
    up = pot[n - nx]
    down = pot[n + nx] if n + nx < ns else POT_HIGH
    gx, gy = zero, zero
    if cv >= POT_HIGH:  # in an obstacle: point out of it, towards an assigned neighbour
        if left < POT_HIGH:
            gx = np.float32(-COST_OBS)
        elif right < POT_HIGH:
            gx = np.float32(COST_OBS)
        if up < POT_HIGH:
            gy = np.float32(-COST_OBS)
        elif down < POT_HIGH:
            gy = np.float32(COST_OBS)
    else:
        if left < POT_HIGH:
            gx += left - cv
        if right < POT_HIGH:
            gx += cv - right
        if up < POT_HIGH:
            gy += up - cv
        if down < POT_HIGH:
            gy += cv - down
    norm = _hypotf(gx, gy)
    if norm > zero:
        inv = np.float32(1.0 / np.float64(norm))
        return inv * gx, inv * gy
    return zero, zero


def _blend(a: np.float32, b: np.float32, t: np.float32) -> np.float32:
    """(1.0 - t) * a + t * b as NavFn writes it: the first product in double, the second in float."""
    return np.float32((1.0 - np.float64(t)) * np.float64(a) + np.float64(t * b))


def _potential_int(v: np.float32) -> int:
    """The potential truncated to an int, as NavFn's ``int minp = potarr[...]`` (INT_MIN when it overflows)."""
    if v >= np.float32(2147483648.0) or v < np.float32(-2147483648.0):
        return -2147483648
    return int(v)


def trace_path(
    pot: np.ndarray, nx: int, ny: int, start_x: int, start_y: int, end_x: int, end_y: int, max_cycles: int
) -> tuple[int, np.ndarray, np.ndarray]:
    """NavFn's gradient descent from cell (start_x, start_y) until the potential is below 50.

    Returns (status, x, y): the path in cell coordinates (float32, ending with the end cell, the seed of
    the potential) and ``PATH_FOUND``, ``PATH_OUT_OF_CYCLES`` or ``PATH_STUCK`` (then x and y are empty).
    """
    ns = nx * ny
    xs = np.empty(max_cycles + 1, dtype=np.float32)
    ys = np.empty(max_cycles + 1, dtype=np.float32)
    empty = np.empty(0, dtype=np.float32)
    stc = start_y * nx + start_x
    dx = np.float32(0.0)
    dy = np.float32(0.0)
    for i in range(max_cycles):  # i: the points so far
        nearest = max(0, min(ns - 1, stc + _round_half_away(dx) + nx * _round_half_away(dy)))
        if pot[nearest] < COST_NEUTRAL:
            xs[i] = np.float32(end_x)
            ys[i] = np.float32(end_y)
            return PATH_FOUND, xs[: i + 1].copy(), ys[: i + 1].copy()
        if stc < nx or stc > ns - nx:
            return PATH_STUCK, empty, empty
        xs[i] = np.float32(stc % nx) + dx
        ys[i] = np.float32(stc // nx) + dy
        oscillating = i >= 2 and xs[i] == xs[i - 2] and ys[i] == ys[i - 2]
        below, above = stc - nx, stc + nx
        high = oscillating or above + 1 >= ns
        if not high:
            for k in (stc, stc + 1, stc - 1, above, above + 1, above - 1, below, below + 1, below - 1):
                if pot[k] >= POT_HIGH:
                    high = True
                    break
        if high:  # follow the grid: the lowest of the 8 neighbours
            best = stc
            lowest = _potential_int(pot[stc])
            for k in (below - 1, below, below + 1, stc - 1, stc + 1, above - 1, above, above + 1):
                if 0 <= k < ns and pot[k] < np.float32(lowest):
                    lowest = _potential_int(pot[k])
                    best = k
            stc = best
            dx = np.float32(0.0)
            dy = np.float32(0.0)
            if pot[stc] >= POT_HIGH:
                return PATH_STUCK, empty, empty
        else:
            g00x, g00y = _gradient(pot, stc, nx, ns)
            g10x, g10y = _gradient(pot, stc + 1, nx, ns)
            g01x, g01y = _gradient(pot, above, nx, ns)
            g11x, g11y = _gradient(pot, above + 1, nx, ns)
            x = _blend(_blend(g00x, g10x, dx), _blend(g01x, g11x, dx), dy)
            y = _blend(_blend(g00y, g10y, dx), _blend(g01y, g11y, dx), dy)
            if x == np.float32(0.0) and y == np.float32(0.0):
                return PATH_STUCK, empty, empty
            ss = PATH_STEP / _hypotf(x, y)
            dx = dx + x * ss
            dy = dy + y * ss
            if dx > np.float32(1.0):
                stc += 1
                dx = dx - np.float32(1.0)
            if dx < np.float32(-1.0):
                stc -= 1
                dx = dx + np.float32(1.0)
            if dy > np.float32(1.0):
                stc += nx
                dy = dy - np.float32(1.0)
            if dy < np.float32(-1.0):
                stc -= nx
                dy = dy + np.float32(1.0)
    return PATH_OUT_OF_CYCLES, empty, empty


class Kernels(NamedTuple):
    """The functions ``NavfnPlanner`` calls, compiled or not."""

    propagate: Callable[..., np.ndarray]
    trace_path: Callable[..., tuple[int, np.ndarray, np.ndarray]]
    compiled: bool


PYTHON = Kernels(propagate, trace_path, False)


@functools.cache
def kernels() -> Kernels:
    """The kernels compiled by numba (on first use; cached on disk)."""
    compiled = compile_together(
        globals(), (_round_half_away, _hypotf, _gradient, _blend, _potential_int, propagate, trace_path)
    )
    return Kernels(compiled["propagate"], compiled["trace_path"], True)
