"""A 2-D layered costmap as Nav2's ``nav2_costmap_2d`` computes it: static, obstacle and inflation layers.

Costs are uint8: 0 FREE, 1..252 inflated, 253 INSCRIBED, 254 LETHAL, 255 NO_INFORMATION. The grid
follows Nav2: ``costs[my, mx]`` (row 0 = lowest y), world -> cell truncates, cell -> world is the
cell centre. An update works like ``LayeredCostmap::updateMap``: for a rolling window the origin
follows the robot (snapped to whole cells, overlapping data kept); each layer reports the cells it
changed (the update bounds), the master grid is reset to its default there, then the layers write
into it in list order. The inflation layer grows the bounds by its radius and computes distances
with an exact Euclidean distance transform (scipy), as the newest Nav2 does, over the bounds plus
its radius only; costs come from a table by integer squared distance (Nav2 caches them per cell offset).

Pure computation: observations come in as points already transformed into the costmap's global
frame; the node (``replay.nodes.planner``) does the TF lookups.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from navlog.replay import messages as m
from navlog.replay.io.map_server import OccupancyMap

FREE_SPACE = 0
INSCRIBED = 253
LETHAL = 254
NO_INFORMATION = 255

Bounds = tuple[int, int, int, int]  # x0, y0, x1, y1 in cells, half-open


def occupancy_values(costs: np.ndarray) -> np.ndarray:
    """Nav2's cost -> OccupancyGrid value table: 0->0, 253->99, 254->100, 255->-1, c->1+(97(c-1))/251."""
    table = np.zeros(256, dtype=np.int16)
    c = np.arange(1, 253)
    table[1:253] = 1 + (97 * (c - 1)) // 251
    table[253], table[254], table[255] = 99, 100, -1
    return table[np.asarray(costs, dtype=np.uint8)].astype(np.int8)


def costs_from_occupancy(values: np.ndarray) -> np.ndarray:
    """OccupancyGrid value -> cost as Nav2 reads a costmap message: -1 -> 255, v -> round(v * 254 / 100)."""
    v = np.asarray(values, dtype=np.int16)
    out = np.rint(np.clip(v, 0, 100) * 254.0 / 100.0).astype(np.uint8)
    out[v < 0] = NO_INFORMATION
    return out


# ---------------------------------------------------------------- footprint


def radius_footprint(radius: float) -> list[tuple[float, float]]:
    """Nav2's 16-point polygon for a circular robot."""
    return [(radius * math.cos(i * 2 * math.pi / 16), radius * math.sin(i * 2 * math.pi / 16)) for i in range(16)]


def pad_footprint(points: list[tuple[float, float]], padding: float) -> list[tuple[float, float]]:
    """Move each vertex outward by ``padding`` along x and y (sign of each coordinate), as Nav2 does."""

    def sign0(v: float) -> float:
        return 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)

    return [(x + sign0(x) * padding, y + sign0(y) * padding) for x, y in points]


def robot_footprint(params) -> list[tuple[float, float]]:
    """The padded footprint of a CostmapParams: its polygon if set, else the robot_radius 16-gon."""
    pts = params.footprint_points()
    if not pts:
        pts = radius_footprint(params.robot_radius)
    return pad_footprint(pts, params.footprint_padding)


def footprint_radii(points: list[tuple[float, float]]) -> tuple[float, float]:
    """(inscribed, circumscribed): nearest edge and farthest vertex from the origin."""
    if not points:
        return 0.0, 0.0
    p = np.asarray(points, dtype=np.float64)
    q = np.roll(p, -1, axis=0)
    d = q - p
    length2 = (d * d).sum(axis=1)
    t = np.where(length2 > 0, np.clip(-(p * d).sum(axis=1) / np.where(length2 > 0, length2, 1), 0, 1), 0)
    closest = p + d * t[:, None]
    inscribed = float(np.hypot(closest[:, 0], closest[:, 1]).min())
    circumscribed = float(np.hypot(p[:, 0], p[:, 1]).max())
    return inscribed, circumscribed


def transform_footprint(points, x: float, y: float, yaw: float) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack([x + c * p[:, 0] - s * p[:, 1], y + s * p[:, 0] + c * p[:, 1]])


# ---------------------------------------------------------------- rays


