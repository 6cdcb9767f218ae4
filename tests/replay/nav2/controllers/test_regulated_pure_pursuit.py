"""Regulated Pure Pursuit against Nav2 Jazzy's unit-test vectors (test_regulated_pp.cpp) and in closed loop."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navlog.replay.nav2.controllers.base import (
    ControlContext,
    ControllerError,
    ControllerSetup,
    InvalidPath,
    NoValidControl,
    se2,
    transform_poses,
)
from navlog.replay.nav2.controllers.checkers import GoalCheckerParams
from navlog.replay.nav2.controllers.registry import CONTROLLERS
from navlog.replay.nav2.controllers.regulated_pure_pursuit import (
    NO_CUSP,
    RegulatedPurePursuitController,
    RegulatedPurePursuitParams,
    apply_constraints,
    circle_segment_intersection,
    cost_constraint,
    find_velocity_sign_change,
    in_collision,
    lookahead_distance,
    lookahead_point,
    projected_arc,
    rotate_to_heading,
)
from navlog.replay.nav2.costmap.cost_values import LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import footprint_cost, transform_footprint
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
from navlog.replay.nav2.schema import ERROR, WARNING, SectionReader

DEFAULT = RegulatedPurePursuitParams()
EPS = float(np.finfo(np.float32).eps)


def straight(length: float, spacing: float, start=(0.0, 0.0), yaw: float = 0.0) -> np.ndarray:
    """Poses every ``spacing`` along a straight line, both ends included (Nav2's path_utils::Straight)."""
    n = round(length / spacing)
    s = np.arange(n + 1) * spacing
    return np.column_stack([start[0] + s * math.cos(yaw), start[1] + s * math.sin(yaw), np.full(n + 1, yaw)])


def left_circle(radius: float, spacing: float) -> np.ndarray:
    """A full circle turning left from the origin heading +x (centre (0, radius)), both ends included."""
    n = math.ceil(2 * math.pi * radius / spacing)
    a = np.linspace(0.0, 2 * math.pi, n + 1)
    return np.column_stack([radius * np.sin(a), radius * (1 - np.cos(a)), a])


def costmap(size: float = 10.0, resolution: float = 0.05, origin=(-5.0, -5.0), radius: float = 0.2) -> CostmapGrid:
    params = CostmapParams(
        width=int(size),
        height=int(size),
        resolution=resolution,
        origin_x=origin[0],
        origin_y=origin[1],
        robot_radius=radius,
        footprint_padding=0.0,
    )
    return CostmapGrid(params, "local_costmap")


def context(grid: CostmapGrid, plan_to_local: np.ndarray | None = None, xy_tol: float = 0.25) -> ControlContext:
    return ControlContext(
        now_ns=0,
        costmap=grid,
        global_to_local=np.eye(3) if plan_to_local is None else plan_to_local,
        goal_checker=GoalCheckerParams(xy_goal_tolerance=xy_tol),
    )


def controller(**kw) -> RegulatedPurePursuitController:
    return RegulatedPurePursuitController(dataclasses.replace(DEFAULT, **kw), ControllerSetup())


# ------------------------------------------------------------------ lookaheadAPI


@pytest.mark.parametrize(
    ("scaled", "v", "expected"), [(False, 10.0, 0.6), (True, 10.0, 0.9), (True, 0.35, 0.525), (True, 0.0, 0.3)]
)
def test_lookahead_distance(scaled, v, expected):
    params = dataclasses.replace(DEFAULT, use_velocity_scaled_lookahead_dist=scaled)
    assert lookahead_distance(params, v) == pytest.approx(expected)


@pytest.mark.parametrize(("lookahead", "x"), [(1.0, 1.0), (3.8, 3.8)])
def test_carrot_on_path_interpolated(lookahead, x):
    path = straight(9.0, 1.0)
    assert lookahead_point(path, lookahead) == pytest.approx((x, 0.0))


# ------------------------------------------------------------------ CircleSegmentIntersection


@pytest.mark.parametrize(
    ("p1", "p2", "r", "expected"),
    [
        ((0, 0), (2, 0), 1.0, (1, 0)),
        ((4, 0), (-1, 0), 2.0, (2, 0)),
        ((0, 4), (0, -0.5), 2.0, (0, 2)),
        ((0, 0), (6, 8), 5.0, (3, 4)),
        ((0, 0), (-6, 8), 5.0, (-3, 4)),
        ((0, 0), (-6, -8), 5.0, (-3, -4)),
        ((0, 0), (6, -8), 5.0, (3, -4)),
    ],
)
def test_circle_segment_intersection(p1, p2, r, expected):
    assert circle_segment_intersection(p1, p2, r) == pytest.approx(expected, abs=EPS)


# ------------------------------------------------------------------ projectCarrotPastGoal


@pytest.mark.parametrize(
    ("points", "expected_deg"),
    [
        ([(0, 0), (1, 0), (2, 0), (3, 0)], 0.0),
        ([(2, 0), (3, 0)], 0.0),
        ([(2, 2), (3, 3)], 45.0),
        ([(0, 2), (0, 3)], 90.0),
        ([(-2, 2), (-3, 3)], 135.0),
        ([(-2, 0), (-3, 0)], 180.0),
        ([(-2, -2), (-3, -3)], -135.0),
        ([(0, -2), (0, -3)], -90.0),
        ([(2, -2), (3, -3)], -45.0),
    ],
)
def test_project_carrot_past_goal(points, expected_deg):
    path = np.array([(x, y, 0.0) for x, y in points], dtype=float)
    a = math.radians(expected_deg)
    assert lookahead_point(path, 10.0, interpolate_after_goal=True) == pytest.approx(
        (10 * math.cos(a), 10 * math.sin(a)), abs=EPS
    )
    assert lookahead_point(path, 10.0) == pytest.approx(points[-1])  # without projection: the last pose


# ------------------------------------------------------------------ rotateTests


def test_rotate_to_path_and_goal_heading_not_stateful():
    ctrl = controller(stateful=False)
    assert not ctrl.should_rotate_to_path((0.5, 0.25), 1.0)
    assert ctrl.should_rotate_to_path((0.5, 1.0), 1.0)
    assert not ctrl.should_rotate_to_path((0.0, 0.0), 1.0)  # the origin: bearing 0
    assert ctrl.should_rotate_to_goal_heading((0.0, 0.0))
    assert ctrl.should_rotate_to_goal_heading((0.0, 0.24))
    assert not ctrl.should_rotate_to_goal_heading((0.0, 0.26))


def test_rotate_to_path_when_reversing_turns_the_back_to_the_carrot():
    ctrl = controller(allow_reversing=True)
    assert not ctrl.should_rotate_to_path((-0.5, -0.25), -1.0)  # behind and slightly aside: reverse straight
    assert ctrl.should_rotate_to_path((-0.5, -1.0), -1.0)


def test_stateful_goal_heading_latches_until_set_plan():
    ctrl = controller(stateful=True)
    assert [ctrl.should_rotate_to_goal_heading((0.0, y)) for y in (0.26, 0.24, 0.26)] == [False, True, True]
    ctrl.set_plan(straight(1.0, 0.1))
    assert not ctrl.should_rotate_to_goal_heading((0.0, 0.26))
    ctrl.should_rotate_to_goal_heading((0.0, 0.0))
    ctrl.reset()
    assert not ctrl.should_rotate_to_goal_heading((0.0, 0.26))


@pytest.mark.parametrize(
    ("angle", "w_odom", "expected"),
    [(0.4, 1.75, 1.6), (-0.4, -1.75, -1.6), (0.4, 0.0, 0.16), (0.4, 1.0, 1.16), (-0.4, 1.0, 0.84)],
)
def test_rotate_to_heading(angle, w_odom, expected):
    assert rotate_to_heading(angle, w_odom, DEFAULT, 0.05) == pytest.approx(expected, abs=1e-9)


# ------------------------------------------------------------------ applyConstraints


@pytest.mark.parametrize(
    ("v", "kappa", "path", "expected"),
    [
        (0.0, 0.5, straight(1.6, 0.1), 0.25),  # the regulated_linear_scaling_min_speed floor
        (1.0, 0.7407, straight(1.6, 0.1), 0.5),  # R = 1.35 > 0.9: capped at desired_linear_vel
        (1.0, 1000.0, straight(1.6, 0.1), 0.25),  # a tight arc: down to the floor
        (1.0, 0.0, straight(0.0, 0.1), 0.05),  # nothing left of the path: min_approach_linear_velocity
        (0.5, 1 / 0.45, straight(1.6, 0.1), 0.25),  # R 0.45: v * R / r_min
    ],
)
def test_apply_constraints(v, kappa, path, expected):
    out = apply_constraints(DEFAULT, v, kappa, 0.0, 0.22, path, 1.0, DEFAULT.desired_linear_vel)
    assert out == pytest.approx(expected, abs=1e-9)
    reverse = apply_constraints(DEFAULT, v, kappa, 0.0, 0.22, path, -1.0, DEFAULT.desired_linear_vel)
    assert reverse == pytest.approx(-expected, abs=1e-9)


def test_approach_regulation_scales_by_distance_to_the_end():
    path = straight(0.3, 0.1)  # 0.3 m left, end 0.3 m away, scaling over 0.6 m
    no_floor = dataclasses.replace(DEFAULT, regulated_linear_scaling_min_speed=0.0)
    assert apply_constraints(no_floor, 0.5, 0.0, 0.0, 0.22, path, 1.0, 0.5) == pytest.approx(0.25)


@pytest.mark.parametrize(
    ("cost", "expected"),
    [(1, 0.5), (50, 0.5), (100, 0.44117), (128, 0.37260), (200, 0.24863), (253, 0.18333), (255, 0.5), (0, 0.5)],
)
def test_cost_regulation_jazzy(cost, expected):
    assert cost_constraint(0.5, cost, 0.22, DEFAULT) == pytest.approx(expected, abs=1e-5)


def test_cost_regulation_is_floored_at_min_speed():
    path = straight(1.6, 0.1)
    assert apply_constraints(DEFAULT, 0.5, 0.0, 100.0, 0.22, path, 1.0, 0.5) == pytest.approx(0.44117, abs=1e-5)
    assert apply_constraints(DEFAULT, 0.5, 0.0, 253.0, 0.22, path, 1.0, 0.5) == pytest.approx(0.25)


# ------------------------------------------------------------------ findVelocitySignChange


def test_find_velocity_sign_change():
    cusp = np.array([(1, 1, 0), (2, 2, 0), (-1, -1, 0)], dtype=float)
    assert find_velocity_sign_change(cusp) == pytest.approx(math.sqrt(8))
    no_cusp = np.array([(1, 1, 0), (2, 2, 0), (3, 3, 0)], dtype=float)
    assert find_velocity_sign_change(no_cusp) == NO_CUSP
    in_place = np.array([(1, 0, 0), (2, 0, 0), (2, 0, 1.0), (3, 0, 1.0)], dtype=float)
    assert find_velocity_sign_change(in_place) == pytest.approx(2.0)


# ------------------------------------------------------------------ speed limit, parameters


def test_speed_limit():
    ctrl = controller()
    ctrl.set_speed_limit(0.51, percentage=False)
    assert ctrl.desired_linear_vel == 0.51
    ctrl.set_speed_limit(30.0, percentage=True)
    assert ctrl.desired_linear_vel == pytest.approx(0.5 * 0.3)
    ctrl.set_speed_limit(0.0, percentage=False)
    assert ctrl.desired_linear_vel == 0.5


def test_registered_and_read_from_a_nav2_section():
    plugin = CONTROLLERS["nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"]
    assert plugin is not None and plugin.implementation is RegulatedPurePursuitController
    r = SectionReader({})
    section = {"stateful": False, "max_robot_pose_search_dist": 3, "desired_linear_vel": 0.3}
    params = RegulatedPurePursuitParams.read_section(r, section, ("FollowPath",), DEFAULT.plugin)
    assert (params.stateful, params.max_robot_pose_search_dist, params.desired_linear_vel) == (False, 3.0, 0.3)
    assert r.problems == []
    bad = RegulatedPurePursuitParams.read_section(r, {"max_robot_pose_search_dist": "far"}, ("FollowPath",), "x")
    assert bad.max_robot_pose_search_dist is None
    assert [(p.severity, p.path) for p in r.problems] == [(ERROR, "FollowPath.max_robot_pose_search_dist")]
    r = SectionReader({})
    alone = RegulatedPurePursuitParams.read_section(r, {"interpolate_curvature_after_goal": True}, ("F",), "x")
    assert [(p.severity, p.path) for p in r.problems] == [(WARNING, "F.interpolate_curvature_after_goal")]
    assert not RegulatedPurePursuitController(alone, ControllerSetup()).interpolate_after_goal


# ------------------------------------------------------------------ transformGlobalPlan


def transformed(plan, robot, search, width, resolution, plan_to_local=None):
    """The plan transformed as in Nav2's TransformGlobalPlanTest: a ``width`` x ``width`` m costmap."""
    grid = costmap(width, resolution, origin=(robot[0] - width / 2, robot[1] - width / 2))
    ctrl = controller(max_robot_pose_search_dist=search)
    ctrl.set_plan(plan)
    return ctrl, ctrl.transform_plan(robot, context(grid, plan_to_local))


def test_transform_no_pruning_on_large_costmap():
    plan = left_circle(1.0, 0.1)
    _, out = transformed(plan, (-0.1, 0.0, 0.0), 5.0, 100, 0.1)
    assert len(out) == len(plan)


def test_transform_start_selection_on_the_far_side_of_a_circle():
    plan = left_circle(2.0, 0.1)
    ctrl, out = transformed(plan, (0.0, 4.0, 0.0), 10.0, 100, 0.1)
    assert abs(len(out) - len(plan) // 2) <= 1
    assert out[0, :2] == pytest.approx((0.0, 0.0), abs=0.5)
    assert len(ctrl.plan) == len(out)  # the first half is pruned for good


def test_transform_circle_shortcut_to_the_end():
    _, out = transformed(left_circle(2.0, 0.1), (-0.1, 0.0, 0.0), 15.0, 100, 0.1)
    assert len(out) <= 2
    assert out[0, :2] == pytest.approx((0.0, 0.0), abs=0.5)


@pytest.mark.parametrize("turn_back", [False, True])
def test_transform_prunes_at_the_costmap_edge(turn_back):
    plan = straight(100.0, 1.0)
    if turn_back:
        back = straight(100.0, 1.0, start=(100.0, 2.0), yaw=math.pi)
        plan = np.vstack([plan, back])
    _, out = transformed(plan, (-0.1, 0.0, 0.0), 10.0, 20, 0.5)
    assert abs(len(out) - 10) <= 1
    assert out[0, :2] == pytest.approx((0.0, 0.0), abs=0.5)


def test_transform_goes_through_the_plan_frame_and_the_robot_frame():
    plan = straight(3.0, 0.1)
    map_to_odom = se2(1.0, -2.0, 0.7)
    robot_map = (1.0, 0.5, math.pi / 2)
    robot_odom = tuple(transform_poses(np.array([robot_map]), map_to_odom)[0])
    _, out = transformed(plan, robot_odom, -1.0, 200, 0.05, map_to_odom)
    # pose (1, 0) of the plan is 0.5 m to the robot's right, heading -90 degrees relative to it
    assert out[0] == pytest.approx((-0.5, 0.0, -math.pi / 2), abs=1e-9)
    assert out[-1] == pytest.approx((-0.5, -2.0, -math.pi / 2), abs=1e-9)


def test_transform_rejects_an_empty_plan_and_a_plan_out_of_reach():
    ctrl = controller()
    with pytest.raises(InvalidPath) as err:
        ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), context(costmap()))
    assert err.value.code == 103
    with pytest.raises(InvalidPath):
        transformed(left_circle(2.0, 0.1), (1000.0, 1000.0, 0.0), 10.0, 10, 0.1)


