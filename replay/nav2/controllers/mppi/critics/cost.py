"""``mppi::critics::CostCritic``: the costmap's cost along the trajectories, collisions ruled out."""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from navlog.replay.compiled import compile_together
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.costmap.cost_values import INSCRIBED, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import footprint_costs
from navlog.replay.nav2.costmap.grid import CostmapGrid
from navlog.replay.nav2.costmap.inflation_layer import InflationLayerParams, inflation_costs
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.base import ControllerSetup
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
    from navlog.replay.nav2.controllers.mppi.params import MPPIParams


@dataclass(frozen=True)
class CostCriticParams(CriticParams):
    cost_weight: float = param(3.81, ge=0.0)
    consider_footprint: bool = False
    critical_cost: float = param(300.0, ge=0.0)
    near_collision_cost: int = param(253, ge=0)
    collision_cost: float = param(1000000.0, ge=0.0)
    near_goal_distance: float = param(0.5, ge=0.0)
    inflation_layer_name: str = ""
    trajectory_point_step: int = param(2, ge=1)


def cells_along(x, y, step, n, grid, origin_x, origin_y, resolution, out):
    """The costmap's cost at every ``step``-th pose of each trajectory (``out``, (batch, n)), to be compiled:
    Nav2's ``worldToMap`` in float32 (``origin_*`` and ``resolution`` float32); outside reads NO_INFORMATION."""
    size_y, size_x = grid.shape
    for i in range(x.shape[0]):
        for k in range(n):
            fx = (x[i, k * step] - origin_x) / resolution
            fy = (y[i, k * step] - origin_y) / resolution
            if fx >= 0 and fy >= 0 and fx < size_x and fy < size_y:
                out[i, k] = grid[int(fy), int(fx)]
            else:
                out[i, k] = NO_INFORMATION


def trajectory_costs(cost, checked, inscribed_collides, tracking, near_goal, near_collision, critical, collision, out):
    """Each trajectory's summed cost into ``out`` (float64), to be compiled; True when every trajectory
    collides. A point collides when its ``checked`` cost is LETHAL (or INSCRIBED, with
    ``inscribed_collides``; or NO_INFORMATION, unless ``tracking``) and its centre cost is not free;
    a colliding trajectory costs ``collision``; otherwise a point adds ``critical`` at or above
    ``near_collision``, else its cost (nothing when ``near_goal``)."""
    every = True
    for i in range(cost.shape[0]):
        total, hit = 0.0, False
        for k in range(cost.shape[1]):
            c, q = cost[i, k], checked[i, k]
            if c >= 1 and (
                q == LETHAL or (q == NO_INFORMATION and not tracking) or (inscribed_collides and q == INSCRIBED)
            ):
                hit = True
                break
            if c >= near_collision:
                total += critical
            elif not near_goal:
                total += float(c)
        out[i] = collision if hit else total
        every = every and hit
    return every


@functools.cache
def compiled_cost_kernels() -> dict[str, Callable[..., Any]]:
    """``cells_along`` and ``trajectory_costs`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (cells_along, trajectory_costs))


class CostCritic(Critic[CostCriticParams]):
    """Costmap cost along every ``trajectory_point_step``-th pose; collisions cost ``collision_cost``.

    Out of the map counts as NO_INFORMATION; free cells add nothing. A point in collision (LETHAL;
    INSCRIBED for a centre check; NO_INFORMATION unless unknown space is tracked) makes the whole
    trajectory cost ``collision_cost``; otherwise cells >= ``near_collision_cost`` add
    ``critical_cost`` and the others their cost (not near the goal). The sum is weighted by
    ``cost_weight / 254`` over the sampled length. Every trajectory in collision sets ``fail_flag``.
    With ``consider_footprint`` and a polygon footprint, points at or above the circumscribed cost
    are checked by the footprint's outline cost; a circular robot is checked by its centre (exact
    for a circle; Nav2 1.3.10 and later refuse that combination).
    """

    def __init__(self, p: CostCriticParams, mppi: MPPIParams, setup: ControllerSetup) -> None:
        super().__init__(p, mppi, setup)
        self.footprint = np.asarray(setup.footprint, dtype=np.float64).reshape(-1, 2)
        self.use_footprint = p.consider_footprint and len(self.footprint) >= 3

    def _circumscribed_cost(self, cm: CostmapGrid) -> float:
        """Nav2's ``findCircumscribedCost``: the inflation cost at the circumscribed radius (-1: no layer)."""
        layers = getattr(cm.params, "layers", {}) or {}
        name = self.p.inflation_layer_name
        infl = [
            lp
            for n, lp in layers.items()
            if isinstance(lp, InflationLayerParams) and (not name or n == name) and getattr(lp, "enabled", True)
        ]
        if not infl:
            return -1.0
        if infl[0].inflation_radius < cm.circumscribed_radius:
            return 0.0
        d = np.array([cm.circumscribed_radius / cm.resolution])
        return float(inflation_costs(d, cm.resolution, cm.inscribed_radius, infl[0].cost_scaling_factor)[0])

    def score(self, data: CriticData) -> None:
        cm = data.costmap
        if cm is None:
            return
        p = self.p
        step = p.trajectory_point_step
        n = data.x.shape[1] // step
        if n == 0:
            return
        kernels = compiled_cost_kernels()
        cost = np.empty((data.x.shape[0], n), dtype=np.uint8)
        f32 = np.float32
        kernels["cells_along"](
            data.x, data.y, step, n, cm.costs, f32(cm.origin_x), f32(cm.origin_y), f32(cm.resolution), cost
        )
        checked = cost
        if self.use_footprint:
            checked = cost.copy()
            possible = self._circumscribed_cost(cm)
            need = (cost >= 1) & ((cost >= possible) | (possible < 1.0))
            px, py, pyaw = (a[:, : n * step : step][need].astype(np.float64) for a in (data.x, data.y, data.yaw))
            c, s = np.cos(pyaw)[:, None], np.sin(pyaw)[:, None]
            fx, fy = self.footprint[:, 0], self.footprint[:, 1]
            placed = np.stack([px[:, None] + c * fx - s * fy, py[:, None] + s * fx + c * fy], axis=-1)
            checked[need] = footprint_costs(cm.costs, placed, cm.origin_x, cm.origin_y, cm.resolution)
        traj_cost = np.empty(data.x.shape[0])
        data.fail_flag = bool(
            kernels["trajectory_costs"](
                cost,
                checked,
                not self.use_footprint,
                bool(cm.params.track_unknown_space),
                data.robot_near_goal(p.near_goal_distance),
                p.near_collision_cost,
                p.critical_cost,
                p.collision_cost,
                traj_cost,
            )
        )
        self.add(data, traj_cost / n, p.cost_weight / 254.0)