def _bresenham(x0, y0, x1, y1, max_length: float, min_length: float):
    """Nav2's ``raytraceLine`` for each ray (x0, y0) -> (x1, y1) (cells; starts may be one cell or one per ray).

    Rays shorter than ``min_length`` are dropped, the others start ``min_length`` cells out and are
    cut at ``max_length`` cells. Returns per ray: start (sx, sy), major and minor unit steps
    ((ax, ay), (bx, by)), the cell count, and per cell the step index i and the minor offset.
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
    total = int(counts.sum())
    first = np.cumsum(counts) - counts
    i = np.arange(total, dtype=np.int64) - first.repeat(counts)
    minor = ((da // 2).repeat(counts) + i * db.repeat(counts)) // np.maximum(da, 1).repeat(counts)
    return sx, sy, (ax, ay), (bx, by), counts, i, minor


def bresenham_cells(x0, y0, x1, y1, max_length, min_length):
    """Cells Nav2's ``raytraceLine`` visits for each ray, vectorised over rays.

    x0, y0: start cell (ints, or one per ray); x1, y1: end cells (int arrays); lengths in cells.
    Returns (mx, my).
    """
    sx, sy, (ax, ay), (bx, by), counts, i, minor = _bresenham(x0, y0, x1, y1, max_length, min_length)
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
    vx = np.floor((xs - ox) / res).astype(np.int64)
    vy = np.floor((ys - oy) / res).astype(np.int64)
    ex, ey = bresenham_cells(vx, vy, vx[following], vy[following], 1e9, 0.0)
    mx = np.concatenate([gx[inside], ex])
    my = np.concatenate([gy[inside], ey])
    ok = (mx >= 0) & (mx < nx) & (my >= 0) & (my < ny)
    return mx[ok], my[ok]


def _union(a: Bounds | None, b: Bounds | None) -> Bounds | None:
    if a is None:
        return b
    if b is None:
        return a
    return min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])


def _shift_grid(grid: np.ndarray, sx: int, sy: int, fill: int) -> np.ndarray:
    """Content of ``grid`` seen from an origin moved by (sx, sy) cells; uncovered cells get ``fill``."""
    out = np.full_like(grid, fill)
    h, w = grid.shape
    if abs(sx) >= w or abs(sy) >= h:
        return out
    src_x = slice(max(sx, 0), w + min(sx, 0))
    dst_x = slice(max(-sx, 0), w + min(-sx, 0))
    src_y = slice(max(sy, 0), h + min(sy, 0))
    dst_y = slice(max(-sy, 0), h + min(-sy, 0))
    out[dst_y, dst_x] = grid[src_y, src_x]
    return out


# ---------------------------------------------------------------- observations and layers


@dataclass
class Observation:
    """Points (N, 3) in the costmap's global frame, with the sensor origin in that frame."""

    origin: np.ndarray  # (3,)
    points: np.ndarray  # (N, 3)
    source: str


class StaticLayer:
    def __init__(self, name: str, params, costmap: Costmap2D) -> None:
        self.name, self.p, self.cm = name, params, costmap
        self.map_costs: np.ndarray | None = None
        self.map: OccupancyMap | None = None
        self.has_new = False

    def interpret(self, occ: OccupancyMap) -> np.ndarray:
        cp = self.cm.params
        raw = occ.data.astype(np.int16) & 0xFF  # unsigned bytes: -1 arrives as 255
        out = np.zeros(raw.shape, dtype=np.uint8)
        unknown = raw == cp.unknown_cost_value
        lethal = (raw >= cp.lethal_cost_threshold) & ~unknown
        if not cp.trinary_costmap:
            scaled = (raw.astype(np.float64) / cp.lethal_cost_threshold * LETHAL).astype(np.int64)
            out = np.clip(scaled, 0, 255).astype(np.uint8)
        out[lethal] = LETHAL
        out[unknown] = NO_INFORMATION if cp.track_unknown_space else FREE_SPACE
        return out

    def set_map(self, occ: OccupancyMap) -> None:
        self.map = occ
        self.map_costs = self.interpret(occ)
        self.has_new = True

    def update_bounds(self) -> Bounds | None:
        if self.map_costs is None:
            return None
        if self.cm.params.rolling_window or self.has_new:
            self.has_new = False
            return 0, 0, self.cm.size_x, self.cm.size_y
        return None

    def _window_costs(self) -> np.ndarray:
        """Static costs resampled at the master cells' centres (rolling window, or other geometry)."""
        cm, occ = self.cm, self.map
        assert occ is not None and self.map_costs is not None
        gx, gy = cm.cell_centres()
        mx = np.floor((gx - occ.origin[0]) / occ.resolution).astype(np.int64)
        my = np.floor((gy - occ.origin[1]) / occ.resolution).astype(np.int64)
        inside = (mx >= 0) & (mx < occ.width) & (my >= 0) & (my < occ.height)
        out = np.full(gx.shape, NO_INFORMATION if cm.params.track_unknown_space else FREE_SPACE, dtype=np.uint8)
        out[inside] = self.map_costs[my[inside], mx[inside]]
        return out

    def update_costs(self, master: np.ndarray, b: Bounds) -> None:
        if self.map_costs is None:
            return
        x0, y0, x1, y1 = b
        same = (
            not self.cm.params.rolling_window
            and self.map_costs.shape == master.shape
            and self.map is not None
            and abs(self.map.origin[0] - self.cm.origin_x) < 1e-9
            and abs(self.map.origin[1] - self.cm.origin_y) < 1e-9
        )
        src = self.map_costs if same else self._window_costs()
        win = src[y0:y1, x0:x1]
        if self.cm.params.use_maximum:
            _update_with_max(master, win, b)
        else:  # true overwrite, unknown included
            master[y0:y1, x0:x1] = win