# ------------------------------------------------------------------ collision checking


def test_projected_arc_steps_one_cell_apart():
    arc = projected_arc((0.0, 0.0, 0.0), 0.5, 0.0, 10.0, 1.0, 0.05, 0.3)
    assert len(arc) == 9  # t = 0.1 ... 0.9
    assert arc[-1] == pytest.approx((0.45, 0.0, 0.0))
    turning = projected_arc((0.0, 0.0, 0.0), 0.0, 1.8, 10.0, 1.0, 0.05, 0.3)
    dt = 2 * math.sin(0.025 / 0.3) / 1.8
    assert dt == pytest.approx(0.0925, abs=5e-5)
    assert len(turning) == 10 and turning[-1, 2] == pytest.approx(10 * dt * 1.8)
    assert len(projected_arc((0.0, 0.0, 0.0), 0.5, 0.0, 0.2, 1.0, 0.05, 0.3)) == 4  # stops at the carrot distance


def test_footprint_cost_is_the_outline_maximum():
    grid = costmap()
    fp = np.asarray(grid.footprint)
    mx, my = grid.world_to_cell(0.2, 0.0)  # under the footprint's front vertex
    grid.costs[my, mx] = 128
    assert footprint_cost(grid.costs, transform_footprint(fp, 0, 0, 0), -5, -5, 0.05) == 128
    grid.costs[my, mx] = LETHAL
    assert footprint_cost(grid.costs, transform_footprint(fp, 0, 0, 0), -5, -5, 0.05) == LETHAL
    assert footprint_cost(grid.costs, transform_footprint(fp, 0, 1.0, 0), -5, -5, 0.05) == 0
    assert footprint_cost(grid.costs, transform_footprint(fp, -4.9, 0, 0), -5, -5, 0.05) == LETHAL  # off the map


