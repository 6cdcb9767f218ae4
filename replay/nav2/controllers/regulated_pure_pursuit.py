"""Regulated Pure Pursuit (``nav2_regulated_pure_pursuit_controller``), as Nav2 Jazzy computes it.

One ``compute_velocity_commands`` call reads as Nav2's cycle:

1. transform and prune the plan (``transform_plan``): the plan pose closest to the robot (searched
   within ``max_robot_pose_search_dist`` of integrated path length; at least two poses kept), up
   to the first pose farther than half the local costmap, in the robot frame; the poses before
   the closest one are dropped for good (until the next ``set_plan``);
2. the lookahead distance (``lookahead_distance``: fixed, or velocity-scaled and clamped), cut to
   the first cusp when ``allow_reversing`` (``find_velocity_sign_change``);
3. the carrot (``lookahead_point``): the first pose at least the lookahead away, interpolated on
   the circle (``circle_segment_intersection``); past the goal, the last pose (or the last segment
   projected out when ``interpolate_curvature_after_goal``);
4. the mode: rotate to the goal heading once the carrot is within the goal checker's xy tolerance
   (latched until ``set_plan``/``reset`` when ``stateful``), rotate towards the path when the
   carrot's bearing exceeds ``rotate_to_heading_min_angle`` (``rotate_to_heading``), or else
   follow the arc, with the speed regulated by curvature, by the cost under the robot and on
   approach to the goal (``apply_constraints``), and ``w = v * curvature``;
5. the collision check ahead (``collision_imminent``): the footprint along the commanded arc,
   up to the carrot's distance and ``max_allowed_time_to_collision_up_to_carrot``; a lethal cell
   raises ``NoValidControl("RegulatedPurePursuitController detected collision ahead!")``.

``cancel`` (``use_cancel_deceleration``) and ``set_speed_limit`` behave as Nav2's. Units: metres,
radians, seconds, m/s and rad/s; the plan is (N, 3) x, y, yaw; no wall clock, no randomness.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from navlog.replay.geometry import normalize_angle, wrap_angles
from navlog.replay.nav2.controllers.base import (
    ControlContext,
    ControllerError,
    ControllerSetup,
    ControlResult,
    InvalidPath,
    NoValidControl,
    Pose2D,
    Twist2D,
    first_after_integrated_distance,
    se2,
    transform_poses,
)
from navlog.replay.nav2.costmap.cost_values import FREE_SPACE, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import footprint_costs
from navlog.replay.nav2.costmap.grid import CostmapGrid
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import WARNING, SectionReader, param

NO_CUSP = float(np.finfo(np.float64).max)  # Nav2's DBL_MAX: the plan has no change of direction
NO_SPEED_LIMIT = 0.0  # nav2_costmap_2d::NO_SPEED_LIMIT


@dataclass(frozen=True)
class RegulatedPurePursuitParams(PluginParams):
    """``nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController`` parameters (Jazzy).

    ``max_robot_pose_search_dist`` None is Nav2's default, half the local costmap's width; a
    negative value searches the whole plan.
    """

    plugin: str = "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
    desired_linear_vel: float = param(0.5, ge=0.0)
    lookahead_dist: float = param(0.6, gt=0.0)
    min_lookahead_dist: float = param(0.3, gt=0.0)
    max_lookahead_dist: float = param(0.9, gt=0.0)
    lookahead_time: float = param(1.5, gt=0.0)
    rotate_to_heading_angular_vel: float = param(1.8, ge=0.0)
    transform_tolerance: float = param(0.1, ge=0.0)
    use_velocity_scaled_lookahead_dist: bool = False
    min_approach_linear_velocity: float = param(0.05, ge=0.0)
    approach_velocity_scaling_dist: float = param(0.6, ge=0.0)
    use_collision_detection: bool = True
    max_allowed_time_to_collision_up_to_carrot: float = param(1.0, ge=0.0)
    use_regulated_linear_velocity_scaling: bool = True
    use_cost_regulated_linear_velocity_scaling: bool = True
    regulated_linear_scaling_min_radius: float = param(0.9, ge=0.0)
    regulated_linear_scaling_min_speed: float = param(0.25, ge=0.0)
    use_rotate_to_heading: bool = True
    allow_reversing: bool = False
    rotate_to_heading_min_angle: float = param(0.785, ge=0.0)
    max_angular_accel: float = param(3.2, gt=0.0)
    max_robot_pose_search_dist: float | None = None
    cost_scaling_dist: float = param(0.6, ge=0.0)
    cost_scaling_gain: float = param(1.0, ge=0.0)
    inflation_cost_scaling_factor: float = param(3.0, gt=0.0)
    use_fixed_curvature_lookahead: bool = False
    curvature_lookahead_dist: float = param(0.6, gt=0.0)
    use_interpolation: bool = True
    interpolate_curvature_after_goal: bool = False
    use_cancel_deceleration: bool = False
    cancel_deceleration: float = param(3.2, ge=0.0)
    stateful: bool = True

    @classmethod
    def read_section(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> Any:
        """As every plugin's, with ``max_robot_pose_search_dist`` checked as a number (its default is None)
        and a warning where Nav2 disables ``interpolate_curvature_after_goal``."""
        params = r.read(cls, section, path, extra={"plugin": plugin})
        if params.interpolate_curvature_after_goal and not params.use_fixed_curvature_lookahead:
            r.add(
                WARNING,
                path + ("interpolate_curvature_after_goal",),
                "needs use_fixed_curvature_lookahead: true; Nav2 disables it (set both, or remove it)",
            )
        value = params.max_robot_pose_search_dist
        if value is not None:
            ok, out = r.convert(value, float, path + ("max_robot_pose_search_dist",), {})
            params = dataclasses.replace(params, max_robot_pose_search_dist=out if ok else None)
        return params


# ------------------------------------------------------------------ geometry of the plan


def path_length(xy: np.ndarray) -> float:
    """Integrated length of a polyline (N, >=2) (``nav2_util::geometry_utils::calculate_path_length``)."""
    if len(xy) < 2:
        return 0.0
    d = np.diff(np.asarray(xy, dtype=np.float64)[:, :2], axis=0)
    return float(np.hypot(d[:, 0], d[:, 1]).sum())


def circle_segment_intersection(p1: tuple[float, float], p2: tuple[float, float], r: float) -> tuple[float, float]:
    """The point of segment p1 -> p2 at distance ``r`` from the origin (p1 inside the circle, p2 outside).

    The line-circle intersection, taking the root on the side of the point farther from the origin.
    """
    x1, y1 = p1
    x2, y2 = p2
    dx, dy = x2 - x1, y2 - y1
    dr2 = dx * dx + dy * dy
    d = x1 * y2 - x2 * y1
    side = math.copysign(1.0, (x2 * x2 + y2 * y2) - (x1 * x1 + y1 * y1))
    root = math.sqrt(r * r * dr2 - d * d)
    return (d * dy + side * dx * root) / dr2, (-d * dx + side * dy * root) / dr2


def lookahead_point(path: np.ndarray, lookahead: float, interpolate_after_goal: bool = False) -> tuple[float, float]:
    """The carrot on a plan in the robot frame (N, >=2): see the module docstring, step 3."""
    dist = np.hypot(path[:, 0], path[:, 1])
    far = np.flatnonzero(dist >= lookahead)
    if len(far) == 0:
        last = (float(path[-1, 0]), float(path[-1, 1]))
        if not interpolate_after_goal or len(path) < 2:
            return last
        heading = math.atan2(path[-1, 1] - path[-2, 1], path[-1, 0] - path[-2, 0])
        projected = (last[0] + math.cos(heading) * lookahead, last[1] + math.sin(heading) * lookahead)
        return circle_segment_intersection(last, projected, lookahead)
    i = int(far[0])
    if i == 0:
        return float(path[0, 0]), float(path[0, 1])
    return circle_segment_intersection(
        (float(path[i - 1, 0]), float(path[i - 1, 1])), (float(path[i, 0]), float(path[i, 1])), lookahead
    )


def curvature(x: float, y: float) -> float:
    """Curvature of the arc from the robot (origin, heading +x) through (x, y): 2y / (x^2 + y^2), 0 when very near."""
    d2 = x * x + y * y
    return 2.0 * y / d2 if d2 > 0.001 else 0.0


def find_velocity_sign_change(path: np.ndarray) -> float:
    """Distance from the robot (origin) to the plan's first cusp, ``NO_CUSP`` when there is none.

    A cusp is a pose where the path turns back (the segments before and after it point apart), or a
    zero-length segment at it with a change of orientation (a rotation in place).
    """
    for i in range(1, len(path) - 1):
        oa = path[i, :2] - path[i - 1, :2]
        ab = path[i + 1, :2] - path[i, :2]
        if oa[0] * ab[0] + oa[1] * ab[1] < 0.0:
            return float(math.hypot(path[i, 0], path[i, 1]))
        if (math.hypot(oa[0], oa[1]) == 0.0 and path[i - 1, 2] != path[i, 2]) or (
            math.hypot(ab[0], ab[1]) == 0.0 and path[i, 2] != path[i + 1, 2]
        ):
            return float(math.hypot(path[i, 0], path[i, 1]))
    return NO_CUSP


# ------------------------------------------------------------------ speed


def angle_to_path(carrot: tuple[float, float], sign: float) -> float:
    """The carrot's bearing from the robot's front, or from its back when reversing (``sign`` < 0)."""
    angle = math.atan2(carrot[1], carrot[0])
    return normalize_angle(angle + math.pi) if sign < 0.0 else angle


def lookahead_distance(params: RegulatedPurePursuitParams, linear_x: float) -> float:
    """``lookahead_dist``, or ``|v| * lookahead_time`` clamped to [min, max] when velocity-scaled."""
    if not params.use_velocity_scaled_lookahead_dist:
        return params.lookahead_dist
    return min(max(abs(linear_x) * params.lookahead_time, params.min_lookahead_dist), params.max_lookahead_dist)


def curvature_constraint(v: float, kappa: float, min_radius: float) -> float:
    """``v`` scaled by radius / min_radius on arcs tighter than ``min_radius``."""
    radius = abs(1.0 / kappa) if kappa != 0.0 else math.inf
    if radius < min_radius:
        return v * (1.0 - abs(radius - min_radius) / min_radius)
    return v


def cost_constraint(v: float, cost: float, inscribed_radius: float, params: RegulatedPurePursuitParams) -> float:
    """``v`` scaled down near obstacles: the obstacle distance is recovered from the inflated cost under the robot."""
    if cost in (NO_INFORMATION, FREE_SPACE):
        return v
    k = params.inflation_cost_scaling_factor
    distance = (k * inscribed_radius - math.log(cost) + math.log(253.0)) / k
    if distance < params.cost_scaling_dist:
        return v * (params.cost_scaling_gain * distance / params.cost_scaling_dist)
    return v


def approach_velocity_constraint(v: float, path: np.ndarray, min_velocity: float, scaling_dist: float) -> float:
    """``v`` scaled by the distance to the plan's end once less than ``scaling_dist`` of plan remains."""
    scale = 1.0
    if path_length(path) < scaling_dist:
        scale = math.hypot(path[-1, 0], path[-1, 1]) / scaling_dist
    return min(v, max(v * scale, min_velocity))