def _update_with_max(master: np.ndarray, layer_win: np.ndarray, b: Bounds) -> None:
    """Where the layer knows the cell: the layer's cost if the master's is unknown, else the higher one."""
    x0, y0, x1, y1 = b
    mw = master[y0:y1, x0:x1]
    known = layer_win != NO_INFORMATION
    out = np.maximum(mw, layer_win)
    np.copyto(out, layer_win, where=known & (mw == NO_INFORMATION))
    np.copyto(mw, out, where=known)


class ObstacleLayer:
    def __init__(self, name: str, params, costmap: Costmap2D) -> None:
        self.name, self.p, self.cm = name, params, costmap
        self.default = NO_INFORMATION if costmap.params.track_unknown_space else FREE_SPACE
        self.grid = np.full((costmap.size_y, costmap.size_x), self.default, dtype=np.uint8)
        self.latest: dict[str, Observation] = {}
        self.footprint_bounds: Bounds | None = None
        if params.is_voxel:
            top = params.origin_z + params.z_resolution * params.z_voxels
            self.max_height = min(params.max_obstacle_height, top)
        else:
            self.max_height = params.max_obstacle_height

    def resize(self) -> None:
        self.grid = np.full((self.cm.size_y, self.cm.size_x), self.default, dtype=np.uint8)

    def shift(self, sx: int, sy: int) -> None:
        self.grid = _shift_grid(self.grid, sx, sy, self.default)

    def add_observation(self, obs: Observation) -> None:
        """Keep the latest observation of a source (observation_persistence 0)."""
        self.latest[obs.source] = obs

    def update_bounds(self, robot: tuple[float, float, float]) -> Bounds | None:
        cm = self.cm
        bounds: Bounds | None = None
        observations = [self.latest[k] for k in sorted(self.latest)]
        self.latest = {}
        filtered = []
        for obs in observations:
            sp = self.p.sources[obs.source]
            pts = obs.points
            z = pts[:, 2]
            keep = (z >= sp.min_obstacle_height) & (z <= sp.max_obstacle_height)  # the observation buffer's filter
            filtered.append((obs, sp, pts[keep]))
        # clearing first
        for obs, sp, pts in filtered:
            if sp.clearing:
                bounds = _union(bounds, self._raytrace(obs.origin, pts, sp))
        # then marking
        for obs, sp, pts in filtered:
            if not sp.marking or len(pts) == 0:
                continue
            z = pts[:, 2]
            ok = (z <= self.max_height) & (z >= self.p.min_obstacle_height)
            d2 = ((pts - obs.origin[None, :]) ** 2).sum(axis=1)
            ok &= (d2 < sp.obstacle_max_range**2) & (d2 >= sp.obstacle_min_range**2)
            mx, my = cm.world_to_cell(pts[ok, 0], pts[ok, 1])
            inside = (mx >= 0) & (mx < cm.size_x) & (my >= 0) & (my < cm.size_y)
            mx, my = mx[inside], my[inside]
            if len(mx):
                self.grid[my, mx] = LETHAL
                bounds = _union(bounds, (int(mx.min()), int(my.min()), int(mx.max()) + 1, int(my.max()) + 1))
        # footprint
        if self.p.footprint_clearing_enabled:
            poly = transform_footprint(cm.footprint, *robot)
            fx, fy = cm.world_to_cell(poly[:, 0], poly[:, 1])
            fb = (int(fx.min()), int(fy.min()), int(fx.max()) + 1, int(fy.max()) + 1)
            self.footprint_poly = poly
            bounds = _union(bounds, _union(fb, self.footprint_bounds))
            self.footprint_bounds = fb
        return bounds

    def _raytrace(self, origin: np.ndarray, pts: np.ndarray, sp) -> Bounds | None:
        cm = self.cm
        ox, oy = float(origin[0]), float(origin[1])
        x0, y0 = cm.world_to_cell(ox, oy)
        if not (0 <= x0 < cm.size_x and 0 <= y0 < cm.size_y):
            cm.skipped["sensor origin outside the costmap"] = cm.skipped.get("sensor origin outside the costmap", 0) + 1
            return None
        if len(pts) == 0:
            return x0, y0, x0 + 1, y0 + 1
        wx, wy = pts[:, 0].copy(), pts[:, 1].copy()
        a, b = wx - ox, wy - oy
        end_x, end_y = cm.origin_x + cm.size_x * cm.resolution, cm.origin_y + cm.size_y * cm.resolution
        with np.errstate(divide="ignore", invalid="ignore"):
            c = wx < cm.origin_x
            t = (cm.origin_x - ox) / a
            wy = np.where(c, oy + b * t, wy)
            wx = np.where(c, cm.origin_x, wx)
            c = wy < cm.origin_y
            t = (cm.origin_y - oy) / b
            wx = np.where(c, ox + a * t, wx)
            wy = np.where(c, cm.origin_y, wy)
            c = wx > end_x
            t = (end_x - ox) / a
            wy = np.where(c, oy + b * t, wy)
            wx = np.where(c, end_x - 0.001, wx)
            c = wy > end_y
            t = (end_y - oy) / b
            wx = np.where(c, ox + a * t, wx)
            wy = np.where(c, end_y - 0.001, wy)
        x1, y1 = cm.world_to_cell(wx, wy)
        ok = (x1 >= 0) & (x1 < cm.size_x) & (y1 >= 0) & (y1 < cm.size_y)
        max_cells = math.ceil(sp.raytrace_max_range / cm.resolution)
        min_cells = math.ceil(sp.raytrace_min_range / cm.resolution)
        sx, sy, (ax, ay), (bx, by), counts, i, minor = _bresenham(x0, y0, x1[ok], y1[ok], max_cells, min_cells)
        if len(i) == 0:
            return x0, y0, x0 + 1, y0 + 1
        # a ray's cells run from its start to its last cell, so those bound them
        end = np.cumsum(counts) - 1
        lx = sx + i[end] * ax + minor[end] * bx
        ly = sy + i[end] * ay + minor[end] * by
        xmin, xmax = min(int(sx.min()), int(lx.min())), max(int(sx.max()), int(lx.max()))
        ymin, ymax = min(int(sy.min()), int(ly.min())), max(int(sy.max()), int(ly.max()))
        w = cm.size_x
        if xmin >= 0 and ymin >= 0 and xmax < w and ymax < cm.size_y:  # always, the rays being clipped: flat indices
            flat = (
                (sy * w + sx).repeat(counts) + i * (ay * w + ax).repeat(counts) + minor * (by * w + bx).repeat(counts)
            )
            self.grid.put(flat, FREE_SPACE)
        else:
            mx = sx.repeat(counts) + i * ax.repeat(counts) + minor * bx.repeat(counts)
            my = sy.repeat(counts) + i * ay.repeat(counts) + minor * by.repeat(counts)
            inside = (mx >= 0) & (mx < cm.size_x) & (my >= 0) & (my < cm.size_y)
            mx, my = mx[inside], my[inside]
            self.grid[my, mx] = FREE_SPACE
            if len(mx) == 0:
                return x0, y0, x0 + 1, y0 + 1
            xmin, xmax, ymin, ymax = int(mx.min()), int(mx.max()), int(my.min()), int(my.max())
        return min(xmin, x0), min(ymin, y0), max(xmax, x0) + 1, max(ymax, y0) + 1

    def update_costs(self, master: np.ndarray, b: Bounds) -> None:
        cm = self.cm
        if self.p.footprint_clearing_enabled and getattr(self, "footprint_poly", None) is not None:
            fx, fy = polygon_cells(self.footprint_poly, cm.origin_x, cm.origin_y, cm.resolution, cm.size_x, cm.size_y)
            self.grid[fy, fx] = FREE_SPACE
        x0, y0, x1, y1 = b
        win = self.grid[y0:y1, x0:x1]
        method = self.p.combination_method
        if method == 0:  # overwrite where the layer knows something
            np.copyto(master[y0:y1, x0:x1], win, where=win != NO_INFORMATION)
        elif method == 1:
            _update_with_max(master, win, b)
        else:  # max, never overwriting unknown
            mw = master[y0:y1, x0:x1]
            np.copyto(mw, np.maximum(mw, win), where=(win != NO_INFORMATION) & (mw != NO_INFORMATION))


