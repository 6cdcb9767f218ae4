"""The controller server's cycle (Nav2's computeControl order) with a fake controller plugin."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2.controllers.base import (
    ControlContext,
    ControllerError,
    ControllerSetup,
    ControlResult,
    NoValidControl,
    se2,
)
from navlog.replay.nav2.controllers.checkers import GoalCheckerParams, ProgressCheckerParams
from navlog.replay.nav2.controllers.controller_server import (
    FAILED,
    FAILED_TO_MAKE_PROGRESS,
    INVALID_PATH,
    NO_VALID_CONTROL,
    PATIENCE_EXCEEDED,
    RUNNING,
    SUCCEEDED,
    TF_ERROR,
    ControllerServer,
    thresholded,
)
from navlog.replay.nav2.controllers.registry import CONTROLLERS
from navlog.replay.nav2.controllers.server import ControllerServerParams
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
from navlog.replay.nav2.plugins import Plugin, PluginParams

S = 1_000_000_000
MS = 1_000_000
FAKE = "navlog_test::FakeController"


@dataclass(frozen=True)
class FakeParams(PluginParams):
    plugin: str = FAKE


class FakeController:
    """Drives straight at 0.3 m/s; ``fail`` makes the next calls raise it; records every call."""

    instances: list[FakeController] = []  # noqa: RUF012 - the test reads the last one built

    def __init__(self, params: FakeParams, setup: ControllerSetup) -> None:
        self.calls: list[tuple] = []
        self.plans: list[np.ndarray] = []
        self.resets = 0
        self.fail: ControllerError | None = None
        FakeController.instances.append(self)

    def set_plan(self, path: np.ndarray) -> None:
        self.plans.append(path)

    def compute_velocity_commands(self, pose, velocity, ctx) -> ControlResult:
        self.calls.append((ctx.now_ns, pose, velocity))
        if self.fail is not None:
            raise self.fail
        return ControlResult(cmd=(0.3, 0.0, 0.0), local_plan=np.zeros((0, 3)))

    def reset(self) -> None:
        self.resets += 1


@pytest.fixture(autouse=True)
def fake_plugin(monkeypatch):
    monkeypatch.setitem(CONTROLLERS._plugins, FAKE, Plugin(FakeParams, FakeController))


def server(failure_tolerance=0.0, goal=None, progress=None, **kw):
    params = ControllerServerParams(
        failure_tolerance=failure_tolerance,
        controllers={"FollowPath": FakeParams()},
        goal_checkers={"goal_checker": goal or GoalCheckerParams()},
        progress_checkers={"progress_checker": progress or ProgressCheckerParams()},
        **kw,
    )
    cs = ControllerServer(params, ControllerSetup())
    return cs, FakeController.instances[-1]


CM = CostmapGrid(CostmapParams())


def ctx(t, T=None):
    return ControlContext(now_ns=t, costmap=CM, global_to_local=np.eye(3) if T is None else T, goal_checker=None)


PATH = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])


def test_goal_is_checked_before_any_command():
    cs, fake = server()
    cs.follow_path(PATH, 0)
    out = cs.cycle(0, (1.9, 0.1, 0.1), (0.5, 0.0, 0.0), ctx(0))
    assert (out.status, out.cmd, out.code) == (SUCCEEDED, (0.0, 0.0, 0.0), 0)
    assert fake.calls == [] and fake.resets == 1 and not cs.active


def test_running_cycle_passes_thresholded_twist_and_reports_distance():
    cs, fake = server()
    cs.follow_path(PATH, 0)
    out = cs.cycle(50 * MS, (0.98, 0.0, 0.0), (0.00005, 0.0002, 0.2), ctx(50 * MS))
    assert out.status == RUNNING and out.cmd == (0.3, 0.0, 0.0)
    assert fake.calls == [(50 * MS, (0.98, 0.0, 0.0), (0.0, 0.0002, 0.2))]
    assert out.distance_to_goal == pytest.approx(1.0)  # from the plan pose nearest the robot (1, 0)
    assert thresholded((0.0001, -0.00011, 0.0001), ControllerServerParams()) == (0.0, -0.00011, 0.0)


def test_goal_end_pose_is_taken_into_the_local_frame():
    cs, _ = server()
    cs.follow_path(PATH, 0)
    T = se2(-1.0, 0.5, 0.0)  # map -> odom: the plan's end (2, 0) is (1, 0.5) in odom
    assert cs.cycle(0, (2.0, 0.0, 0.0), (0, 0, 0), ctx(0, T)).status == RUNNING
    assert cs.cycle(50 * MS, (1.0, 0.5, 0.0), (0, 0, 0), ctx(50 * MS, T)).status == SUCCEEDED


def test_no_progress_fails_with_105_after_the_allowance():
    cs, fake = server()  # 0.5 m in 10 s
    cs.follow_path(PATH, 0)
    t = 0
    while t <= 10 * S:
        assert cs.cycle(t, (0.0, 0.0, 0.0), (0, 0, 0), ctx(t)).status == RUNNING
        t += 50 * MS
    out = cs.cycle(t, (0.0, 0.0, 0.0), (0, 0, 0), ctx(t))
    assert (out.status, out.code, out.cmd) == (FAILED, FAILED_TO_MAKE_PROGRESS, (0.0, 0.0, 0.0))
    assert fake.resets == 1


def test_no_valid_control_without_tolerance_fails_at_once():
    cs, fake = server(failure_tolerance=0.0)
    cs.follow_path(PATH, 0)
    fake.fail = NoValidControl("blocked")
    out = cs.cycle(0, (0.0, 0.0, 0.0), (0, 0, 0), ctx(0))
    assert (out.status, out.code, out.message) == (FAILED, NO_VALID_CONTROL, "blocked")


def test_failure_tolerance_gives_zero_commands_then_patience_exceeded():
    cs, fake = server(failure_tolerance=0.3)
    cs.follow_path(PATH, 0)
    assert cs.cycle(0, (0.0, 0.0, 0.0), (0, 0, 0), ctx(0)).cmd == (0.3, 0.0, 0.0)  # last valid at 0
    fake.fail = NoValidControl("blocked")
    statuses = []
    for k in range(1, 8):
        out = cs.cycle(k * 50 * MS, (0.0, 0.0, 0.0), (0, 0, 0), ctx(k * 50 * MS))
        statuses.append((out.status, out.cmd))
    # 0.05 .. 0.30 s: zero command, still running; 0.35 s > 0.3 s: PATIENCE_EXCEEDED
    assert statuses[:6] == [(RUNNING, (0.0, 0.0, 0.0))] * 6
    assert statuses[6] == (FAILED, (0.0, 0.0, 0.0)) and out.code == PATIENCE_EXCEEDED


def test_failure_tolerance_minus_one_waits_forever():
    cs, fake = server(failure_tolerance=-1.0, progress=ProgressCheckerParams(movement_time_allowance=1000.0))
    cs.follow_path(PATH, 0)
    fake.fail = NoValidControl("blocked")
    assert all(cs.cycle(k * S, (0.0, 0.0, 0.0), (0, 0, 0), ctx(k * S)).status == RUNNING for k in range(100))


def test_controller_error_fails_with_its_code():
    cs, fake = server()
    cs.follow_path(PATH, 0)
    err = ControllerError("plan is off the costmap")
    err.code = INVALID_PATH
    fake.fail = err
    out = cs.cycle(0, (0.0, 0.0, 0.0), (0, 0, 0), ctx(0))
    assert (out.status, out.code) == (FAILED, INVALID_PATH)


def test_empty_path_and_missing_pose():
    cs, _ = server()
    cs.follow_path(np.zeros((0, 3)), 0)
    assert cs.cycle(0, (0.0, 0.0, 0.0), (0, 0, 0), ctx(0)).code == INVALID_PATH
    cs.follow_path(PATH, 0)
    assert cs.cycle(0, None, (0, 0, 0), ctx(0)).code == TF_ERROR


def test_preemption_resets_goal_checker_not_progress_checker():
    cs, fake = server()
    cs.follow_path(PATH, 0)
    # xy reached, yaw 1 rad off: the stateful latch is set, only yaw is checked from now on
    assert cs.cycle(0, (2.0, 0.0, 1.0), (0, 0, 0), ctx(0)).status == RUNNING
    assert cs.goal_checker.check_xy is False
    assert cs.cycle(50 * MS, (2.3, 0.0, 1.0), (0, 0, 0), ctx(50 * MS)).status == RUNNING
    assert cs.goal_checker.check_xy is False  # drifted out of xy: still latched
    cs.follow_path(PATH.copy(), 5 * S)  # a replan: taken at the next cycle
    assert len(fake.plans) == 1 and cs.goal_checker.check_xy is False
    assert cs.cycle(5 * S, (2.3, 0.0, 1.0), (0, 0, 0), ctx(5 * S)).status == RUNNING
    assert len(fake.plans) == 2 and cs.goal_checker.check_xy is True  # reset: xy checked again
    # the progress baseline still dates from t = 0 (a replan does not reset it): fails after 10 s
    t = 10 * S + 50 * MS
    assert cs.cycle(t, (2.0, 0.0, 1.0), (0, 0, 0), ctx(t)).code == FAILED_TO_MAKE_PROGRESS


def test_unknown_or_ambiguous_ids_are_config_errors():
    with pytest.raises(ConfigError, match="did you mean 'FollowPath'"):
        ControllerServer(
            ControllerServerParams(controllers={"FollowPath": FakeParams()}),
            ControllerSetup(),
            controller_id="FolowPath",
        )
    params = ControllerServerParams(
        controllers={"FollowPath": FakeParams()},
        goal_checker_plugins=("a", "b"),
        goal_checkers={"a": GoalCheckerParams(), "b": GoalCheckerParams()},
        progress_checkers={"progress_checker": ProgressCheckerParams()},
    )
    with pytest.raises(ConfigError, match="lists 2 goal checkers"):
        ControllerServer(params, ControllerSetup())
    assert ControllerServer(params, ControllerSetup(), goal_checker_id="b").goal_checker_id == "b"
    # a controller whose plugin navlog reads but does not run (no parameters in the dict)
    with pytest.raises(ConfigError, match="has no parameters navlog read"):
        ControllerServer(ControllerServerParams(), ControllerSetup())


def test_default_params_build_the_simple_checkers():
    cs, _ = server()
    assert type(cs.goal_checker).__name__ == "SimpleGoalChecker"
    assert type(cs.progress_checker).__name__ == "SimpleProgressChecker"


def test_regulated_pure_pursuit_follows_an_l_path_to_success():
    from navlog.replay.nav2.controllers.regulated_pure_pursuit import RegulatedPurePursuitParams

    params = ControllerServerParams(
        controllers={"FollowPath": RegulatedPurePursuitParams()},
        goal_checkers={"goal_checker": GoalCheckerParams()},
        progress_checkers={"progress_checker": ProgressCheckerParams()},
    )
    cm = CostmapGrid(CostmapParams(width=8, height=8, resolution=0.05, origin_x=-2.0, origin_y=-2.0, robot_radius=0.2))
    cs = ControllerServer(params, ControllerSetup(robot_radius=0.2))
    leg1 = np.column_stack([np.arange(0.0, 3.0, 0.05), np.zeros(60), np.zeros(60)])
    leg2 = np.column_stack([np.full(41, 3.0), np.arange(0.0, 2.05, 0.05), np.full(41, math.pi / 2)])
    cs.follow_path(np.vstack([leg1, leg2]), 0)
    x, y, yaw, v, w = 0.0, 0.0, 0.0, 0.0, 0.0
    for k in range(600):  # 30 s at 20 Hz
        t = k * 50 * MS
        c = ControlContext(now_ns=t, costmap=cm, global_to_local=np.eye(3), goal_checker=cs.goal_checker)
        out = cs.cycle(t, (x, y, yaw), (v, 0.0, w), c)
        if out.status != RUNNING:
            break
        v, _, w = out.cmd
        x, y, yaw = x + v * 0.05 * math.cos(yaw), y + v * 0.05 * math.sin(yaw), yaw + w * 0.05
    assert out.status == SUCCEEDED and out.cmd == (0.0, 0.0, 0.0)
    assert math.hypot(x - 3.0, y - 2.0) <= 0.25 and abs(yaw - math.pi / 2) <= 0.25
    assert 10 < k * 0.05 < 20  # 5 m at up to 0.5 m/s, slowed in the turn and on approach
