"""What every global planner shares: the result, the error, the costmap it reads, path length and cost.

A planner (``NavfnPlanner``, ``Smac2DPlanner``) is built from its parameter dataclass and plans on
anything with ``costs`` (uint8, ``costs[my, mx]``), ``resolution``, ``origin_x`` and ``origin_y``
(a ``Costmap2D``, or a bare grid in tests), from a start pose to a goal pose (x, y, yaw) in the
costmap's frame. It returns a ``PlanResult`` or raises ``PlanningError`` with what a user can change.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.geometry import world_to_cell

Pose2D = tuple[float, float, float]  # x, y (metres), yaw (radians)


class PlanningError(NavlogError):
    """No plan: start or goal outside the map or occupied, or no path exists."""


class PlanningCostmap(Protocol):
    """What a planner reads of a costmap."""

    costs: np.ndarray  # uint8 (ny, nx), Nav2 cost values
    resolution: float
    origin_x: float
    origin_y: float


class Planner(Protocol):
    """A global planner (a planner plugin's implementation)."""

    def plan(self, cm: PlanningCostmap, start: Pose2D, goal: Pose2D) -> PlanResult: ...


@dataclass
class PlanResult:
    """A plan in world coordinates (robot -> goal) with what it cost to find."""

    poses: np.ndarray  # (N, 3) x, y, yaw; yaw 0 except where the planner sets it
    length: float  # metres
    cost: float  # cost-weighted length in metres (free space: equal to the length)
    time_s: float  # planning time (wall clock; reported, never part of the output)
    goal_used: Pose2D  # the goal actually planned to (tolerance may move it)
    planner: str
    notes: list[str] = field(default_factory=list)


def path_length(xy: np.ndarray) -> float:
    """Length in metres of a path (N, >=2) of x, y rows."""
    if len(xy) < 2:
        return 0.0
    return float(np.hypot(*np.diff(xy[:, :2], axis=0).T).sum())


def path_cost(
    xy: np.ndarray,
    cell_cost: np.ndarray,
    resolution: float,
    origin: tuple[float, float],
    neutral: float,
    step: float = 0.25,
) -> float:
    """Line integral of cell_cost / neutral along a world path (sampled every ``step`` cells).

    Each segment is sampled at the centres of ceil(length / (step * resolution)) equal parts and
    contributes length * mean(sampled costs) / neutral; the sum runs in path order.
    """
    xy = np.asarray(xy, dtype=np.float64)
    if len(xy) < 2:
        return 0.0
    ny, nx = cell_cost.shape
    x0, y0 = xy[:-1, 0], xy[:-1, 1]
    ddx, ddy = xy[1:, 0] - x0, xy[1:, 1] - y0
    seg = np.array([math.hypot(a, b) for a, b in zip(ddx.tolist(), ddy.tolist())])  # math.hypot: the scalar rounding
    keep = seg != 0.0
    x0, y0, ddx, ddy, seg = x0[keep], y0[keep], ddx[keep], ddy[keep], seg[keep]
    if len(seg) == 0:
        return 0.0
    n = np.maximum(np.ceil(seg / (step * resolution)).astype(np.int64), 1)
    ray = np.repeat(np.arange(len(n)), n)
    first = np.cumsum(n) - n
    nr = n[ray]
    t = (np.arange(len(ray)) - first[ray] + 0.5) / nr
    mx = np.clip(world_to_cell(x0[ray] + t * ddx[ray], origin[0], resolution), 0, nx - 1)
    my = np.clip(world_to_cell(y0[ray] + t * ddy[ray], origin[1], resolution), 0, ny - 1)
    vals = cell_cost[my, mx].astype(np.float64)
    means = np.add.reduceat(vals, first) / n
    for i in np.flatnonzero(n >= 8):  # numpy sums 8 or more values pairwise: the same sums as ndarray.mean
        means[i] = vals[first[i] : first[i] + n[i]].copy().mean()  # a fresh (aligned) array: the same rounding
    return float(np.cumsum(seg * means / neutral)[-1])


def costmap_extent(cm: PlanningCostmap) -> str:
    """The costmap's extent in words, for messages: 'x [x0, x1), y [y0, y1)'."""
    ny, nx = cm.costs.shape
    return (
        f"x [{cm.origin_x:.2f}, {cm.origin_x + nx * cm.resolution:.2f}), "
        f"y [{cm.origin_y:.2f}, {cm.origin_y + ny * cm.resolution:.2f})"
    )


def costmap_cell(cm: PlanningCostmap, what: str, pose: Pose2D) -> tuple[int, int]:
    """The cell (mx, my) holding ``pose``; PlanningError '<what> (x, y) is outside the costmap ...' when none does
    (also for a coordinate that is not finite or too large to index a cell)."""
    ny, nx = cm.costs.shape
    fx = (pose[0] - cm.origin_x) / cm.resolution
    fy = (pose[1] - cm.origin_y) / cm.resolution
    if not (0.0 <= fx < nx and 0.0 <= fy < ny):  # (also NaN)
        x, y = (f"{v:.2f}" if abs(v) < 1e12 else f"{v:.3g}" for v in pose[:2])  # (1e+308, not its 309 digits)
        raise PlanningError(f"{what} ({x}, {y}) is outside the costmap {costmap_extent(cm)}")
    return math.floor(fx), math.floor(fy)


def tolerance_hint(cm: PlanningCostmap, goal: Pose2D, allow_unknown: bool) -> str:
    """'; the nearest free cell is 0.35 m away at (x, y): tolerance >= 0.35 would reach it' or ''."""
    from scipy import ndimage

    free = cm.costs < 253
    if allow_unknown:
        free |= cm.costs == 255
    if not free.any():
        return "; the costmap has no free cell"
    d, (iy, ix) = ndimage.distance_transform_edt(~free, return_indices=True)
    res = cm.resolution
    gx = min(max(int(math.floor((goal[0] - cm.origin_x) / res)), 0), free.shape[1] - 1)
    gy = min(max(int(math.floor((goal[1] - cm.origin_y) / res)), 0), free.shape[0] - 1)
    fx, fy = int(ix[gy, gx]), int(iy[gy, gx])
    wx, wy = cm.origin_x + (fx + 0.5) * res, cm.origin_y + (fy + 0.5) * res
    dist = math.hypot(wx - goal[0], wy - goal[1])
    return (
        f"; the nearest free cell is at ({wx:.2f}, {wy:.2f}), {dist:.2f} m away: "
        f"tolerance >= {dist:.2f} would plan to it (if it is reachable)"
    )