def inflation_costs(d_cells: np.ndarray, resolution: float, inscribed: float, k: float) -> np.ndarray:
    """Nav2's inflation cost for distances in cells to the nearest lethal cell."""
    d = np.asarray(d_cells, dtype=np.float64)
    metres = d * resolution
    cost = np.floor(252.0 * np.exp(-k * (metres - inscribed))).astype(np.int64)
    cost = np.where(metres <= inscribed, INSCRIBED, cost)
    cost = np.where(d == 0, LETHAL, cost)
    return np.clip(cost, 0, 255).astype(np.uint8)


class InflationLayer:
    def __init__(self, name: str, params, costmap: Costmap2D) -> None:
        self.name, self.p, self.cm = name, params, costmap
        self.need_full = True

    @property
    def cell_radius(self) -> int:
        return int(math.ceil(self.p.inflation_radius / self.cm.resolution))

    def update_bounds(self, bounds: Bounds | None) -> Bounds | None:
        cm = self.cm
        if self.need_full:
            self.need_full = False
            return 0, 0, cm.size_x, cm.size_y
        if bounds is None:
            return None
        r = self.cell_radius
        x0, y0, x1, y1 = bounds
        return max(x0 - r, 0), max(y0 - r, 0), min(x1 + r, cm.size_x), min(y1 + r, cm.size_y)

    def _cost_table(self) -> np.ndarray:
        """Inflation cost by squared distance in cells (0 .. r^2), then 0 for 'beyond the radius'."""
        r = self.cell_radius
        key = (r, self.cm.resolution, self.cm.inscribed_radius, self.p.cost_scaling_factor)
        if getattr(self, "_table_key", None) != key:
            d = np.sqrt(np.arange(r * r + 1, dtype=np.float64))  # as the distance transform computes them
            table = inflation_costs(d, self.cm.resolution, self.cm.inscribed_radius, self.p.cost_scaling_factor)
            self._table = np.append(table, np.uint8(FREE_SPACE))
            self._table_key = key
        return self._table

    def update_costs(self, master: np.ndarray, b: Bounds) -> None:
        cm = self.cm
        r = self.cell_radius
        x0, y0, x1, y1 = b
        rx0, ry0 = max(x0 - r, 0), max(y0 - r, 0)
        rx1, ry1 = min(x1 + r, cm.size_x), min(y1 + r, cm.size_y)
        region = master[ry0:ry1, rx0:rx1]
        sources = region == LETHAL
        if self.p.inflate_around_unknown:
            sources |= region == NO_INFORMATION
        if not sources.any():
            return
        d2 = squared_distance_within(sources, (y0 - ry0, y1 - ry0), (x0 - rx0, x1 - rx0))
        # the table's last entry, FREE, stands for every distance beyond the radius: it changes no cell
        new = self._cost_table().take(d2, mode="clip")
        mw = master[y0:y1, x0:x1]
        out = np.maximum(mw, new)
        # an unknown cell takes the new cost only if it is high enough (any cost with inflate_unknown)
        take = mw == NO_INFORMATION
        take &= (new > FREE_SPACE) if self.p.inflate_unknown else (new >= INSCRIBED)
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


