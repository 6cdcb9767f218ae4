"""Goal and progress checkers against Nav2's own unit-test vectors (nav2_controller/plugins/test)."""

from __future__ import annotations

import math

import pytest

from navlog.replay.geometry import normalize_angle
from navlog.replay.nav2 import parse_nav2_text
from navlog.replay.nav2.controllers.checkers import (
    GoalCheckerParams,
    PoseProgressChecker,
    PositionGoalChecker,
    ProgressCheckerParams,
    SimpleGoalChecker,
    SimpleProgressChecker,
    StoppedGoalChecker,
)
from navlog.replay.nav2.controllers.registry import GOAL_CHECKERS, PROGRESS_CHECKERS

EPS = 2.220446049250313e-16  # std::numeric_limits<double>::epsilon()
ORIGIN = (0.0, 0.0, 0.0)
MS = 1_000_000  # ns


def _both(pose, goal, vel):
    gc, sgc = SimpleGoalChecker(GoalCheckerParams()), StoppedGoalChecker(GoalCheckerParams())
    return gc.is_goal_reached(pose, goal, vel), sgc.is_goal_reached(pose, goal, vel)


@pytest.mark.parametrize(
    ("pose", "goal", "vel", "simple", "stopped"),
    [
        ((0, 0, 0), (0, 0, 0), (0, 0, 0), True, True),
        ((0, 0, 0), (1, 0, 0), (0, 0, 0), False, False),
        ((0, 0, 0), (0, 1, 0), (0, 0, 0), False, False),
        ((0, 0, 0), (0, 0, 1), (0, 0, 0), False, False),
        ((0, 0, 3.14), (0, 0, -3.14), (0, 0, 0), True, True),
        ((0, 0, 3.14), (0, 0, -3.14), (1, 0, 0), True, False),
        ((0, 0, 0), (0, 0, 0), (1, 0, 0), True, False),
        ((0, 0, 0), (0, 0, 0), (0, 1, 0), True, False),
        ((0, 0, 0), (0, 0, 0), (0, 0, 1), True, False),
    ],
)
def test_two_checks(pose, goal, vel, simple, stopped):
    assert _both(pose, goal, vel) == (simple, stopped)


AX = 0.25 / math.sqrt(2)


@pytest.mark.parametrize(
    ("pose", "vel", "simple", "stopped"),
    [
        ((0.25, 0, 0), (0.25, 0, 0), True, True),  # the xy boundary counts as reached, v boundary as stopped
        ((0.25, 0, 0), (0.25 + EPS, 0, 0), True, False),
        ((0.25 + EPS, 0, 0), (0.25, 0, 0), False, False),
        ((AX, AX, 0), (AX, AX, 0), True, True),
        ((AX, AX, 0), (AX + EPS, AX + EPS, 0), True, False),
        ((AX + EPS, AX + EPS, 0), (AX, AX, 0), False, False),
        ((0, 0, 0.25), (0, 0, 0.25), True, True),
        ((0, 0, 0.25), (0, 0, 0.25 + EPS), True, False),
        ((0, 0, 0.25 + 1e-15), (0, 0, 0), False, False),
    ],
)
def test_is_reached_boundaries(pose, vel, simple, stopped):
    assert _both(pose, ORIGIN, vel) == (simple, stopped)


def test_symmetric_yaw_tolerance_accepts_the_reversed_goal():
    pose = (0.0, 0.0, 0.25 + math.pi)
    assert not SimpleGoalChecker(GoalCheckerParams()).is_goal_reached(pose, ORIGIN, ORIGIN)
    sym = SimpleGoalChecker(GoalCheckerParams(symmetric_yaw_tolerance=True))
    assert sym.is_goal_reached(pose, ORIGIN, ORIGIN)
    assert not sym.is_goal_reached((0.0, 0.0, 0.26 + math.pi), ORIGIN, ORIGIN)


def test_stateful_latch_holds_until_reset():
    gc = SimpleGoalChecker(GoalCheckerParams())
    goal = (1.0, 0.0, math.pi / 2)
    assert not gc.is_goal_reached((0.9, 0.0, 0.0), goal, ORIGIN)  # xy in, yaw out: latched
    assert gc.check_xy is False
    # drifted out of xy tolerance while rotating: still reached once the yaw is right
    assert gc.is_goal_reached((0.6, 0.0, math.pi / 2), goal, ORIGIN)
    gc.reset()
    assert not gc.is_goal_reached((0.6, 0.0, math.pi / 2), goal, ORIGIN)
    stateless = SimpleGoalChecker(GoalCheckerParams(stateful=False))
    assert not stateless.is_goal_reached((0.9, 0.0, 0.0), goal, ORIGIN)
    assert not stateless.is_goal_reached((0.6, 0.0, math.pi / 2), goal, ORIGIN)