def test_unknown_on_an_earlier_edge_masks_a_lethal_cell_as_in_nav2():
    square = np.array([(0.0, 0.0), (0.5, 0.0), (0.5, 0.5), (0.0, 0.5)])  # edges: bottom, right, top, left
    costs = np.zeros((20, 20), np.uint8)
    costs[5, 10] = LETHAL  # on the right edge (x 0.5, y 0.25), checked second
    assert footprint_cost(costs, square, 0.0, 0.0, 0.05) == LETHAL
    costs[0, 5] = NO_INFORMATION  # on the bottom edge, checked first
    assert footprint_cost(costs, square, 0.0, 0.0, 0.05) == NO_INFORMATION
    tracking = CostmapGrid(CostmapParams(width=1, height=1, resolution=0.05, track_unknown_space=True))
    tracking.costs[:] = costs
    not_tracking = CostmapGrid(CostmapParams(width=1, height=1, resolution=0.05))
    not_tracking.costs[:] = costs
    robot = np.array([(0.0, 0.0, 0.0)])
    assert not in_collision(tracking, square, robot)[0]
    assert in_collision(not_tracking, square, robot)[0]


def test_collision_ahead_raises_no_valid_control():
    grid = costmap()
    mx, _ = grid.world_to_cell(0.45, 0.0)
    grid.costs[:, mx] = LETHAL  # a wall 0.45 m ahead; the footprint's front reaches it 0.25 m on
    ctrl = controller()
    ctrl.set_plan(straight(3.0, 0.05))
    with pytest.raises(NoValidControl, match="RegulatedPurePursuitController detected collision ahead!") as err:
        ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), context(grid))
    assert err.value.code == 106
    free = controller(use_collision_detection=False)
    free.set_plan(straight(3.0, 0.05))
    assert free.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), context(grid)).cmd[0] == 0.5