# ---------------------------------------------------------------- the costmap


class Costmap2D:
    """A layered costmap built from a CostmapParams (one of a Nav2 file's costmaps)."""

    def __init__(self, params, name: str = "global_costmap") -> None:
        self.params = params
        self.name = name
        self.footprint = robot_footprint(params)
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.footprint)
        self.resolution = float(params.resolution)
        self.size_x = max(int(params.width / self.resolution), 1)
        self.size_y = max(int(params.height / self.resolution), 1)
        self.origin_x, self.origin_y = float(params.origin_x), float(params.origin_y)
        self.default = NO_INFORMATION if params.track_unknown_space else FREE_SPACE
        self.costs = np.full((self.size_y, self.size_x), self.default, dtype=np.uint8)
        self.skipped: dict[str, int] = {}
        self.layers: list[Any] = []
        self.initialized = False
        from navlog.replay.nav2.params import InflationLayerParams, ObstacleLayerParams, StaticLayerParams

        if not params.layers and not params.plugins:
            pass
        for lname in params.plugins:
            lp = params.layers.get(lname)
            if lp is None or not lp.enabled:
                continue
            if isinstance(lp, StaticLayerParams):
                self.layers.append(StaticLayer(lname, lp, self))
            elif isinstance(lp, ObstacleLayerParams):
                self.layers.append(ObstacleLayer(lname, lp, self))
            elif isinstance(lp, InflationLayerParams):
                self.layers.append(InflationLayer(lname, lp, self))

    # ---------------------------------------------------------- geometry
    def world_to_cell(self, x, y):
        mx = np.floor((np.asarray(x, dtype=np.float64) - self.origin_x) / self.resolution).astype(np.int64)
        my = np.floor((np.asarray(y, dtype=np.float64) - self.origin_y) / self.resolution).astype(np.int64)
        if mx.ndim == 0:
            return int(mx), int(my)
        return mx, my

    def cell_to_world(self, mx, my):
        x = self.origin_x + (np.asarray(mx, dtype=np.float64) + 0.5) * self.resolution
        y = self.origin_y + (np.asarray(my, dtype=np.float64) + 0.5) * self.resolution
        if np.ndim(x) == 0:
            return float(x), float(y)
        return x, y

    def contains(self, mx: int, my: int) -> bool:
        return 0 <= mx < self.size_x and 0 <= my < self.size_y

    def cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        xs = self.origin_x + (np.arange(self.size_x) + 0.5) * self.resolution
        ys = self.origin_y + (np.arange(self.size_y) + 0.5) * self.resolution
        return np.meshgrid(xs, ys)

    @property
    def static_layers(self) -> list[StaticLayer]:
        return [layer for layer in self.layers if isinstance(layer, StaticLayer)]

    @property
    def obstacle_layers(self) -> list[ObstacleLayer]:
        return [layer for layer in self.layers if isinstance(layer, ObstacleLayer)]

    def resize(self, size_x: int, size_y: int, resolution: float, origin_x: float, origin_y: float) -> None:
        self.size_x, self.size_y, self.resolution = int(size_x), int(size_y), float(resolution)
        self.origin_x, self.origin_y = float(origin_x), float(origin_y)
        self.costs = np.full((self.size_y, self.size_x), self.default, dtype=np.uint8)
        for layer in self.layers:
            if isinstance(layer, ObstacleLayer):
                layer.resize()
            if isinstance(layer, InflationLayer):
                layer.need_full = True

    # ---------------------------------------------------------- inputs
    def set_static_map(self, occ: OccupancyMap) -> None:
        """A new map for the static layer(s); a non-rolling costmap takes the map's size and origin."""
        if not self.static_layers:
            return
        if not self.params.rolling_window:
            self.resize(occ.width, occ.height, occ.resolution, occ.origin[0], occ.origin[1])
        for layer in self.static_layers:
            layer.set_map(occ)

    def add_observation(self, obs: Observation) -> bool:
        """Give an observation to the obstacle layers that list its source; False if none does."""
        used = False
        for layer in self.obstacle_layers:
            if obs.source in layer.p.sources:
                layer.add_observation(obs)
                used = True
        return used

    def update_origin(self, new_x: float, new_y: float) -> None:
        sx = int((new_x - self.origin_x) / self.resolution)
        sy = int((new_y - self.origin_y) / self.resolution)
        if sx == 0 and sy == 0:
            return
        self.origin_x += sx * self.resolution
        self.origin_y += sy * self.resolution
        self.costs = _shift_grid(self.costs, sx, sy, self.default)
        for layer in self.obstacle_layers:
            layer.shift(sx, sy)

    # ---------------------------------------------------------- update
    def update(self, robot_x: float, robot_y: float, robot_yaw: float = 0.0) -> Bounds | None:
        """One update cycle at the robot pose (global frame). Returns the cells that were recomputed."""
        if self.params.rolling_window:
            self.update_origin(
                robot_x - self.size_x * self.resolution / 2.0, robot_y - self.size_y * self.resolution / 2.0
            )
        robot = (robot_x, robot_y, robot_yaw)
        bounds: Bounds | None = None
        for layer in self.layers:
            if isinstance(layer, StaticLayer):
                bounds = _union(bounds, layer.update_bounds())
            elif isinstance(layer, ObstacleLayer):
                bounds = _union(bounds, layer.update_bounds(robot))
            else:
                bounds = layer.update_bounds(bounds)
        if self.params.rolling_window:
            bounds = (0, 0, self.size_x, self.size_y)
        if not self.initialized:
            bounds = (0, 0, self.size_x, self.size_y)
            self.initialized = True
        if bounds is None:
            return None
        x0, y0, x1, y1 = bounds
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, self.size_x), min(y1, self.size_y)
        if x1 <= x0 or y1 <= y0:
            return None
        b = (x0, y0, x1, y1)
        self.costs[y0:y1, x0:x1] = self.default
        for layer in self.layers:
            layer.update_costs(self.costs, b)
        return b

    # ---------------------------------------------------------- output
    def to_msg(self, ns: int, frame_id: str | None = None) -> Any:
        """nav_msgs/OccupancyGrid with Nav2's value mapping."""
        occ = OccupancyMap(
            data=occupancy_values(self.costs),
            resolution=self.resolution,
            origin=(self.origin_x, self.origin_y, 0.0),
            frame_id=frame_id or self.params.global_frame,
        )
        return occ.to_msg(ns)

    def footprint_msg(self, ns: int, x: float, y: float, yaw: float) -> Any:
        """geometry_msgs/PolygonStamped of the padded footprint at a pose (global frame)."""
        poly = transform_footprint(self.footprint, x, y, yaw)
        Point32 = m.msg_class("geometry_msgs/msg/Point32")
        Polygon = m.msg_class("geometry_msgs/msg/Polygon")
        return m.msg_class("geometry_msgs/msg/PolygonStamped")(
            header=m.header(ns, self.params.global_frame),
            polygon=Polygon(points=[Point32(x=float(px), y=float(py), z=0.0) for px, py in poly]),
        )

    def cost_at(self, x: float, y: float) -> int | None:
        mx, my = self.world_to_cell(x, y)
        if not self.contains(mx, my):
            return None
        return int(self.costs[my, mx])


