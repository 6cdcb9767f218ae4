"""DWB's trajectory critics (``dwb_critics``), each scoring all of a cycle's trajectories at once.

A critic is prepared once per cycle (``prepare``: the robot pose and twist, the goal and the
transformed plan, all in the costmap frame), then ``score`` returns, per trajectory, its raw score
and whether the critic makes it illegal (Nav2's ``IllegalTrajectoryException``). The planner adds
``scale(cycle) · score`` over its critics, in their order, and keeps the lowest legal total.
``debrief`` sees the command chosen (Oscillation keeps its history there). Costs and distances are
in the costmap's cells, as Nav2's:

- BaseObstacle: the cost of the cell under each pose; off the grid, LETHAL, INSCRIBED or
  NO_INFORMATION is illegal. Score: the last pose's cost (or their sum with ``sum_scores``).
- ObstacleFootprint: the highest cost along the footprint's outline (``footprint_costs``); a vertex
  off the grid, LETHAL or NO_INFORMATION on the outline is illegal; scale x resolution.
- PathDist / GoalDist: grid distances to the plan's cells (or to its last cell on the costmap):
  the plan, densified to the costmap's resolution, from its first pose on known costmap cells up
  to where it leaves them; each cell holds the Manhattan distance (cells) to the source cell
  nearest it, as the costmap queue propagates it from the sources nearest first. A pose on a cell
  nothing reaches (no plan on the costmap) is illegal; ``aggregation_type`` last / sum / product;
  scale x resolution / 2.
- PathAlign / GoalAlign: the same distances at the point ``forward_point_distance`` ahead of the
  last pose (GoalAlign's target is the plan's end moved that far on along the robot->goal
  direction); PathAlign's scale is 0 within ``forward_point_distance`` of the goal.
- RotateToGoal: 0 until the robot comes within the plugin's ``xy_goal_tolerance`` of the goal;
  then it must slow down (a trajectory not slower than the current speed is illegal; score
  speed² · slowing_factor + |yaw error at the end|) and, once slower than
  ``trans_stopped_velocity``, only rotate (translating is illegal; score |yaw error|). Both
  latch until the plan changes.
- Oscillation: a command reversing the sign of an axis that already flipped is illegal, until the
  robot has moved ``oscillation_reset_dist`` or turned ``oscillation_reset_angle``.
- PreferForward: ``penalty`` for reversing or for turning in place slowly, else |wz| · theta_scale.
- Twirling: |wz|.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from navlog.replay.geometry import wrap_angles
from navlog.replay.nav2.controllers.dwb.params import (
    BaseObstacleParams,
    CriticParams,
    GoalAlignParams,
    GoalDistParams,
    MapGridParams,
    ObstacleFootprintParams,
    OscillationParams,
    PathAlignParams,
    PathDistParams,
    PreferForwardParams,
    RotateToGoalParams,
    TwirlingParams,
)
from navlog.replay.nav2.controllers.dwb.trajectories import Trajectories
from navlog.replay.nav2.costmap.cost_values import INSCRIBED, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import footprint_costs
from navlog.replay.nav2.costmap.grid import CostmapGrid

Pose2D = tuple[float, float, float]
Twist2D = tuple[float, float, float]


@dataclass
class Cycle:
    """What the critics see of one controller cycle (costmap frame)."""

    pose: Pose2D
    velocity: Twist2D
    goal: Pose2D
    plan: np.ndarray  # (N, 3) the transformed plan
    costmap: CostmapGrid
    footprint: np.ndarray  # (K, 2) robot frame
    xy_goal_tolerance: float
    trans_stopped_velocity: float
    now_ns: int = 0
    _cells: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=dict, repr=False)
    _grids: dict[bytes, np.ndarray] = field(default_factory=dict, repr=False)

    def distances(self, mx: np.ndarray, my: np.ndarray) -> np.ndarray:
        """``grid_distances`` from the source cells, computed once per cycle for the critics sharing them."""
        key = mx.tobytes() + b"|" + my.tobytes()
        if key not in self._grids:
            self._grids[key] = grid_distances(self.costmap.costs.shape, mx, my)
        return self._grids[key]

    def pose_cells(self, t: Trajectories) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``cells`` of every pose of ``t``, computed once per cycle for all the critics."""
        if id(t) not in self._cells:
            self._cells[id(t)] = cells(self.costmap, t.poses[..., :2])
        return self._cells[id(t)]