def test_robot_off_the_costmap_is_an_error_naming_the_costmap():
    ctrl = controller(use_collision_detection=False)
    ctrl.set_plan(straight(3.0, 0.05, start=(6.0, 0.0)))
    with pytest.raises(ControllerError, match="costmap"):
        ctrl.compute_velocity_commands((6.0, 0.0, 0.0), (0.0, 0.0, 0.0), context(costmap()))


# ------------------------------------------------------------------ one cycle


def test_cycle_modes_follow_rotate_to_path_and_goal_heading():
    grid = costmap()
    ctrl = controller()
    ctrl.set_plan(straight(2.0, 0.05))
    follow = ctrl.compute_velocity_commands((0.0, 0.1, 0.0), (0.5, 0.0, 0.0), context(grid))
    kappa = 2 * -0.1 / (0.6**2)  # carrot at (sqrt(0.36 - 0.01), -0.1)
    assert follow.cmd == pytest.approx((0.5, 0.0, 0.5 * kappa))
    assert follow.local_plan[0] == pytest.approx((0.0, 0.0, 0.0))  # the followed plan, costmap frame
    assert follow.trajectories is not None and follow.trajectories.shape == (1, 9, 2)
    turn = ctrl.compute_velocity_commands((0.0, 0.0, math.pi / 2), (0.0, 0.0, 0.0), context(grid))
    assert turn.cmd == pytest.approx((0.0, 0.0, -3.2 * 0.05))  # rotate to path, acceleration-limited
    ctrl.set_plan(np.array([(0.0, 0.0, 0.0), (0.1, 0.0, 0.1)]))
    goal = ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 1.8), context(grid))
    assert goal.cmd == pytest.approx((0.0, 0.0, math.sqrt(2 * 3.2 * 0.1)))  # to the goal heading, slowing to stop