def rotate_to_heading(angle: float, angular_odom: float, params: RegulatedPurePursuitParams, dt: float) -> float:
    """The turn-in-place rate towards ``angle`` (rad): full rate, acceleration-limited from the odometry,
    slowed to stop at the heading (``|w| <= sqrt(2 a |angle|)``)."""
    sign = 1.0 if angle > 0.0 else -1.0
    a = params.max_angular_accel
    w = sign * params.rotate_to_heading_angular_vel
    w = min(max(w, angular_odom - a * dt), angular_odom + a * dt)
    stop = math.sqrt(2.0 * a * abs(angle))
    if abs(w) > stop:
        w = sign * stop
    return w


def apply_constraints(
    params: RegulatedPurePursuitParams,
    v: float,
    kappa: float,
    cost: float,
    inscribed_radius: float,
    path: np.ndarray,
    sign: float,
    v_max: float,
) -> float:
    """The regulated linear speed from ``v``: curvature and cost regulation, the
    ``regulated_linear_scaling_min_speed`` floor, approach regulation, clamped to ``v_max`` (the
    desired speed under the speed limit) and signed."""
    v_curv = v_cost = v
    if params.use_regulated_linear_velocity_scaling:
        v_curv = curvature_constraint(v, kappa, params.regulated_linear_scaling_min_radius)
    if params.use_cost_regulated_linear_velocity_scaling:
        v_cost = cost_constraint(v, cost, inscribed_radius, params)
    out = max(min(v_curv, v_cost), params.regulated_linear_scaling_min_speed)
    out = approach_velocity_constraint(
        out, path, params.min_approach_linear_velocity, params.approach_velocity_scaling_dist
    )
    return sign * min(abs(out), v_max)