def scan_points(msg: Any) -> np.ndarray:
    """A LaserScan's valid returns as (N, 3) points in the sensor frame, as laser_geometry projects them.

    Ranges in [range_min, range_max) are kept; NaN and inf are dropped (see ``scan_points_inf_valid``).
    """
    r = np.asarray(msg.ranges, dtype=np.float64)
    ang = float(msg.angle_min) + np.arange(len(r)) * float(msg.angle_increment)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r < float(msg.range_max)) & (r >= float(msg.range_min))
    r, ang = r[ok], ang[ok]
    return np.column_stack([r * np.cos(ang), r * np.sin(ang), np.zeros_like(r)])


def scan_points_inf_valid(msg: Any) -> np.ndarray:
    """As ``scan_points`` with inf_is_valid: +inf becomes range_max - 1e-4 (a clearing ray)."""
    r = np.asarray(msg.ranges, dtype=np.float64).copy()
    r[np.isposinf(r)] = float(msg.range_max) - 1e-4
    ang = float(msg.angle_min) + np.arange(len(r)) * float(msg.angle_increment)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r < float(msg.range_max)) & (r >= float(msg.range_min))
    r, ang = r[ok], ang[ok]
    return np.column_stack([r * np.cos(ang), r * np.sin(ang), np.zeros_like(r)])