def test_reversing_follows_a_path_behind_the_robot():
    ctrl = controller(allow_reversing=True, use_rotate_to_heading=False)
    ctrl.set_plan(straight(2.0, 0.05, yaw=math.pi))
    out = ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), context(costmap()))
    assert out.cmd == pytest.approx((-0.5, 0.0, 0.0))


def test_cancel_deceleration_brings_the_robot_to_a_stop():
    ctrl = controller(use_cancel_deceleration=True)
    ctrl.set_plan(straight(3.0, 0.05))
    assert not ctrl.cancel()
    v = ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.5, 0.0, 0.0), context(costmap())).cmd[0]
    assert v == pytest.approx(0.5 - 0.05 * 3.2)
    ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.1, 0.0, 0.0), context(costmap()))
    assert ctrl.cancel()


# ------------------------------------------------------------------ closed loop


def draw_clutter(grid: CostmapGrid, map_to_odom: np.ndarray) -> None:
    """Lethal boxes beside the L-shaped path (map frame), with a 0.45 m band of cost 128 round them."""
    xs, ys = grid.cell_centres()
    inv = np.linalg.inv(map_to_odom)  # cell centres into the map frame
    mx = inv[0, 0] * xs + inv[0, 1] * ys + inv[0, 2]
    my = inv[1, 0] * xs + inv[1, 1] * ys + inv[1, 2]
    for x0, y0, x1, y1 in [(1.0, 0.35, 1.6, 1.2), (3.4, 1.2, 4.0, 1.8), (1.5, -1.2, 2.2, -0.5)]:
        d = np.hypot(np.clip(mx, x0, x1) - mx, np.clip(my, y0, y1) - my)
        grid.costs = np.maximum(grid.costs, np.where(d < 0.45, 128, 0).astype(np.uint8))
        grid.costs[d == 0] = LETHAL