# ------------------------------------------------------------------ collision


def in_collision(costmap: CostmapGrid, footprint: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Per pose (P, 3): whether the footprint there touches a lethal cell (or unknown when not tracking it).

    A pose outside the costmap is not a collision (Nav2 only warns there).
    """
    poses = np.asarray(poses, dtype=np.float64).reshape(-1, 3)
    mx, my = costmap.world_to_cell(poses[:, 0], poses[:, 1])
    inside = (mx >= 0) & (mx < costmap.size_x) & (my >= 0) & (my < costmap.size_y)
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    fx, fy = footprint[:, 0], footprint[:, 1]
    placed = np.stack([poses[:, :1] + c * fx - s * fy, poses[:, 1:2] + s * fx + c * fy], axis=-1)
    cost = footprint_costs(costmap.costs, placed, costmap.origin_x, costmap.origin_y, costmap.resolution)
    unknown_allowed = (cost == NO_INFORMATION) & bool(costmap.params.track_unknown_space)
    return inside & ~unknown_allowed & (cost >= LETHAL)


def projected_arc(
    pose: Pose2D, v: float, w: float, carrot_dist: float, max_time: float, resolution: float, circumscribed: float
) -> np.ndarray:
    """The poses (K, 3) the collision check visits along the arc (v, w): one costmap cell of travel
    apart (of the footprint's outer point when turning in place), within ``max_time`` and no farther
    (straight line) than ``carrot_dist`` from the start."""
    if abs(v) < 0.01 and abs(w) > 0.01:
        dt = 2.0 * math.sin((resolution / 2.0) / circumscribed) / abs(w)
    elif v != 0.0:
        dt = resolution / abs(v)
    else:
        return np.zeros((0, 3))  # not moving: nothing ahead to check
    x, y, yaw = pose
    out = []
    i = 1
    while i * dt < max_time:
        i += 1
        x += dt * v * math.cos(yaw)
        y += dt * v * math.sin(yaw)
        yaw += dt * w
        if math.hypot(x - pose[0], y - pose[1]) > carrot_dist:
            break
        out.append((x, y, yaw))
    return np.asarray(out, dtype=np.float64).reshape(-1, 3)


# ------------------------------------------------------------------ the controller


class RegulatedPurePursuitController:
    """Nav2's ``RegulatedPurePursuitController``: ``cls(params, setup)``; see the module docstring."""

    def __init__(self, params: RegulatedPurePursuitParams, setup: ControllerSetup) -> None:
        self.params = params
        self.setup = setup
        self.dt = 1.0 / setup.controller_frequency
        self.desired_linear_vel = params.desired_linear_vel  # what the speed limit sets
        # Nav2 disables interpolation after the goal without a fixed curvature lookahead
        self.interpolate_after_goal = params.interpolate_curvature_after_goal and params.use_fixed_curvature_lookahead
        self.goal_dist_tol = 0.25  # until the goal checker tells
        self.plan = np.zeros((0, 3))
        self.has_reached_xy_tolerance = False
        self.cancelling = False
        self.finished_cancelling = False
        self.is_rotating_to_heading = False
        self.carrot: tuple[float, float] = (0.0, 0.0)  # the last carrot, robot frame

    # -- Nav2's nav2_core::Controller
    def set_plan(self, path: np.ndarray) -> None:
        """A new global plan (N, 3) in the plan frame; clears the rotate-to-goal latch."""
        self.has_reached_xy_tolerance = False
        self.plan = np.asarray(path, dtype=np.float64).reshape(-1, 3).copy()

    def reset(self) -> None:
        self.cancelling = False
        self.finished_cancelling = False
        self.has_reached_xy_tolerance = False

    def cancel(self) -> bool:
        """Start decelerating (``use_cancel_deceleration``); True once stopped (or without deceleration)."""
        if not self.params.use_cancel_deceleration:
            return True
        self.cancelling = True
        return self.finished_cancelling

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """A speed limit in m/s, or in percent of ``desired_linear_vel``; ``NO_SPEED_LIMIT`` lifts it."""
        if limit == NO_SPEED_LIMIT:
            self.desired_linear_vel = self.params.desired_linear_vel
        elif percentage:
            self.desired_linear_vel = self.params.desired_linear_vel * limit / 100.0
        else:
            self.desired_linear_vel = limit

    def compute_velocity_commands(self, pose: Pose2D, velocity: Twist2D, ctx: ControlContext) -> ControlResult:
        """One cycle: the command (v, 0, w); raises ``NoValidControl`` on a collision ahead."""
        p = self.params
        self.goal_dist_tol = ctx.goal_checker.xy_goal_tolerance
        path = self.transform_plan(pose, ctx)

        lookahead = lookahead_distance(p, velocity[0])
        curv_lookahead = p.curvature_lookahead_dist
        if p.allow_reversing:
            cusp = find_velocity_sign_change(path)
            lookahead = min(lookahead, cusp)
            curv_lookahead = min(curv_lookahead, cusp)

        carrot = lookahead_point(path, lookahead)
        self.carrot = carrot
        heading_carrot = carrot
        kappa = curvature(*carrot)
        if p.use_fixed_curvature_lookahead:
            heading_carrot = lookahead_point(path, curv_lookahead, self.interpolate_after_goal)
            kappa = curvature(*heading_carrot)

        sign = 1.0 if not p.allow_reversing or carrot[0] >= 0.0 else -1.0
        if self.should_rotate_to_goal_heading(carrot):
            self.is_rotating_to_heading = True
            v, w = 0.0, rotate_to_heading(float(path[-1, 2]), velocity[2], p, self.dt)
        elif self.should_rotate_to_path(heading_carrot, sign):
            self.is_rotating_to_heading = True
            v, w = 0.0, rotate_to_heading(angle_to_path(heading_carrot, sign), velocity[2], p, self.dt)
        else:
            self.is_rotating_to_heading = False
            cost = self.cost_at_robot(pose, ctx.costmap)
            v_max = self.desired_linear_vel
            v = apply_constraints(p, v_max, kappa, cost, ctx.costmap.inscribed_radius, path, sign, v_max)
            if self.cancelling:
                v = velocity[0] - sign * self.dt * p.cancel_deceleration
                if (sign > 0 and v <= 0.0) or (sign < 0 and v >= 0.0):
                    v = 0.0
                    self.finished_cancelling = True
            w = v * kappa

        arc = None
        if p.use_collision_detection:
            arc = self.collision_arc(pose, v, w, math.hypot(*carrot), ctx.costmap)
        local_plan = transform_poses(path, se2(*pose))
        return ControlResult(cmd=(v, 0.0, w), local_plan=local_plan, trajectories=arc)

    # -- the steps
    def transform_plan(self, pose: Pose2D, ctx: ControlContext) -> np.ndarray:
        """The plan near the robot in the robot frame (M, 3), pruning the plan; see the module docstring, step 1."""
        plan = self.plan
        if len(plan) == 0:
            raise InvalidPath("RegulatedPurePursuitController: received plan with zero length")
        if self.interpolate_after_goal and len(plan) == 1:
            raise InvalidPath("RegulatedPurePursuitController: received plan with length of one")
        plan_to_local = np.asarray(ctx.global_to_local, dtype=np.float64)
        robot = np.linalg.solve(plan_to_local, np.array([pose[0], pose[1], 1.0]))[:2]  # the robot in the plan frame
        search = self.params.max_robot_pose_search_dist
        if search is None:
            search = _size_in_metres(ctx.costmap) / 2.0
        elif search < 0.0:
            search = math.inf
        upper = first_after_integrated_distance(plan, search)
        to_robot = np.hypot(plan[:, 0] - robot[0], plan[:, 1] - robot[1])
        begin = int(np.argmin(to_robot[:upper]))
        if len(plan) > 1 and begin == upper - 1:
            begin = max(upper - 2, 0)
        outside = np.flatnonzero(to_robot[begin:] > _size_in_metres(ctx.costmap) / 2.0)
        end = begin + int(outside[0]) if len(outside) else len(plan)
        self.plan = plan[begin:]
        if end <= begin:
            raise InvalidPath("RegulatedPurePursuitController: resulting plan has 0 poses in it")
        local = transform_poses(plan[begin:end], np.linalg.inv(se2(*pose)) @ plan_to_local)
        local[:, 2] = wrap_angles(local[:, 2])
        return local

    def should_rotate_to_goal_heading(self, carrot: tuple[float, float]) -> bool:
        """Whether the carrot is within the goal checker's xy tolerance (latched when ``stateful``)."""
        if not self.params.use_rotate_to_heading:
            return False
        near = math.hypot(*carrot) < self.goal_dist_tol
        if self.params.stateful:
            self.has_reached_xy_tolerance = self.has_reached_xy_tolerance or near
            return self.has_reached_xy_tolerance
        return near

    def should_rotate_to_path(self, carrot: tuple[float, float], sign: float) -> bool:
        """Whether the carrot's bearing (from the back when reversing) exceeds ``rotate_to_heading_min_angle``."""
        return (
            self.params.use_rotate_to_heading
            and abs(angle_to_path(carrot, sign)) > self.params.rotate_to_heading_min_angle
        )

    def cost_at_robot(self, pose: Pose2D, costmap: CostmapGrid) -> float:
        """The costmap cost under the robot's centre; an error when the robot is off the costmap."""
        cost = costmap.cost_at(pose[0], pose[1])
        if cost is None:
            raise ControllerError(
                "RegulatedPurePursuitController: Dimensions of the costmap are too small to encapsulate the robot "
                "footprint at current speeds! (the robot is outside the local costmap: enlarge it, or check that "
                "it rolls with the robot)"
            )
        return float(cost)

    def collision_arc(
        self, pose: Pose2D, v: float, w: float, carrot_dist: float, costmap: CostmapGrid
    ) -> np.ndarray | None:
        """The checked arc (1, K, 2); raises ``NoValidControl`` when the footprint meets a lethal cell on it."""
        footprint = np.asarray(costmap.footprint, dtype=np.float64).reshape(-1, 2)
        if len(footprint) == 0:
            footprint = np.asarray(self.setup.footprint, dtype=np.float64).reshape(-1, 2)
        circumscribed = costmap.circumscribed_radius or self.setup.robot_radius
        arc = projected_arc(
            pose,
            v,
            w,
            carrot_dist,
            self.params.max_allowed_time_to_collision_up_to_carrot,
            costmap.resolution,
            circumscribed,
        )
        if in_collision(costmap, footprint, np.vstack([pose, arc])).any():
            raise NoValidControl("RegulatedPurePursuitController detected collision ahead!")
        return arc[None, :, :2]


def _size_in_metres(costmap: CostmapGrid) -> float:
    """The costmap's larger side in metres as Nav2 gives it (``(cells - 1 + 0.5) * resolution``)."""
    return (max(costmap.size_x, costmap.size_y) - 0.5) * costmap.resolution