Scored = tuple[np.ndarray, np.ndarray, str]  # (K,) raw scores, (K,) illegal, why illegal


def cells(costmap: CostmapGrid, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Costmap cells (mx, my) of points (..., 2) and whether each lies on the grid (off-grid cells clipped to 0)."""
    mx, my = costmap.world_to_cell(xy[..., 0], xy[..., 1])
    inside = (mx >= 0) & (my >= 0) & (mx < costmap.size_x) & (my < costmap.size_y)
    return np.where(inside, mx, 0), np.where(inside, my, 0), inside


def forward_points(poses: np.ndarray, distance: float) -> np.ndarray:
    """(..., 2) the points ``distance`` ahead of poses (..., 3) along their heading."""
    return poses[..., :2] + distance * np.stack([np.cos(poses[..., 2]), np.sin(poses[..., 2])], axis=-1)


def adjust_plan_resolution(xy: np.ndarray, resolution: float) -> np.ndarray:
    """``adjustPlanResolution``: points added between plan poses more than two cells apart.

    Between poses d > 2 cells apart, ``m = int((d - 2 cells) / resolution) - 1`` equal parts are
    made and the points 1 .. m - 1 of them inserted.
    """
    if len(xy) < 2:
        return xy.reshape(-1, 2)
    delta = np.diff(xy, axis=0)
    sq = (delta**2).sum(axis=1)
    parts = np.where(sq > 4.0 * resolution**2, ((np.sqrt(sq) - 2.0 * resolution) / resolution).astype(np.int64) - 1, 0)
    added = np.maximum(parts - 1, 0)
    if not added.any():
        return xy
    # each segment contributes its start pose, then its added points; the plan's last pose ends it
    seg = np.repeat(np.arange(len(delta)), added + 1)
    j = np.arange(len(seg)) - np.repeat(np.cumsum(added + 1) - (added + 1), added + 1)
    step = delta[seg] / np.where(parts[seg] > 0, parts[seg], 1)[:, None]
    out = xy[seg] + j[:, None] * step
    return np.vstack([out, xy[-1:]])


def plan_cells(costmap: CostmapGrid, plan_xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(mx, my) of the densified plan from its first pose on a known costmap cell up to where it leaves them."""
    mx, my, inside = cells(costmap, adjust_plan_resolution(plan_xy, costmap.resolution))
    ok = inside & (costmap.costs[my, mx] != NO_INFORMATION)
    if not ok.any():
        return mx[:0], my[:0]
    i = int(ok.argmax())
    j = len(ok) if ok[i:].all() else i + int((~ok[i:]).argmax())
    return mx[i:j], my[i:j]


def grid_distances(shape: tuple[int, int], mx: np.ndarray, my: np.ndarray) -> np.ndarray:
    """Per cell, the Manhattan distance (cells) to the nearest source cell; ``size + 1`` (unreachable) with no source."""
    unreachable = float(shape[0] * shape[1] + 1)
    if len(mx) == 0:
        return np.full(shape, unreachable)
    from scipy.ndimage import distance_transform_edt

    free = np.ones(shape, dtype=bool)
    free[my, mx] = False
    iy, ix = distance_transform_edt(free, return_distances=False, return_indices=True)
    gy, gx = np.indices(shape)
    return (np.abs(iy - gy) + np.abs(ix - gx)).astype(np.float64)


class Critic:
    """A critic: ``name`` (as listed in ``critics``) and its parameters; see the module docstring."""

    def __init__(self, name: str, params: CriticParams) -> None:
        self.name = name
        self.params = params

    def reset(self) -> None:
        """Forget the state kept across cycles (a new plan)."""

    def prepare(self, cycle: Cycle) -> bool:
        """Get ready to score this cycle's trajectories; False when the critic cannot (Nav2 warns)."""
        return True

    def scale(self, cycle: Cycle) -> float:
        return self.params.scale

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        raise NotImplementedError

    def debrief(self, cmd: Twist2D, cycle: Cycle) -> None:
        """See the command chosen this cycle (zero when none was)."""


class BaseObstacle(Critic):
    params: BaseObstacleParams

    def _aggregate(self, per_pose: np.ndarray, t: Trajectories) -> np.ndarray:
        if self.params.sum_scores:
            return np.where(t.valid, per_pose, 0.0).sum(axis=1)
        return per_pose[:, -1].astype(np.float64)

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        mx, my, inside = cycle.pose_cells(t)
        cost = cycle.costmap.costs[my, mx].astype(np.float64)
        illegal = (~inside | (cost >= INSCRIBED)).any(axis=1)
        return self._aggregate(cost, t), illegal, "trajectory hits an obstacle or goes off the grid"


class ObstacleFootprint(BaseObstacle):
    params: ObstacleFootprintParams

    def scale(self, cycle: Cycle) -> float:
        return cycle.costmap.resolution * self.params.scale

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        cm = cycle.costmap
        _, _, inside = cycle.pose_cells(t)
        valid = t.valid
        poses = t.poses[valid]
        c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
        fp = cycle.footprint
        vertices = np.stack(
            [poses[:, :1] + c * fp[:, 0] - s * fp[:, 1], poses[:, 1:2] + s * fp[:, 0] + c * fp[:, 1]], axis=-1
        )
        cost = np.zeros(valid.shape)
        cost[valid] = footprint_costs(cm.costs, vertices, cm.origin_x, cm.origin_y, cm.resolution)
        cost = np.where(valid, cost, cost[np.arange(len(cost)), t.count - 1][:, None])  # pads repeat the last
        illegal = np.asarray((~inside | (cost > INSCRIBED)).any(axis=1))
        return self._aggregate(cost, t), illegal, "footprint hits an obstacle, unknown space or leaves the grid"


class MapGrid(Critic):
    """PathDist's and GoalDist's shared scoring over a grid of distances."""

    params: MapGridParams
    stop_on_failure = True

    def __init__(self, name: str, params: CriticParams) -> None:
        super().__init__(name, params)
        self.values = np.zeros((0, 0))
        self.unreachable = 1.0

    def scale(self, cycle: Cycle) -> float:
        return cycle.costmap.resolution * 0.5 * self.params.scale

    def set_sources(self, cycle: Cycle, mx: np.ndarray, my: np.ndarray) -> bool:
        cm = cycle.costmap
        self.values = cycle.distances(mx, my)
        self.unreachable = float(cm.size_x * cm.size_y + 1)
        return len(mx) > 0

    def pose_cells(self, poses: np.ndarray, cycle: Cycle, t: Trajectories) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The cells the critic scores for ``poses`` (..., 3) (its forward points for the align critics)."""
        return cycle.pose_cells(t) if poses is t.poses else cells(cycle.costmap, poses[..., :2])

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        agg = self.params.aggregation_type
        if agg == "last" and not self.stop_on_failure:
            mx, my, inside = self.pose_cells(t.poses[:, -1], cycle, t)
            return self.values[my, mx], ~inside, "goes off the grid"
        mx, my, inside = self.pose_cells(t.poses, cycle, t)
        d = self.values[my, mx]
        valid = t.valid
        illegal = (valid & ~inside).any(axis=1)
        if self.stop_on_failure:
            illegal |= (valid & (d == self.unreachable)).any(axis=1)
        if agg == "sum":
            score = np.where(valid, d, 0.0).sum(axis=1)
        elif agg == "product":
            score = np.where(valid, d, 1.0).prod(axis=1)
        else:
            score = d[:, -1]
        return score, illegal, "goes off the grid or to cells the plan does not reach"


class PathDist(MapGrid):
    params: PathDistParams

    def prepare(self, cycle: Cycle) -> bool:
        mx, my = plan_cells(cycle.costmap, cycle.plan[:, :2])
        return self.set_sources(cycle, mx, my)


class GoalDist(MapGrid):
    params: GoalDistParams

    def target_plan(self, cycle: Cycle) -> np.ndarray:
        return cycle.plan[:, :2]

    def prepare(self, cycle: Cycle) -> bool:
        mx, my = plan_cells(cycle.costmap, self.target_plan(cycle))
        return self.set_sources(cycle, mx[-1:], my[-1:])


class PathAlign(PathDist):
    params: PathAlignParams  # type: ignore[assignment]
    stop_on_failure = False

    def __init__(self, name: str, params: CriticParams) -> None:
        super().__init__(name, params)
        self.zero_scale = False

    def prepare(self, cycle: Cycle) -> bool:
        d = self.params.forward_point_distance
        dx, dy = cycle.pose[0] - cycle.goal[0], cycle.pose[1] - cycle.goal[1]
        self.zero_scale = dx * dx + dy * dy <= d * d
        return True if self.zero_scale else super().prepare(cycle)

    def scale(self, cycle: Cycle) -> float:
        return 0.0 if self.zero_scale else super().scale(cycle)

    def pose_cells(self, poses: np.ndarray, cycle: Cycle, t: Trajectories) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return cells(cycle.costmap, forward_points(poses, self.params.forward_point_distance))


class GoalAlign(GoalDist):
    params: GoalAlignParams  # type: ignore[assignment]
    stop_on_failure = False

    def target_plan(self, cycle: Cycle) -> np.ndarray:
        xy = cycle.plan[:, :2].copy()
        angle = math.atan2(cycle.goal[1] - cycle.pose[1], cycle.goal[0] - cycle.pose[0])
        xy[-1] += self.params.forward_point_distance * np.array([math.cos(angle), math.sin(angle)])
        return xy

    def pose_cells(self, poses: np.ndarray, cycle: Cycle, t: Trajectories) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return cells(cycle.costmap, forward_points(poses, self.params.forward_point_distance))


class RotateToGoal(Critic):
    params: RotateToGoalParams

    def reset(self) -> None:
        self.in_window = False
        self.rotating = False

    def __init__(self, name: str, params: CriticParams) -> None:
        super().__init__(name, params)
        self.reset()
        self.speed_sq = 0.0
        self.goal_yaw = 0.0

    def prepare(self, cycle: Cycle) -> bool:
        dx, dy = cycle.pose[0] - cycle.goal[0], cycle.pose[1] - cycle.goal[1]
        self.in_window = self.in_window or dx * dx + dy * dy <= cycle.xy_goal_tolerance**2
        self.speed_sq = cycle.velocity[0] ** 2 + cycle.velocity[1] ** 2
        self.rotating = self.rotating or (self.in_window and self.speed_sq <= cycle.trans_stopped_velocity**2)
        self.goal_yaw = cycle.goal[2]
        return True

    def end_yaw(self, t: Trajectories) -> np.ndarray:
        lookahead = self.params.lookahead_time
        if lookahead < 0.0:
            return t.poses[:, -1, 2]
        k = np.arange(len(t.poses))
        i = np.clip((t.times <= lookahead).sum(axis=1) - 1, 0, t.poses.shape[1] - 2)
        t0, t1 = t.times[k, i], t.times[k, i + 1]
        span = np.where(t1 > t0, t1 - t0, 1.0)
        ratio = np.clip((lookahead - t0) / span, 0.0, 1.0)
        return t.poses[k, i, 2] * (1 - ratio) + t.poses[k, i + 1, 2] * ratio

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        k = len(t.twists)
        if not self.in_window:
            return np.zeros(k), np.zeros(k, dtype=bool), ""
        rotation = np.abs(wrap_angles(np.subtract(self.goal_yaw, self.end_yaw(t))))
        speed_sq = t.twists[:, 0] ** 2 + t.twists[:, 1] ** 2
        if not self.rotating:
            return speed_sq * self.params.slowing_factor + rotation, speed_sq >= self.speed_sq, "not slowing near goal"
        return rotation, speed_sq > 0.0, "translating while rotating to the goal"


class _Trend:
    """One axis of Oscillation's command history."""

    def __init__(self) -> None:
        self.sign = 0
        self.positive_only = self.negative_only = False

    def update(self, v: float) -> bool:
        flag = False
        if v < 0.0:
            flag = self.sign > 0
            self.negative_only |= flag
            self.sign = -1
        elif v > 0.0:
            flag = self.sign < 0
            self.positive_only |= flag
            self.sign = 1
        return flag

    def oscillating(self, v: np.ndarray) -> np.ndarray:
        return (self.positive_only & (v < 0.0)) | (self.negative_only & (v > 0.0))

    @property
    def flipped(self) -> bool:
        return self.positive_only or self.negative_only


class Oscillation(Critic):
    params: OscillationParams

    def __init__(self, name: str, params: CriticParams) -> None:
        super().__init__(name, params)
        self.reset()
        self.pose: Pose2D = (0.0, 0.0, 0.0)
        self.stationary: Pose2D = (0.0, 0.0, 0.0)
        self.reset_ns = 0

    def reset(self) -> None:
        self.trends = (_Trend(), _Trend(), _Trend())

    def prepare(self, cycle: Cycle) -> bool:
        self.pose = cycle.pose
        return True

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        bad = np.zeros(len(t.twists), dtype=bool)
        for axis, trend in enumerate(self.trends):
            bad |= trend.oscillating(t.twists[:, axis])
        return np.zeros(len(bad)), bad, "trajectory is oscillating"

    def debrief(self, cmd: Twist2D, cycle: Cycle) -> None:
        p = self.params
        x, y, th = self.trends
        flag = x.update(cmd[0])
        if p.x_only_threshold < 0.0 or abs(cmd[0]) <= p.x_only_threshold:
            flag = y.update(cmd[1]) | flag
            flag = th.update(cmd[2]) | flag
        if flag:
            self.stationary, self.reset_ns = self.pose, cycle.now_ns
        if any(tr.flipped for tr in self.trends) and self._reset_available(cycle.now_ns):
            self.reset()

    def _reset_available(self, now_ns: int) -> bool:
        p = self.params
        dx, dy = self.pose[0] - self.stationary[0], self.pose[1] - self.stationary[1]
        if p.oscillation_reset_dist >= 0.0 and dx * dx + dy * dy > p.oscillation_reset_dist**2:
            return True
        if p.oscillation_reset_angle >= 0.0 and abs(self.pose[2] - self.stationary[2]) > p.oscillation_reset_angle:
            return True
        return p.oscillation_reset_time >= 0.0 and (now_ns - self.reset_ns) * 1e-9 > p.oscillation_reset_time


class PreferForward(Critic):
    params: PreferForwardParams

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        p = self.params
        vx, wz = t.twists[:, 0], np.abs(t.twists[:, 2])
        penalised = (vx < 0.0) | ((vx < p.strafe_x) & (wz < p.strafe_theta))
        return np.where(penalised, p.penalty, wz * p.theta_scale), np.zeros(len(vx), dtype=bool), ""


class Twirling(Critic):
    params: TwirlingParams

    def score(self, t: Trajectories, cycle: Cycle) -> Scored:
        return np.abs(t.twists[:, 2]), np.zeros(len(t.twists), dtype=bool), ""


CRITICS: dict[type[CriticParams], type[Critic]] = {
    BaseObstacleParams: BaseObstacle,
    ObstacleFootprintParams: ObstacleFootprint,
    PathDistParams: PathDist,
    GoalDistParams: GoalDist,
    PathAlignParams: PathAlign,
    GoalAlignParams: GoalAlign,
    RotateToGoalParams: RotateToGoal,
    OscillationParams: Oscillation,
    PreferForwardParams: PreferForward,
    TwirlingParams: Twirling,
}


def make_critic(name: str, params: CriticParams) -> Critic:
    """The critic of ``params``' class, named ``name``."""
    return CRITICS[type(params)](name, params)