@pytest.mark.parametrize("cluttered", [False, True])
@pytest.mark.parametrize("map_to_odom", [(0.0, 0.0, 0.0), (0.4, -0.3, 0.2)])
def test_closed_loop_l_path_reaches_the_end(cluttered, map_to_odom):
    """A unicycle follows (0, 0) -> (3, 0) -> (3, 3) and stops at the goal, touching no lethal cell."""
    plan = np.vstack([straight(3.0, 0.05), straight(3.0, 0.05, start=(3.0, 0.0), yaw=math.pi / 2)[1:]])
    T = se2(*map_to_odom)
    grid = costmap(size=10.0, origin=(-3.0, -3.0))
    if cluttered:
        draw_clutter(grid, T)
    ctrl = RegulatedPurePursuitController(DEFAULT, ControllerSetup())
    ctrl.set_plan(plan)
    goal = transform_poses(plan[-1:], T)[0]
    x, y, yaw = transform_poses(np.array([(0.0, 0.0, math.pi / 2)]), T)[0]  # starts facing away from the path
    v = w = 0.0
    dt = 0.05
    fp = np.asarray(grid.footprint)
    near_obstacles = []  # the speeds commanded with the robot's centre in a cost-128 band
    for _ in range(1200):  # 60 s of sim time
        if math.hypot(x - goal[0], y - goal[1]) < 0.25 and abs(math.remainder(yaw - goal[2], 2 * math.pi)) < 0.25:
            break
        v, _, w = ctrl.compute_velocity_commands((x, y, yaw), (v, 0.0, w), context(grid, T)).cmd
        if grid.cost_at(x, y) == 128 and v > 0:
            near_obstacles.append(v)
        x += v * math.cos(yaw) * dt
        y += v * math.sin(yaw) * dt
        yaw += w * dt
        placed = transform_footprint(fp, x, y, yaw)
        assert footprint_cost(grid.costs, placed, grid.origin_x, grid.origin_y, grid.resolution) < LETHAL
    else:
        pytest.fail(f"goal not reached: robot at ({x:.2f}, {y:.2f}, {yaw:.2f}), goal {goal}")
    assert math.hypot(x - goal[0], y - goal[1]) < 0.25
    # cost regulation: 128 under a robot of inscribed radius 0.196 m reads as 0.42 m from an obstacle
    assert bool(near_obstacles) == cluttered
    assert all(v <= 0.5 * 0.4234 / 0.6 + 1e-3 for v in near_obstacles)