def test_position_goal_checker_ignores_yaw_and_latches():
    pc = PositionGoalChecker(GoalCheckerParams(plugin="nav2_controller::PositionGoalChecker"))
    assert pc.is_goal_reached((0.25, 0.0, 3.0), ORIGIN, ORIGIN)
    assert pc.is_goal_reached((5.0, 0.0, 0.0), ORIGIN, ORIGIN)  # latched
    pc.reset()
    assert not pc.is_goal_reached((0.25 + EPS, 0.0, 0.0), ORIGIN, ORIGIN)
    assert pc.yaw_goal_tolerance == 0.0 and pc.xy_goal_tolerance == 0.25


def _check(pc, pose1, delay_ms):
    """Nav2's checkMacro: reset, check at the origin at t0, then ``pose1`` ``delay_ms`` later."""
    pc.reset()
    t0 = 7 * 1_000_000_000
    assert pc.check(ORIGIN, t0)
    return pc.check(pose1, t0 + delay_ms * MS)


@pytest.mark.parametrize("cls", [SimpleProgressChecker, PoseProgressChecker])
def test_progress_allowance(cls):
    pc = cls(ProgressCheckerParams(movement_time_allowance=0.1))
    for pose in [(0, 0, 0), (0.25, 0, 0), (0, 0.25, 0), (1, 0, 0), (0, 1, 0)]:
        assert _check(pc, pose, 50)  # within half the allowance: passes
    for pose in [(0, 0, 0), (0.25, 0, 0), (0, 0.25, 0)]:
        assert not _check(pc, pose, 200)
    for pose in [(1, 0, 0), (0, 1, 0)]:
        assert _check(pc, pose, 200)
    assert _check(pc, (0, 0, 0), 100)  # exactly the allowance still passes (<=)
    assert not _check(pc, (0, 0, 0), 101)


def test_progress_radius_is_strict_and_negative_always_passes():
    r = 0.25
    pc = SimpleProgressChecker(ProgressCheckerParams(required_movement_radius=r, movement_time_allowance=0.05))
    ax = r / math.sqrt(2)
    for pose in [(0, 0, 0), (r, 0, 0), (0, r, 0), (ax, ax, 0)]:
        assert not _check(pc, pose, 100)
    for pose in [(r + EPS, 0, 0), (0, r + EPS, 0), (ax + EPS, ax + EPS, 0)]:
        assert _check(pc, pose, 100)
    neg = SimpleProgressChecker(ProgressCheckerParams(required_movement_radius=-r, movement_time_allowance=0.05))
    for pose in [(0, 0, 0), (r, 0, 0), (0, r, 0), (ax, ax, 0)]:
        assert _check(neg, pose, 100)


def test_pose_progress_counts_rotation():
    params = ProgressCheckerParams(movement_time_allowance=0.1)
    assert not _check(PoseProgressChecker(params), (0, 0, 0.25), 200)
    assert _check(PoseProgressChecker(params), (0, 0, 1.0), 200)
    assert not _check(SimpleProgressChecker(params), (0, 0, 1.0), 200)  # the simple checker ignores rotation


def test_baseline_moves_with_progress():
    pc = SimpleProgressChecker(ProgressCheckerParams())  # 0.5 m in 10 s
    s = 1_000_000_000
    assert pc.check((0.0, 0.0, 0.0), 0)
    assert pc.check((0.6, 0.0, 0.0), 9 * s)  # moved: new baseline at 9 s
    assert pc.check((0.7, 0.0, 0.0), 19 * s)
    assert not pc.check((0.7, 0.0, 0.0), 19 * s + 1)


def test_normalize_angle_matches_ros_angles():
    assert normalize_angle(math.pi) == -math.pi
    assert normalize_angle(-math.pi) == -math.pi
    assert normalize_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)


def test_checkers_are_registered_and_built_from_a_file():
    text = """
controller_server:
  ros__parameters:
    goal_checker_plugins: ["general_goal_checker", "precise"]
    progress_checker_plugins: ["progress_checker"]
    general_goal_checker:
      plugin: "nav2_controller::SimpleGoalChecker"
      xy_goal_tolerance: 0.3
      symmetric_yaw_tolerance: true
    precise:
      plugin: "nav2_controller::StoppedGoalChecker"
      trans_stopped_velocity: 0.1
    progress_checker:
      plugin: "nav2_controller::PoseProgressChecker"
      required_movement_radius: 0.4
"""
    cs = parse_nav2_text(text).require_valid().controller_server
    gparams = cs.goal_checkers["general_goal_checker"]
    gc = GOAL_CHECKERS.create(gparams.plugin, gparams)
    assert type(gc) is SimpleGoalChecker and gc.xy_goal_tolerance == 0.3
    assert gc.is_goal_reached((0.3, 0.0, math.pi), ORIGIN, ORIGIN)
    assert type(GOAL_CHECKERS.create(cs.goal_checkers["precise"].plugin, cs.goal_checkers["precise"])) is (
        StoppedGoalChecker
    )
    pparams = cs.progress_checkers["progress_checker"]
    assert type(PROGRESS_CHECKERS.create(pparams.plugin, pparams)) is PoseProgressChecker
    assert GOAL_CHECKERS.implementation("nav2_controller/PositionGoalChecker") is PositionGoalChecker
