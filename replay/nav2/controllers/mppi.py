"""MPPI (``nav2_mppi_controller::MPPIController``, Jazzy): its parameters, its critics, its optimizer.

One controller cycle reads as Nav2's ``evalControl``:

1. **path handler**: the global plan is pruned behind the robot, cut at ``prune_distance`` of
   integrated length and at the first pose that leaves the local costmap, and moved into the
   costmap's frame; the goal is the plan's last pose;
2. **optimize**, ``iteration_count`` times: noise (one normal draw per axis and per batch row and
   time step, ``vx_std``/``vy_std``/``wz_std``, vy for Omni only) is added to the control sequence;
   the motion model clamps each noised control to what ``ax_max``/``ax_min``/``az_max`` allow from
   the one before (``predict``); the velocities are integrated into poses; every critic adds its
   cost; the sequence becomes the softmax-weighted (``temperature``, with the ``gamma`` control
   cost) mean of the noised sequences and is clipped by ``applyControlSequenceConstraints``;
3. **fallback**: when the CostCritic finds every trajectory in collision, the optimizer resets and
   retries; after ``retry_attempt_limit`` retries the cycle raises ``NoValidControl``;
4. the sequence is smoothed (Savitzky-Golay, with the 4 last commands as history), its element 0
   (1 when the control period equals ``model_dt``: the sequence is then shifted every cycle) is the
   command.

Noise comes from ``np.random.default_rng(setup.seed)`` only: the same seed, plan, poses and costmaps
give the same commands bit for bit. Nav2 draws with its own engine, so Nav2's numbers cannot be
reproduced draw for draw; the optimizer is checked with injected noise (``Optimizer.set_noises``)
and the critics with Nav2's unit-test vectors.

Each critic in ``critics`` has its section of the same name inside the controller's section,
read into its own parameter dataclass (``CRITICS``: name -> parameters, code). The batch's arrays
are float32 as Nav2's, shaped (batch, time_steps), and NumPy vectorised over the batch; the
sequential clamp of ``predict`` runs as a numba kernel (``clamp_rollouts``, the same bits as its
NumPy form, which runs where numba is missing).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.compiled import compile_together
from navlog.replay.config import suggest
from navlog.replay.nav2.controllers.base import (
    ControlContext,
    ControllerError,
    ControllerSetup,
    ControlResult,
    NoValidControl,
    Pose2D,
    Twist2D,
    first_after_integrated_distance,
    transform_poses,
)
from navlog.replay.nav2.costmap.cost_values import INSCRIBED, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import footprint_costs
from navlog.replay.nav2.costmap.grid import CostmapGrid
from navlog.replay.nav2.costmap.inflation_layer import InflationLayerParams, inflation_costs
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import ERROR, NOTE, WARNING, SectionReader, param

__all__ = [
    "CRITICS",
    "AckermannConstraintsParams",
    "ConstraintCriticParams",
    "CostCriticParams",
    "CriticData",
    "CriticParams",
    "GoalAngleCriticParams",
    "GoalCriticParams",
    "InvalidPath",
    "MPPIController",
    "MPPIParams",
    "ObstaclesCriticParams",
    "Optimizer",
    "PathAlignCriticParams",
    "PathAngleCriticParams",
    "PathFollowCriticParams",
    "PathHandler",
    "PreferForwardCriticParams",
    "TwirlingCriticParams",
    "VelocityDeadbandCriticParams",
]

# sections of MPPI's own parameters, not critics
OWN_SECTIONS = ("TrajectoryVisualizer", "AckermannConstraints")
F32 = np.float32  # the batch's arrays are float32, as Nav2's
SAVITZKY_GOLAY = np.array([-21.0, 14.0, 39.0, 54.0, 59.0, 54.0, 39.0, 14.0, -21.0]) / 231.0


# ====================================================================== parameters


@dataclass(frozen=True)
class CriticParams:
    """What every MPPI critic reads (``CriticFunction``): enabled, cost_power, cost_weight."""

    enabled: bool = True
    cost_power: int = param(1, ge=1)
    cost_weight: float = param(1.0, ge=0.0)


@dataclass(frozen=True)
class ConstraintCriticParams(CriticParams):
    cost_weight: float = param(4.0, ge=0.0)


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


@dataclass(frozen=True)
class ObstaclesCriticParams(CriticParams):
    """Read and checked; navlog runs the CostCritic (Nav2's default since Iron) instead."""

    consider_footprint: bool = False
    critical_weight: float = param(20.0, ge=0.0)
    repulsion_weight: float = param(1.5, ge=0.0)
    collision_cost: float = param(100000.0, ge=0.0)
    collision_margin_distance: float = param(0.10, ge=0.0)
    near_goal_distance: float = param(0.5, ge=0.0)
    inflation_layer_name: str = ""


@dataclass(frozen=True)
class GoalCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    threshold_to_consider: float = param(1.4, ge=0.0)


@dataclass(frozen=True)
class GoalAngleCriticParams(CriticParams):
    cost_weight: float = param(3.0, ge=0.0)
    threshold_to_consider: float = param(0.5, ge=0.0)
    symmetric_yaw_tolerance: bool = False


@dataclass(frozen=True)
class PathAlignCriticParams(CriticParams):
    cost_weight: float = param(10.0, ge=0.0)
    max_path_occupancy_ratio: float = param(0.07, ge=0.0)
    offset_from_furthest: int = param(20, ge=0)
    trajectory_point_step: int = param(4, ge=1)
    threshold_to_consider: float = param(0.5, ge=0.0)
    use_path_orientations: bool = False


@dataclass(frozen=True)
class PathFollowCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    offset_from_furthest: int = param(6, ge=0)
    threshold_to_consider: float = param(1.4, ge=0.0)


@dataclass(frozen=True)
class PathAngleCriticParams(CriticParams):
    cost_weight: float = param(2.2, ge=0.0)
    offset_from_furthest: int = param(4, ge=0)
    threshold_to_consider: float = param(0.5, ge=0.0)
    max_angle_to_furthest: float = param(0.785398, ge=0.0)
    mode: int = param(0, choices=(0, 1, 2))


@dataclass(frozen=True)
class PreferForwardCriticParams(CriticParams):
    cost_weight: float = param(5.0, ge=0.0)
    threshold_to_consider: float = param(0.5, ge=0.0)


@dataclass(frozen=True)
class TwirlingCriticParams(CriticParams):
    cost_weight: float = param(10.0, ge=0.0)


@dataclass(frozen=True)
class VelocityDeadbandCriticParams(CriticParams):
    cost_weight: float = param(35.0, ge=0.0)
    deadband_velocities: tuple[float, ...] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class AckermannConstraintsParams:
    min_turning_r: float = param(0.2, ge=0.0)


@dataclass(frozen=True)
class MPPIParams(PluginParams):
    """``nav2_mppi_controller::MPPIController`` parameters with its critics' (``critic_params``, by name).

    ``max_robot_pose_search_dist`` <= 0 means Nav2's default: half the local costmap's larger side.
    """

    plugin: str = "nav2_mppi_controller::MPPIController"
    time_steps: int = param(56, ge=1)
    model_dt: float = param(0.05, gt=0.0)
    batch_size: int = param(1000, ge=1)
    ax_max: float = param(3.0, ge=0.0)
    ax_min: float = param(-3.0, le=0.0)
    ay_max: float = param(3.0, ge=0.0)
    ay_min: float = param(-3.0, le=0.0)
    az_max: float = param(3.5, ge=0.0)
    vx_std: float = param(0.2, gt=0.0)
    vy_std: float = param(0.2, gt=0.0)
    wz_std: float = param(0.4, gt=0.0)
    vx_max: float = param(0.5, ge=0.0)
    vx_min: float = param(-0.35, le=0.0)
    vy_max: float = param(0.5, ge=0.0)
    wz_max: float = param(1.9, ge=0.0)
    iteration_count: int = param(1, ge=1)
    prune_distance: float = param(1.5, gt=0.0)
    max_robot_pose_search_dist: float = 0.0
    transform_tolerance: float = param(0.1, ge=0.0)
    temperature: float = param(0.3, gt=0.0)
    gamma: float = param(0.015, ge=0.0)
    motion_model: str = param("DiffDrive", choices=("DiffDrive", "Omni", "Ackermann"))
    visualize: bool = False
    regenerate_noises: bool = False
    retry_attempt_limit: int = param(1, ge=0)
    open_loop: bool = False
    enforce_path_inversion: bool = False
    critics: tuple[str, ...] = ()
    ackermann: AckermannConstraintsParams = field(default_factory=AckermannConstraintsParams)
    critic_params: dict[str, CriticParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "visualize",
        "enforce_path_inversion",
        "publish_optimal_trajectory",
        "publish_critics_stats",
        "inversion_xy_tolerance",
        "inversion_yaw_tolerance",
        "shift_control_sequence",
        "transform_tolerance",
    )

    @classmethod
    def read_loaded(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> MPPIParams:
        """The controller's parameters with each listed critic's section read and checked as its type."""
        sections = tuple(k for k, v in section.items() if isinstance(v, dict)) if isinstance(section, dict) else ()
        section = section if isinstance(section, dict) else {}
        obj = r.read(cls, section, path, sections=sections, extra={"plugin": plugin})
        ackermann = r.read(
            AckermannConstraintsParams, section.get("AckermannConstraints", {}), path + ("AckermannConstraints",)
        )
        if "TrajectoryVisualizer" in section:
            r.add(NOTE, path + ("TrajectoryVisualizer",), "read, not implemented by navlog")
        critic_params: dict[str, CriticParams] = {}
        for crit in obj.critics:
            ctype = CRITICS.get(crit.removeprefix("mppi::critics::"))
            if ctype is None:
                r.add(
                    ERROR,
                    path + ("critics",),
                    f"unknown MPPI critic '{crit}'{suggest(crit, list(CRITICS))}; Nav2 fails to load it at launch",
                )
                continue
            critic_params[crit] = r.read(ctype[0], section.get(crit, {}), path + (crit,))
        for crit in sections:
            if crit not in obj.critics and crit not in OWN_SECTIONS:
                r.add(
                    WARNING,
                    path + (crit,),
                    f"section '{crit}' is not in critics: MPPI ignores it{suggest(crit, obj.critics)}",
                )
        cc = critic_params.get("CostCritic")
        if isinstance(cc, CostCriticParams) and cc.near_collision_cost > 253:
            r.add(
                WARNING,
                path + ("CostCritic", "near_collision_cost"),
                f"{cc.near_collision_cost} is above 253 (inscribed): no cell reaches it, critical_cost is never added",
            )
        return dataclasses.replace(obj, ackermann=ackermann, critic_params=critic_params)


# ====================================================================== critics


@dataclass
class CriticData:
    """What the critics score (Nav2's ``CriticData``): the batch's velocities and poses, the path, the goal.

    ``vx``/``vy``/``wz`` and ``x``/``y``/``yaw`` are (batch, time_steps); column 0 of the velocities
    is the robot's speed. ``path`` is (N, 3) in the costmap frame. ``costs`` (batch,) is added to.
    ``furthest`` and ``path_valid`` are computed on first use (a test may set them).
    """

    pose: Pose2D
    goal: tuple[float, float]
    path: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    wz: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    model_dt: float
    costmap: CostmapGrid | None = None
    goal_xy_tolerance: float | None = None  # the goal checker's; None without one
    holonomic: bool = False
    costs: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fail_flag: bool = False
    furthest: int | None = None
    path_valid: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.costs.shape != (self.x.shape[0],):
            self.costs = np.zeros(self.x.shape[0])

    def robot_near_goal(self, radius: float) -> bool:
        """Nav2's ``withinPositionGoalTolerance``: robot-goal distance strictly below ``radius``."""
        dx, dy = self.pose[0] - self.goal[0], self.pose[1] - self.goal[1]
        return dx * dx + dy * dy < radius * radius

    def furthest_reached(self) -> int:
        """Nav2's ``findPathFurthestReachedPoint``: per trajectory (in order), the path index nearest its
        last point searched from the running maximum; the maximum over the batch."""
        if self.furthest is None:
            d = (self.path[None, :, 0] - self.x[:, -1:]) ** 2 + (self.path[None, :, 1] - self.y[:, -1:]) ** 2
            n = d.shape[1]
            # nearest[i, r]: first index of the minimum of d[i, r:] (a suffix minimum and the next index holding it)
            suffix_min = np.minimum.accumulate(d[:, ::-1], axis=1)[:, ::-1]
            holds = np.where(d == suffix_min, np.arange(n), n)
            nearest = np.minimum.accumulate(holds[:, ::-1], axis=1)[:, ::-1]
            # r_i = nearest[i, r_(i-1)] from r = 0: compose the rows pairwise (the earlier row applied first)
            while len(nearest) > 1:
                if len(nearest) % 2:
                    nearest = np.vstack([nearest, np.arange(n)])
                nearest = np.take_along_axis(nearest[1::2], nearest[0::2], axis=1)
            self.furthest = int(nearest[0, 0])
        return self.furthest

    def path_points_valid(self) -> np.ndarray:
        """Nav2's ``findPathCosts``: per path point but the last, in the map and not lethal, inscribed or
        (unless unknown space is tracked) unknown."""
        if self.path_valid is None:
            pts = self.path[:-1]
            if self.costmap is None:
                self.path_valid = np.ones(len(pts), dtype=bool)
            else:
                cost, inside = _map_costs(self.costmap, pts[:, 0], pts[:, 1])
                tracking = bool(self.costmap.params.track_unknown_space)
                bad = (cost == LETHAL) | (cost == INSCRIBED) | ((cost == NO_INFORMATION) & (not tracking))
                self.path_valid = inside & ~bad
        return self.path_valid


def _map_costs(cm: CostmapGrid, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(costs, inside) at world points as Nav2's ``worldToMap``; outside points read NO_INFORMATION."""
    fx = (np.asarray(x) - cm.origin_x) / cm.resolution
    fy = (np.asarray(y) - cm.origin_y) / cm.resolution
    inside = (fx >= 0) & (fy >= 0) & (fx < cm.size_x) & (fy < cm.size_y)
    mx = np.where(inside, fx, 0).astype(np.int64)
    my = np.where(inside, fy, 0).astype(np.int64)
    return np.where(inside, cm.costs[my, mx], NO_INFORMATION), inside


def _angle_diff(a: Any, b: Any) -> Any:
    """Nav2's ``shortest_angular_distance(a, b)``: b - a wrapped to [-pi, pi)."""
    t = np.fmod(np.asarray(b) - np.asarray(a) + np.pi, 2.0 * np.pi)
    return np.where(t < 0.0, t + np.pi, t - np.pi)


class Critic:
    """One critic: built from its parameters and the controller's; ``score`` adds to ``data.costs``."""

    def __init__(self, p: CriticParams, mppi: MPPIParams, setup: ControllerSetup) -> None:
        self.p = p

    def add(self, data: CriticData, cost: np.ndarray, weight: float | None = None) -> None:
        """``data.costs += (cost * weight) ** cost_power`` (the power only when above 1), as every critic."""
        w = self.p.cost_weight if weight is None else weight
        data.costs += (cost * w) ** self.p.cost_power if self.p.cost_power > 1 else cost * w

    def score(self, data: CriticData) -> None:  # pragma: no cover - every critic overrides it
        raise NotImplementedError


class ConstraintCritic(Critic):
    """Speeds beyond the limits, integrated over time (Ackermann: turns tighter than min_turning_r too).

    The limits are those the controller declares: ``vmax = hypot(vx_max, vy_max)`` even for DiffDrive.
    """

    def __init__(self, p: CriticParams, mppi: MPPIParams, setup: ControllerSetup) -> None:
        super().__init__(p, mppi, setup)
        self.max_vel = math.hypot(mppi.vx_max, mppi.vy_max)
        self.min_vel = math.copysign(math.hypot(mppi.vx_min, mppi.vy_max), 1.0 if mppi.vx_min > 0 else -1.0)
        self.model = mppi.motion_model
        self.min_turning_r = mppi.ackermann.min_turning_r

    def score(self, data: CriticData) -> None:
        v = np.where(data.vx > 0.0, 1.0, -1.0) * np.hypot(data.vx, data.vy) if self.model == "Omni" else data.vx
        out = np.maximum(v - self.max_vel, 0.0) + np.maximum(self.min_vel - v, 0.0)
        if self.model == "Ackermann":
            with np.errstate(divide="ignore", invalid="ignore"):
                out = out + np.maximum(self.min_turning_r - np.abs(data.vx) / np.abs(data.wz), 0.0)
        self.add(data, (out * data.model_dt).sum(axis=1))


class CostCritic(Critic):
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

    def __init__(self, p: CriticParams, mppi: MPPIParams, setup: ControllerSetup) -> None:
        super().__init__(p, mppi, setup)
        assert isinstance(p, CostCriticParams)
        self.cp = p
        self.footprint = np.asarray(setup.footprint, dtype=np.float64).reshape(-1, 2)
        self.use_footprint = p.consider_footprint and len(self.footprint) >= 3

    def _circumscribed_cost(self, cm: CostmapGrid) -> float:
        """Nav2's ``findCircumscribedCost``: the inflation cost at the circumscribed radius (-1: no layer)."""
        layers = getattr(cm.params, "layers", {}) or {}
        name = self.cp.inflation_layer_name
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
        step = self.cp.trajectory_point_step
        n = data.x.shape[1] // step
        if n == 0:
            return
        tx, ty, tyaw = data.x[:, : n * step : step], data.y[:, : n * step : step], data.yaw[:, : n * step : step]
        cost, _ = _map_costs(cm, tx, ty)
        tracking = bool(cm.params.track_unknown_space)
        checked = cost.copy()
        if self.use_footprint:
            possible = self._circumscribed_cost(cm)
            need = (cost >= 1) & ((cost >= possible) | (possible < 1.0))
            px, py, pyaw = (a[need].astype(np.float64) for a in (tx, ty, tyaw))
            c, s = np.cos(pyaw)[:, None], np.sin(pyaw)[:, None]
            fx, fy = self.footprint[:, 0], self.footprint[:, 1]
            placed = np.stack([px[:, None] + c * fx - s * fy, py[:, None] + s * fx + c * fy], axis=-1)
            checked[need] = footprint_costs(cm.costs, placed, cm.origin_x, cm.origin_y, cm.resolution)
        collide = (checked == LETHAL) | ((checked == NO_INFORMATION) & (not tracking))
        if not self.use_footprint:
            collide |= checked == INSCRIBED
        collide &= cost >= 1
        near_goal = data.robot_near_goal(self.cp.near_goal_distance)
        add = np.where(cost >= self.cp.near_collision_cost, self.cp.critical_cost, 0.0 if near_goal else cost)
        any_collide = collide.any(axis=1)
        traj_cost = np.where(any_collide, self.cp.collision_cost, add.sum(axis=1))
        self.add(data, traj_cost / n, self.cp.cost_weight / 254.0)
        data.fail_flag = bool(any_collide.all())


class GoalCritic(Critic):
    """Mean distance of the trajectory to the goal, once the robot is within threshold_to_consider."""

    def score(self, data: CriticData) -> None:
        assert isinstance(self.p, GoalCriticParams)
        if not data.robot_near_goal(self.p.threshold_to_consider):
            return
        self.add(data, np.hypot(data.x - data.goal[0], data.y - data.goal[1]).mean(axis=1))


class GoalAngleCritic(Critic):
    """Mean heading error to the path's last yaw, once the robot is within threshold_to_consider."""

    def score(self, data: CriticData) -> None:
        p = self.p
        assert isinstance(p, GoalAngleCriticParams)
        if not data.robot_near_goal(p.threshold_to_consider):
            return
        goal_yaw = float(data.path[-1, 2])
        d = np.abs(_angle_diff(data.yaw, goal_yaw))
        if p.symmetric_yaw_tolerance:
            flipped = math.remainder(goal_yaw + math.pi, 2 * math.pi)
            d = np.minimum(d, np.abs(_angle_diff(data.yaw, flipped)))
        self.add(data, d.mean(axis=1))


class PathAlignCritic(Critic):
    """Mean distance of sampled trajectory points to the path point at the same integrated length."""

    def score(self, data: CriticData) -> None:
        p = self.p
        assert isinstance(p, PathAlignCriticParams)
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
        step = p.trajectory_point_step
        tx, ty, tyaw = data.x[:, ::step], data.y[:, ::step], data.yaw[:, ::step]
        traj_len = np.cumsum(np.hypot(np.diff(tx, axis=1), np.diff(ty, axis=1)), axis=1)
        # Nav2's findClosestPathPt, searched from the previous answer: the running maximum of the global one
        i = np.searchsorted(along, traj_len, side="right")
        last = len(along) - 1
        ic = np.minimum(i, last)
        prev = along[np.maximum(ic - 1, 0)]
        nearest = np.where(i > last, last, np.where(traj_len - prev < along[ic] - traj_len, ic - 1, ic))
        nearest = np.maximum.accumulate(nearest, axis=1)
        ok = valid[nearest]
        dx, dy = path[nearest, 0] - tx[:, 1:], path[nearest, 1] - ty[:, 1:]
        if p.use_path_orientations:
            dyaw = _angle_diff(path[nearest, 2], tyaw[:, 1:])
            dist = np.sqrt(dx * dx + dy * dy + dyaw * dyaw)
        else:
            dist = np.sqrt(dx * dx + dy * dy)
        samples = ok.sum(axis=1)
        total = np.where(ok, dist, 0.0).sum(axis=1)
        self.add(data, np.where(samples > 0, total / np.maximum(samples, 1), 0.0))


class PathFollowCritic(Critic):
    """Distance of the trajectory's end to the path point ``offset_from_furthest`` ahead of the furthest reached."""

    def score(self, data: CriticData) -> None:
        p = self.p
        assert isinstance(p, PathFollowCriticParams)
        if len(data.path) < 2 or data.robot_near_goal(p.threshold_to_consider):
            return
        furthest = data.furthest_reached()
        valid = data.path_points_valid()
        size = len(data.path) - 1
        idx = min(furthest + p.offset_from_furthest, size)
        while idx < size - 1 and not valid[idx]:
            idx += 1
        self.add(data, np.hypot(data.x[:, -1] - data.path[idx, 0], data.y[:, -1] - data.path[idx, 1]))


def _pose_point_angle(pose: Pose2D, px: float, py: float, mode: int, point_yaw: float) -> float:
    """Nav2's ``posePointAngle``: the robot's heading error to a point (mode 1: either way; 2: along point_yaw)."""
    yaw = math.atan2(py - pose[1], px - pose[0])
    if mode == 2:
        if abs(float(_angle_diff(yaw, point_yaw))) > math.pi / 2:
            yaw = math.remainder(yaw + math.pi, 2 * math.pi)
        return abs(float(_angle_diff(yaw, pose[2])))
    fwd = abs(float(_angle_diff(yaw, pose[2])))
    if mode == 1:
        return min(fwd, abs(float(_angle_diff(yaw, math.remainder(pose[2] + math.pi, 2 * math.pi)))))
    return fwd


class PathAngleCritic(Critic):
    """Heading error of the trajectory's end to a path point ahead, when the robot faces away from it."""

    def __init__(self, p: CriticParams, mppi: MPPIParams, setup: ControllerSetup) -> None:
        super().__init__(p, mppi, setup)
        assert isinstance(p, PathAngleCriticParams)
        reversing = abs(mppi.vx_min) >= 1e-6 and mppi.vx_min < 0.0
        self.mode = 0 if (p.mode == 1 and not reversing) else p.mode

    def score(self, data: CriticData) -> None:
        p = self.p
        assert isinstance(p, PathAngleCriticParams)
        if data.robot_near_goal(p.threshold_to_consider):
            return
        idx = min(data.furthest_reached() + p.offset_from_furthest, len(data.path) - 1)
        gx, gy, gyaw = (float(v) for v in data.path[idx])
        if _pose_point_angle(data.pose, gx, gy, self.mode, gyaw) < p.max_angle_to_furthest:
            return
        between = np.arctan2(gy - data.y[:, -1], gx - data.x[:, -1])
        end_yaw = data.yaw[:, -1]
        if self.mode == 1:
            fwd = np.abs(_angle_diff(end_yaw, between))
            between = np.where(fwd < math.pi / 2, between, _angle_diff(-math.pi, between))
        elif self.mode == 2:
            away = np.abs(_angle_diff(between, gyaw)) >= math.pi / 2
            between = np.where(away, _angle_diff(-math.pi, between), between)
        self.add(data, np.abs(_angle_diff(end_yaw, between)))


class PreferForwardCritic(Critic):
    """Reverse speed integrated over time, except within threshold_to_consider of the goal."""

    def score(self, data: CriticData) -> None:
        assert isinstance(self.p, PreferForwardCriticParams)
        if data.robot_near_goal(self.p.threshold_to_consider):
            return
        self.add(data, (np.maximum(-data.vx, 0.0) * data.model_dt).sum(axis=1))


class TwirlingCritic(Critic):
    """Mean |wz|, except inside the goal checker's xy tolerance."""

    def score(self, data: CriticData) -> None:
        if data.goal_xy_tolerance is not None and data.robot_near_goal(data.goal_xy_tolerance):
            return
        self.add(data, np.abs(data.wz).mean(axis=1))


class VelocityDeadbandCritic(Critic):
    """Speeds inside the deadband (per axis, vy for Omni only), integrated over time."""

    def score(self, data: CriticData) -> None:
        assert isinstance(self.p, VelocityDeadbandCriticParams)
        db = [abs(v) for v in (tuple(self.p.deadband_velocities) + (0.0, 0.0, 0.0))[:3]]
        out = np.maximum(db[0] - np.abs(data.vx), 0.0) + np.maximum(db[2] - np.abs(data.wz), 0.0)
        if data.holonomic:
            out = out + np.maximum(db[1] - np.abs(data.vy), 0.0)
        self.add(data, (out * data.model_dt).sum(axis=1))


CRITICS: dict[str, tuple[type[CriticParams], type[Critic] | None]] = {
    "ConstraintCritic": (ConstraintCriticParams, ConstraintCritic),
    "CostCritic": (CostCriticParams, CostCritic),
    "GoalCritic": (GoalCriticParams, GoalCritic),
    "GoalAngleCritic": (GoalAngleCriticParams, GoalAngleCritic),
    "ObstaclesCritic": (ObstaclesCriticParams, None),
    "PathAlignCritic": (PathAlignCriticParams, PathAlignCritic),
    "PathAngleCritic": (PathAngleCriticParams, PathAngleCritic),
    "PathFollowCritic": (PathFollowCriticParams, PathFollowCritic),
    "PreferForwardCritic": (PreferForwardCriticParams, PreferForwardCritic),
    "TwirlingCritic": (TwirlingCriticParams, TwirlingCritic),
    "VelocityDeadbandCritic": (VelocityDeadbandCriticParams, VelocityDeadbandCritic),
}
"""Critic name as ``critics`` lists it -> (its parameters, its code; None: read and checked, not run)."""


def build_critics(params: MPPIParams, setup: ControllerSetup) -> list[Critic]:
    """The enabled critics of ``params.critics``, in order (ConfigError for one navlog does not run)."""
    out: list[Critic] = []
    for name in params.critics:
        entry = CRITICS.get(name.removeprefix("mppi::critics::"))
        if entry is None:
            raise ConfigError(f"unknown MPPI critic '{name}'{suggest(name, list(CRITICS))}")
        ptype, ctype = entry
        if ctype is None:
            runnable = ", ".join(n for n, (_, c) in CRITICS.items() if c is not None)
            raise ConfigError(f"MPPI critic '{name}' is read, not implemented by navlog; use one of {runnable}")
        p = params.critic_params.get(name, ptype())
        if p.enabled:
            out.append(ctype(p, params, setup))
    return out


# ====================================================================== optimizer


def clamp_rollouts(cv, state, axes, ups, downs):
    """``Optimizer.predict`` compiled: per axis in ``axes`` and per rollout, each control clamped to
    [last + down, last + up] (reverse: [last - up, last - down]; axis 2, wz, always the former) from
    the one before, in float64 and stored as float32, exactly as the NumPy version."""
    nb, nt = cv.shape[1], cv.shape[2]
    for k in range(axes.shape[0]):
        a = axes[k]
        up, down = ups[a], downs[a]
        for i in range(nb):
            last = float(state[a, i, 0])
            for j in range(1, nt):
                if a == 2 or last > 0:
                    lo, hi = last + down, last + up
                else:
                    lo, hi = last - up, last - down
                cv[a, i, j - 1] = min(max(float(cv[a, i, j - 1]), lo), hi)
                last = float(cv[a, i, j - 1])
                state[a, i, j] = cv[a, i, j - 1]


@functools.cache
def _kernels() -> Any:
    """``clamp_rollouts`` compiled by numba (cached on disk), or None where numba is missing."""
    compiled = compile_together(globals(), (clamp_rollouts,))
    return None if compiled is None else compiled["clamp_rollouts"]


class Optimizer:
    """Nav2's MPPI ``Optimizer``: the control sequence, its noise, the motion model, the critics.

    ``eval_control`` is one cycle (see the module docstring). ``set_noises`` replaces the noise
    (tests inject fixed noise); otherwise noise is drawn at reset and, with ``regenerate_noises``,
    again after each use.
    """

    def __init__(self, params: MPPIParams, setup: ControllerSetup, critics: list[Critic]) -> None:
        self.p = params
        self.critics = critics
        self.rng = np.random.default_rng(setup.seed)
        self.holonomic = params.motion_model == "Omni"
        period = 1.0 / setup.controller_frequency
        if period + 1e-6 < params.model_dt:
            self.shift = False
        elif abs(period - params.model_dt) < 1e-6:
            self.shift = True
        else:
            raise ConfigError(
                f"MPPI: the controller period 1/controller_frequency = {period:g} s is longer than model_dt "
                f"{params.model_dt:g} s; Nav2 refuses it ('Controller period more then model dt'): set "
                f"controller_frequency to {1.0 / params.model_dt:g} Hz or model_dt to {period:g}"
            )
        self.set_speed_limit(0.0, True)
        self._fail_count = 0
        self._injected: np.ndarray | None = None
        self._path_facts: tuple[int | None, np.ndarray | None] = (None, None)
        self.last_cmd: Twist2D = (0.0, 0.0, 0.0)
        self.reset()

    # -------------------------------------------------------- state
    def reset(self) -> None:
        """Zero control sequence and history, fresh noise (Nav2's ``reset``; speed limits are kept)."""
        b, t = self.p.batch_size, self.p.time_steps
        self.u = np.zeros((3, t), dtype=F32)  # vx, vy, wz
        self.history = np.zeros((4, 3), dtype=F32)
        self.costs = np.zeros(b, dtype=F32)
        if self.p.open_loop:
            self.last_cmd = (0.0, 0.0, 0.0)
        if self._injected is None:
            self.noises = np.zeros((3, b, t), dtype=F32)
            self._generate_noises()
        self.trajectories = np.zeros((3, b, t), dtype=F32)

    def _generate_noises(self) -> None:
        b, t = self.p.batch_size, self.p.time_steps
        for axis, std in ((0, self.p.vx_std), (2, self.p.wz_std)) + (((1, self.p.vy_std),) if self.holonomic else ()):
            self.noises[axis] = self.rng.standard_normal((b, t), dtype=F32)
            self.noises[axis] *= F32(std)

    def set_noises(self, vx: np.ndarray, vy: np.ndarray, wz: np.ndarray) -> None:
        """Use this noise (each (batch, time_steps)) from now on, instead of drawn noise."""
        shape = (self.p.batch_size, self.p.time_steps)
        self._injected = np.stack([np.broadcast_to(np.asarray(a, dtype=F32), shape) for a in (vx, vy, wz)])
        self.noises = self._injected

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2's ``setSpeedLimit``: 0 restores the limits, else scale vx, vy and wz by pct/100 or limit/vx_max."""
        p = self.p
        if limit == 0.0:
            ratio = 1.0
        elif percentage:
            ratio = limit / 100.0
        else:
            ratio = limit / p.vx_max
        self.vx_max, self.vx_min = p.vx_max * ratio, p.vx_min * ratio
        self.vy_max, self.wz_max = p.vy_max * ratio, p.wz_max * ratio

    # -------------------------------------------------------- one cycle
    def eval_control(
        self,
        pose: Pose2D,
        speed: Twist2D,
        path: np.ndarray,
        goal: tuple[float, float],
        costmap: CostmapGrid | None,
        goal_xy_tolerance: float | None = None,
    ) -> Twist2D:
        """The command for this cycle (Nav2's ``evalControl``); NoValidControl after the retries."""
        speed = self.last_cmd if self.p.open_loop else speed
        self._path_facts = (None, None)
        while True:
            data = self._optimize(pose, speed, path, goal, costmap, goal_xy_tolerance)
            if not self._fallback(data.fail_flag):
                break
        self._smooth()
        k = 1 if self.shift else 0
        cmd = (float(self.u[0, k]), float(self.u[1, k]) if self.holonomic else 0.0, float(self.u[2, k]))
        self.last_cmd = cmd
        if self.shift:
            self.u[:, :-1] = self.u[:, 1:].copy()
            self.u[:, -1] = self.u[:, -2]
        return cmd

    def _optimize(self, pose, speed, path, goal, costmap, goal_xy_tolerance) -> CriticData:
        data = None
        self.costs = np.zeros(self.p.batch_size, dtype=F32)
        for _ in range(self.p.iteration_count):
            cv, state = self._noised_controls(speed)
            self.trajectories = self.integrate(pose, state)
            data = CriticData(
                pose=pose,
                goal=goal,
                path=path,
                vx=state[0],
                vy=state[1],
                wz=state[2],
                x=self.trajectories[0],
                y=self.trajectories[1],
                yaw=self.trajectories[2],
                model_dt=self.p.model_dt,
                costmap=costmap,
                goal_xy_tolerance=goal_xy_tolerance,
                holonomic=self.holonomic,
                costs=self.costs,
                furthest=self._path_facts[0],
                path_valid=self._path_facts[1],
            )
            for critic in self.critics:
                critic.score(data)
            # as Nav2, the furthest reached path point and the path's validity are found once a cycle
            self._path_facts = (data.furthest, data.path_valid)
            self._update_control_sequence(cv)
        assert data is not None
        return data

    def _noised_controls(self, speed: Twist2D) -> tuple[np.ndarray, np.ndarray]:
        """(cv, state): noised controls clamped by ``predict``, and state velocities (column 0 = speed)."""
        cv = self.u[:, None, :] + self.noises
        if self.p.regenerate_noises and self._injected is None:
            self._generate_noises()
        state = self.predict(cv, speed)
        return cv, state

    def predict(self, cv: np.ndarray, speed: Twist2D) -> np.ndarray:
        """Nav2's ``MotionModel::predict``: each control clamped to the acceleration limits from the one
        before, starting from ``speed``; ``cv`` (3, B, T) is clamped in place, the state (3, B, T) returned.
        """
        p, dt = self.p, self.p.model_dt
        state = np.zeros_like(cv)
        t = cv.shape[2]
        state[0, :, 0], state[1, :, 0], state[2, :, 0] = speed[0], speed[1] if self.holonomic else 0.0, speed[2]
        axes: list[tuple[int, float, float]] = [(0, p.ax_max, p.ax_min), (2, p.az_max, -p.az_max)]
        if self.holonomic:
            axes.insert(1, (1, p.ay_max, p.ay_min))
        compiled = _kernels()
        if compiled is not None:
            ups, downs = np.zeros(3), np.zeros(3)
            for a, amax, amin in axes:
                ups[a], downs[a] = amax * dt, amin * dt
            compiled(cv, state, np.array([a for a, _, _ in axes], dtype=np.int64), ups, downs)
            return state
        for a, amax, amin in axes:
            col = np.ascontiguousarray(cv[a].T)  # (T, B): one row per time step
            last = state[a, :, 0].copy()
            up, down = amax * dt, amin * dt
            for j in range(1, t):
                last64 = last.astype(np.float64)  # bounds in float64, as the compiled kernel
                if a == 2:  # wz: symmetric, whatever the sign
                    lo, hi = last64 + down, last64 + up
                else:  # forward: accelerate by up, slow by down; reverse: mirrored
                    fwd = last > 0
                    lo = last64 + np.where(fwd, down, -up)
                    hi = last64 + np.where(fwd, up, -down)
                np.clip(col[j - 1], lo, hi, out=col[j - 1])
                last = col[j - 1]
            cv[a] = col.T
            state[a, :, 1:] = cv[a, :, :-1]
        return state

    def integrate(self, pose: Pose2D, state: np.ndarray) -> np.ndarray:
        """Nav2's ``integrateStateVelocities``: (x, y, yaw) (3, B, T); step j moves along the yaw of step j-1."""
        dt = self.p.model_dt
        vx, vy, wz = state
        yaw = pose[2] + np.cumsum(wz * dt, axis=-1)
        c = np.empty_like(yaw)
        s = np.empty_like(yaw)
        c[..., 0], s[..., 0] = math.cos(pose[2]), math.sin(pose[2])
        np.cos(yaw[..., :-1], out=c[..., 1:])
        np.sin(yaw[..., :-1], out=s[..., 1:])
        dx, dy = vx * c, vx * s
        if self.holonomic:
            dx, dy = dx - vy * s, dy + vy * c
        x = pose[0] + np.cumsum(dx * dt, axis=-1)
        y = pose[1] + np.cumsum(dy * dt, axis=-1)
        return np.stack([x, y, yaw])

    def _update_control_sequence(self, cv: np.ndarray) -> None:
        """Nav2's ``updateControlSequence``: control cost, softmax over the batch, weighted mean, constraints."""
        p = self.p
        axes = (0, 1, 2) if self.holonomic else (0, 2)
        std = (p.vx_std, p.vy_std, p.wz_std)
        for a in axes:
            self.costs += p.gamma / std[a] ** 2 * ((cv[a] - self.u[a]) @ self.u[a])
        w = np.exp(-(self.costs - self.costs.min()) / p.temperature)
        w /= w.sum()
        for a in axes:
            self.u[a] = w @ cv[a]
        self.apply_constraints()

    def apply_constraints(self) -> None:
        """Nav2's ``applyControlSequenceConstraints``: clip to the speed limits, then the acceleration
        limits along the sequence, then (Ackermann) no turn tighter than min_turning_r."""
        p, dt, u = self.p, self.p.model_dt, self.u
        if self.holonomic:
            np.clip(u[1], -self.vy_max, self.vy_max, out=u[1])
        np.clip(u[0], self.vx_min, self.vx_max, out=u[0])
        np.clip(u[2], -self.wz_max, self.wz_max, out=u[2])
        vx, vy, wz = u[0].tolist(), u[1].tolist(), u[2].tolist()
        for i in range(1, len(vx)):
            vx[i] = _accel_clamp(vx[i], vx[i - 1], p.ax_max * dt, p.ax_min * dt)
            wz[i] = min(max(wz[i], wz[i - 1] - p.az_max * dt), wz[i - 1] + p.az_max * dt)
            if self.holonomic:
                vy[i] = _accel_clamp(vy[i], vy[i - 1], p.ay_max * dt, p.ay_min * dt)
        u[0], u[1], u[2] = vx, vy, wz
        if p.motion_model == "Ackermann":
            r = p.ackermann.min_turning_r
            with np.errstate(divide="ignore", invalid="ignore"):
                tight = np.abs(u[0]) / np.abs(u[2]) < r
            u[2] = np.where(tight, np.sign(u[2]) * np.abs(u[0]) / r, u[2])

    def _fallback(self, fail: bool) -> bool:
        """Nav2's ``fallback``: on failure reset and retry, up to retry_attempt_limit times in a row."""
        if not fail:
            self._fail_count = 0
            return False
        self.reset()
        self._fail_count += 1
        if self._fail_count > self.p.retry_attempt_limit:
            self._fail_count = 0
            raise NoValidControl("MPPI: optimizer fail to compute path (every trajectory collides)")
        return True

    def _smooth(self) -> None:
        """Nav2's ``savitskyGolayFilter`` over all but the last control, the 4 last commands as history."""
        t = self.p.time_steps
        if t - 1 < 20:
            return
        for a in range(3):
            padded = np.concatenate([self.history[:, a], self.u[a], np.repeat(self.u[a, -1], 4)])
            self.u[a, :-1] = np.correlate(padded, SAVITZKY_GOLAY, mode="valid")[: t - 1]
        k = 1 if self.shift else 0
        self.history[:-1] = self.history[1:].copy()
        self.history[-1] = self.u[:, k]


def _accel_clamp(v: float, last: float, up: float, down: float) -> float:
    """Clamp ``v`` to what an acceleration of ``up`` and a deceleration of ``down`` (<= 0) allow from ``last``."""
    if last > 0:
        return min(max(v, last + down), last + up)
    return min(max(v, last - up), last - down)


# ====================================================================== path handler


class InvalidPath(ControllerError):
    """The plan cannot be followed (Nav2's ``InvalidPath``, FollowPath code 103)."""

    code = 103


class PathHandler:
    """Nav2's MPPI ``PathHandler``: the global plan pruned behind the robot and the part of it the
    optimizer follows, in the costmap frame."""

    def __init__(self, params: MPPIParams) -> None:
        self.p = params
        self.plan = np.zeros((0, 3))

    def set_path(self, path: np.ndarray) -> None:
        self.plan = np.asarray(path, dtype=np.float64).reshape(-1, 3).copy()

    def goal(self, global_to_local: np.ndarray) -> Pose2D:
        """The plan's last pose in the costmap frame."""
        if len(self.plan) == 0:
            raise InvalidPath("MPPI: received plan with zero length")
        g = transform_poses(self.plan[-1:], global_to_local)[0]
        return float(g[0]), float(g[1]), float(g[2])

    def transform_path(self, pose: Pose2D, global_to_local: np.ndarray, costmap: CostmapGrid) -> np.ndarray:
        """The plan from the pose closest to the robot up to ``prune_distance`` of integrated length, cut
        at the first pose outside the costmap, in the costmap frame (N, 3); the plan behind is dropped."""
        if len(self.plan) == 0:
            raise InvalidPath("MPPI: received plan with zero length")
        robot = transform_poses(np.array([pose], dtype=np.float64), np.linalg.inv(global_to_local))[0]
        search = self.p.max_robot_pose_search_dist
        if search <= 0.0:
            search = max(costmap.size_x, costmap.size_y) * costmap.resolution * 0.5
        upper = first_after_integrated_distance(self.plan, search)
        d = np.hypot(self.plan[:upper, 0] - robot[0], self.plan[:upper, 1] - robot[1])
        closest = int(np.argmin(d)) if upper > 0 else 0
        end = first_after_integrated_distance(self.plan, self.p.prune_distance, closest)
        local = transform_poses(self.plan[closest:end], global_to_local)
        _, inside = _map_costs(costmap, local[:, 0], local[:, 1])
        out = np.nonzero(~inside)[0]
        if len(out):
            local = local[: out[0]]
        self.plan = self.plan[closest:]
        if len(local) == 0:
            raise InvalidPath("MPPI: resulting plan has 0 poses in it (the plan is off the local costmap)")
        return local


# ====================================================================== the controller


class MPPIController:
    """``nav2_mppi_controller::MPPIController`` as a navlog ``Controller`` (see ``base``)."""

    def __init__(self, params: MPPIParams, setup: ControllerSetup) -> None:
        self.params = params
        self.setup = setup
        self.critics = build_critics(params, setup)
        self.optimizer = Optimizer(params, setup, self.critics)
        self.path_handler = PathHandler(params)

    def set_plan(self, path: np.ndarray) -> None:
        self.path_handler.set_path(path)

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2's speed limit: a percentage of the maximum speeds, or an absolute vx limit; 0 removes it."""
        self.optimizer.set_speed_limit(limit, percentage)

    def reset(self) -> None:
        self.optimizer.reset()
        self.optimizer.set_speed_limit(0.0, True)

    def compute_velocity_commands(self, pose: Pose2D, velocity: Twist2D, ctx: ControlContext) -> ControlResult:
        goal = self.path_handler.goal(ctx.global_to_local)
        local = self.path_handler.transform_path(pose, ctx.global_to_local, ctx.costmap)
        tol = getattr(ctx.goal_checker, "xy_goal_tolerance", None) if ctx.goal_checker is not None else None
        cmd = self.optimizer.eval_control(
            pose, velocity, local, (goal[0], goal[1]), ctx.costmap, None if tol is None else float(tol)
        )
        traj = self.optimizer.trajectories
        return ControlResult(cmd=cmd, local_plan=local, trajectories=np.stack([traj[0], traj[1]], axis=-1)[::5, ::3])
