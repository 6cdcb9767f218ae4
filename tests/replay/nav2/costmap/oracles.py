"""NumPy and SciPy forms of the costmap kernels (``navlog.replay.nav2.costmap.kernels``): vectorised,
plainly written, the oracles the compiled kernels must equal bit for bit."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from navlog.replay.nav2.costmap.cost_values import FREE_SPACE, INSCRIBED, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.raytrace import cell_steps


def numpy_inflate_window(
    region: np.ndarray,
    row0: int,
    row1: int,
    col0: int,
    col1: int,
    table: np.ndarray,
    around_unknown: bool,
    inflate_unknown: bool,
) -> None:
    """``kernels.inflate_window`` with NumPy and SciPy: the distance transform's nearest cells, then the table."""
    sources = region == LETHAL
    if around_unknown:
        sources |= region == NO_INFORMATION
    if not sources.any():
        return
    d2 = squared_distance_within(sources, (row0, row1), (col0, col1))
    # the table's last entry, FREE, stands for every distance beyond the radius: it changes no cell
    new = table.take(d2, mode="clip")
    mw = region[row0:row1, col0:col1]
    out = np.maximum(mw, new)
    # an unknown cell takes the new cost only if it is high enough (any cost with inflate_unknown)
    take = mw == NO_INFORMATION
    take &= (new > FREE_SPACE) if inflate_unknown else (new >= INSCRIBED)
    np.copyto(out, new, where=take)
    mw[...] = out


def squared_distance_within(sources: np.ndarray, rows: tuple[int, int], cols: tuple[int, int]) -> np.ndarray:
    """Squared Euclidean distance in cells (int) from each cell of sources[rows, cols] to the nearest
    True cell of ``sources``: the exact distance transform's nearest cells (scipy), squared in integers.
    """
    fy, fx = ndimage.distance_transform_edt(~sources, return_distances=False, return_indices=True)
    a, b = rows
    c0, c1 = cols
    dy = fy[a:b, c0:c1] - np.arange(a, b, dtype=fy.dtype)[:, None]
    dx = fx[a:b, c0:c1] - np.arange(c0, c1, dtype=fx.dtype)[None, :]
    dy *= dy
    dx *= dx
    dy += dx
    return dy


def numpy_clear_rays(grid, sx, sy, ax, ay, bx, by, counts, da, db, value: int) -> tuple[int, int, int, int, int]:
    """Set the cells of the rays (``ray_steps``' arrays) that lie inside ``grid`` (rows y, columns x) to ``value``.

    Returns how many ray cells lie inside and their bounds (xmin, ymin, xmax, ymax, inclusive; zeros when
    none does). ``kernels.clear_rays`` with NumPy: all cells of all rays at once.
    """
    if len(counts) == 0:
        return 0, 0, 0, 0, 0
    i, minor = cell_steps(counts, da, db)
    # a ray's cells run from its start to its last cell, so those bound them
    end = np.cumsum(counts) - 1
    lx = sx + i[end] * ax + minor[end] * bx
    ly = sy + i[end] * ay + minor[end] * by
    xmin, xmax = min(int(sx.min()), int(lx.min())), max(int(sx.max()), int(lx.max()))
    ymin, ymax = min(int(sy.min()), int(ly.min())), max(int(sy.max()), int(ly.max()))
    h, w = grid.shape
    if xmin >= 0 and ymin >= 0 and xmax < w and ymax < h:  # all inside: flat indices
        flat = (sy * w + sx).repeat(counts) + i * (ay * w + ax).repeat(counts) + minor * (by * w + bx).repeat(counts)
        grid.put(flat, value)
        return len(i), xmin, ymin, xmax, ymax
    mx = sx.repeat(counts) + i * ax.repeat(counts) + minor * bx.repeat(counts)
    my = sy.repeat(counts) + i * ay.repeat(counts) + minor * by.repeat(counts)
    inside = (mx >= 0) & (mx < w) & (my >= 0) & (my < h)
    mx, my = mx[inside], my[inside]
    grid[my, mx] = value
    if len(mx) == 0:
        return 0, 0, 0, 0, 0
    return len(mx), int(mx.min()), int(my.min()), int(mx.max()), int(my.max())
