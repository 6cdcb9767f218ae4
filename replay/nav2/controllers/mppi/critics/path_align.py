"""``mppi::critics::PathAlignCritic``: the trajectories' distance to the path at the same integrated length."""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.compiled import compile_together
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData


@dataclass(frozen=True)
class PathAlignCriticParams(CriticParams):
    cost_weight: float = param(10.0, ge=0.0)
    max_path_occupancy_ratio: float = param(0.07, ge=0.0)
    offset_from_furthest: int = param(20, ge=0)
    trajectory_point_step: int = param(4, ge=1)
    threshold_to_consider: float = param(0.5, ge=0.0)
    use_path_orientations: bool = False


def aligned_distances(x, y, yaw, step, path, along, valid, use_orientations, out):
    """Each trajectory's mean distance to the path (``out``, float64), to be compiled. Every ``step``-th
    pose after the first is matched to the path point nearest its integrated length (float32 running
    sum, as Nav2) among ``along`` (the path's, float64), searched on from the previous match (Nav2's
    ``findClosestPathPt``); points matched to an invalid path point are left out; no point left: 0."""
    last = along.shape[0] - 1
    for i in range(x.shape[0]):
        length = x[i, 0] - x[i, 0]  # float32 zero
        nearest, upper, samples, total = 0, 0, 0, 0.0
        for k in range(step, x.shape[1], step):
            sx, sy = x[i, k] - x[i, k - step], y[i, k] - y[i, k - step]  # float32
            length += np.float32(math.sqrt(sx * sx + sy * sy))
            t = float(length)
            while upper <= last and along[upper] <= t:  # the first path length beyond t
                upper += 1
            if upper > last:
                here = last
            else:
                before = along[max(upper - 1, 0)]
                here = upper - 1 if t - before < along[upper] - t else upper
            nearest = max(nearest, here)
            if not valid[nearest]:
                continue
            dx, dy = path[nearest, 0] - float(x[i, k]), path[nearest, 1] - float(y[i, k])
            d2 = dx * dx + dy * dy
            if use_orientations:
                turn = np.fmod(float(yaw[i, k]) - path[nearest, 2] + math.pi, 2.0 * math.pi)
                turn = turn + math.pi if turn < 0.0 else turn - math.pi
                d2 += turn * turn
            samples += 1
            total += math.sqrt(d2)
        out[i] = total / samples if samples > 0 else 0.0


@functools.cache
def compiled_aligned_distances() -> Callable[..., None]:
    """``aligned_distances`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (aligned_distances,))["aligned_distances"]


class PathAlignCritic(Critic[PathAlignCriticParams]):
    """Mean distance of sampled trajectory points to the path point at the same integrated length."""

    def score(self, data: CriticData) -> None:
        p = self.p
        if data.robot_near_goal(p.threshold_to_consider):
            return
        count = data.furthest_reached()
        if count < p.offset_from_furthest or count == 0:
            return
        valid = data.path_points_valid()
        invalid_running = np.cumsum(~valid[:count])
        over = (invalid_running / count > p.max_path_occupancy_ratio) & (invalid_running > 2.0)
        if over.any():
            return
        path = data.path[:count]
        seg = np.hypot(np.diff(path[:, 0]), np.diff(path[:, 1]))
        along = np.concatenate([[0.0], np.cumsum(seg)])
        out = np.empty(data.x.shape[0])
        compiled_aligned_distances()(
            data.x, data.y, data.yaw, p.trajectory_point_step, path, along, valid, p.use_path_orientations, out
        )
        self.add(data, out)
