"""The robot footprint as Nav2's costmap uses it: parsed, padded, its radii, placed at a pose.

A footprint is a polygon of (x, y) vertices in the robot frame, metres; a circular robot
(``robot_radius``) gets Nav2's 16-point polygon. Padding moves each vertex outward along x and y.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.config import parse_yaml
from navlog.replay.nav2.costmap.cost_values import LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.raytrace import bresenham_cells


class FootprintParams(Protocol):
    """What ``robot_footprint`` reads of a costmap's parameters."""

    @property
    def robot_radius(self) -> float: ...

    @property
    def footprint_padding(self) -> float: ...

    def footprint_points(self) -> list[tuple[float, float]]: ...


def parse_footprint(text: str) -> list[tuple[float, float]]:
    """Nav2's footprint string '[[x, y], ...]' as points ('[]' -> [])."""
    try:
        value = parse_yaml(text, "footprint") if text.strip() else []
    except ConfigError:
        raise ValueError(f"footprint {text!r} is not of the form [[x, y], [x, y], ...]") from None
    if value in (None, []):
        return []
    if (
        not isinstance(value, list)
        or len(value) < 3
        or any(not isinstance(p, list) or len(p) != 2 for p in value)
        or any(isinstance(v, bool) or not isinstance(v, (int, float)) for p in value for v in p)
    ):
        raise ValueError(f"footprint {text!r} must be '[]' or at least 3 points [[x, y], [x, y], ...]")
    return [(float(p[0]), float(p[1])) for p in value]


def radius_footprint(radius: float) -> list[tuple[float, float]]:
    """Nav2's 16-point polygon for a circular robot."""
    return [(radius * math.cos(i * 2 * math.pi / 16), radius * math.sin(i * 2 * math.pi / 16)) for i in range(16)]


def pad_footprint(points: list[tuple[float, float]], padding: float) -> list[tuple[float, float]]:
    """Move each vertex outward by ``padding`` along x and y (sign of each coordinate), as Nav2 does."""

    def sign0(v: float) -> float:
        return 1.0 if v > 0 else (-1.0 if v < 0 else 0.0)

    return [(x + sign0(x) * padding, y + sign0(y) * padding) for x, y in points]


def robot_footprint(params: FootprintParams) -> list[tuple[float, float]]:
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
    """The footprint's vertices (N, 2) placed at pose (x, y, yaw) in the costmap's global frame."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.column_stack([x + c * p[:, 0] - s * p[:, 1], y + s * p[:, 0] + c * p[:, 1]])


def footprint_cost(costs: np.ndarray, vertices: np.ndarray, origin_x: float, origin_y: float, resolution: float) -> int:
    """Nav2's ``FootprintCollisionChecker::footprintCost``: the highest cost under the footprint's outline.

    ``costs[my, mx]`` is the costmap, ``vertices`` (K, 2) the footprint placed in its frame (see
    ``transform_footprint``); ``footprint_costs`` does the same for many placements at once.
    """
    v = np.asarray(vertices, dtype=np.float64).reshape(1, -1, 2)
    return int(footprint_costs(costs, v, origin_x, origin_y, resolution)[0])


def footprint_costs(
    costs: np.ndarray, vertices: np.ndarray, origin_x: float, origin_y: float, resolution: float
) -> np.ndarray:
    """``footprint_cost`` of P placements of a footprint, ``vertices`` (P, K, 2): int64 (P,).

    As Nav2: a vertex outside the map is LETHAL (254); edges are rasterised in order (vertex i ->
    i + 1, then vertex 0 -> the last); an edge touching a LETHAL cell costs LETHAL, and the first
    edge that brings the running maximum to LETHAL ends the check (so a NO_INFORMATION cell (255)
    met on an earlier edge keeps the result at 255).
    """
    v = np.asarray(vertices, dtype=np.float64)
    p, k = v.shape[0], v.shape[1]
    if p == 0 or k == 0:
        return np.zeros(p, dtype=np.int64)
    ny, nx = costs.shape
    mx = np.floor((v[..., 0] - origin_x) / resolution).astype(np.int64)
    my = np.floor((v[..., 1] - origin_y) / resolution).astype(np.int64)
    off_map = ((mx < 0) | (my < 0) | (mx >= nx) | (my >= ny)).any(axis=1)
    start = np.append(np.arange(k - 1), 0)
    end = np.append(np.arange(1, k), k - 1)
    sx, sy, ex, ey = mx[:, start].ravel(), my[:, start].ravel(), mx[:, end].ravel(), my[:, end].ravel()
    cx, cy = bresenham_cells(sx, sy, ex, ey, 1e9, 0.0)
    first = np.cumsum(np.maximum(np.abs(ex - sx), np.abs(ey - sy)) + 1)
    first = np.concatenate([[0], first[:-1]])
    cells = costs[np.clip(cy, 0, ny - 1), np.clip(cx, 0, nx - 1)].astype(np.int64)
    edge_max = np.maximum.reduceat(cells, first).reshape(p, k)
    edge_lethal = np.logical_or.reduceat(cells == LETHAL, first).reshape(p, k)
    edge_cost = np.where(edge_lethal, LETHAL, edge_max)
    before = np.concatenate([np.zeros((p, 1), np.int64), np.maximum.accumulate(edge_cost, axis=1)[:, :-1]], axis=1)
    stops_lethal = (edge_lethal & (before < NO_INFORMATION)).any(axis=1)
    result = np.where(stops_lethal, LETHAL, edge_cost.max(axis=1))
    return np.where(off_map, LETHAL, result)
