"""``MPPIController``: no valid control, reproducibility, closed loop."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.controllers.base import ControlContext, ControllerSetup, NoValidControl
from navlog.replay.nav2.controllers.mppi.controller import MPPIController
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
from navlog.replay.nav2.costmap.inflation_layer import inflation_costs
from tests.replay.nav2.controllers.mppi.unit_setup import JAZZY_ARTICLE, Tolerance, local_costmap


def test_all_trajectories_colliding_is_no_valid_control_after_the_retries():
    ctl = MPPIController(MPPIParams(critics=("CostCritic",), batch_size=50), ControllerSetup())
    cm = local_costmap()
    cm.costs[:] = 254
    ctl.set_plan(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    ctx = ControlContext(0, cm, np.eye(3), Tolerance())
    with pytest.raises(NoValidControl) as err:
        ctl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ctx)
    assert err.value.code == 106


def _run(params: MPPIParams, seed: int, cycles: int) -> list[tuple[float, float, float]]:
    ctl = MPPIController(params, ControllerSetup(seed=seed))
    ctl.set_plan(np.column_stack([np.arange(0, 2.0, 0.05), np.zeros(40), np.zeros(40)]))
    ctx = ControlContext(0, local_costmap(), np.eye(3), Tolerance())
    return [ctl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ctx).cmd for _ in range(cycles)]


@pytest.mark.parametrize("name", ["seed001", "bringup"])
def test_same_seed_same_commands_bit_for_bit(name, request):
    if name == "seed001":
        path = JAZZY_ARTICLE
    else:
        path = (
            request.getfixturevalue("shared_dir") / "external-data" / "params" / "nav2_bringup_jazzy_nav2_params.yaml"
        )
    loaded = load_nav2_params(path)
    assert loaded.errors == []
    p = loaded.controller_server.controllers["FollowPath"]
    a, b, c = _run(p, 7, 3), _run(p, 7, 3), _run(p, 8, 3)
    assert a == b
    assert a != c
    assert a[-1][0] > 0.05  # it drives forward along the plan


def _world(clutter: bool) -> CostmapGrid:
    """A 6 x 6 m local costmap (resolution 0.05), free or with two boxes by the L, inflated as Nav2 does."""
    from scipy.ndimage import distance_transform_edt

    cm = local_costmap()
    lethal = np.zeros_like(cm.costs, dtype=bool)
    if clutter:
        # boxes 0.6 m from the path, as a planner on a costmap inflated to 0.7 m leaves them
        lethal[np.ix_(range(50, 58), range(92, 98))] = True  # x 1.6..1.9, y -0.5..-0.1: beside the 2nd leg
        lethal[np.ix_(range(26, 28), range(50, 56))] = True  # x -0.5..-0.2, y -1.7..-1.6: below the 1st leg
        lethal[np.ix_(range(66, 72), range(62, 68))] = True  # x 0.1..0.4, y 0.3..0.6: inside the corner, ahead
    if lethal.any():
        d = distance_transform_edt(~lethal)
        inflated = inflation_costs(d, cm.resolution, 0.22, 3.0)
        inflated[d * cm.resolution > 0.7] = 0
        cm.costs[:] = inflated
    return cm


def _l_path() -> np.ndarray:
    """An L from (-1, -1) east to (1, -1), then north to (1, 1), its corner rounded (radius 0.5) as a smoothed plan."""
    s = np.arange(0.0, 1.5, 0.05)
    leg1 = np.column_stack([-1.0 + s, np.full_like(s, -1.0), np.zeros_like(s)])
    a = np.linspace(0.0, math.pi / 2, 16)[:-1]
    arc = np.column_stack([0.5 + 0.5 * np.sin(a), -0.5 - 0.5 * np.cos(a), a])
    s = np.arange(0.0, 1.5 + 1e-9, 0.05)
    leg2 = np.column_stack([np.ones_like(s), -0.5 + s, np.full_like(s, math.pi / 2)])
    return np.vstack([leg1, arc, leg2])


@pytest.mark.parametrize("clutter", [False, True])
def test_closed_loop_follows_an_l_shaped_path(clutter):
    p = load_nav2_params(JAZZY_ARTICLE).controller_server.controllers["FollowPath"]
    p = dataclasses.replace(p, batch_size=1000)
    path = _l_path()
    cm = _world(clutter)
    ctl = MPPIController(p, ControllerSetup(seed=3, robot_radius=0.22))
    ctl.set_plan(path)
    x, y, yaw = -1.0, -1.0, 0.0
    v = (0.0, 0.0, 0.0)
    worst = 0
    for _ in range(300):  # 15 s
        if math.hypot(x - 1.0, y - 1.0) < 0.25:
            break
        ctx = ControlContext(0, cm, np.eye(3), Tolerance())
        v = ctl.compute_velocity_commands((x, y, yaw), v, ctx).cmd
        for _ in range(5):  # the unicycle, integrated at 10 ms
            x += v[0] * math.cos(yaw) * 0.01
            y += v[0] * math.sin(yaw) * 0.01
            yaw += v[2] * 0.01
            worst = max(worst, cm.cost_at(x, y) or 0)
    assert math.hypot(x - 1.0, y - 1.0) < 0.25
    assert worst < 253  # the robot's circle never overlapped a lethal cell


def _go2_turns_into_a_goal(**mppi_changes) -> tuple[float | None, float]:
    """config/nav2/nav_go2_mppi.yaml drives the Go2 (go2.yaml's first-order response and accelerations, behind
    the file's velocity smoother, replanned at 1 Hz) at 0.3 m/s along a straight plan east into nav_tour's
    inner_southeast goal (1.2, -1.0), whose heading 1.571 is 90 degrees to the plan. Returns the time at which
    the file's goal checker succeeds (None: not within 10 s) and how far the robot ran past the goal."""
    import yaml

    from navlog.replay.config import find_config
    from navlog.replay.nav2.controllers.checkers import SimpleGoalChecker
    from navlog.replay.nav2.velocity_smoother import VelocitySmoother

    nav2_file, robot_file = find_config("nav2", "nav_go2_mppi"), find_config("robots", "go2")
    assert nav2_file is not None and robot_file is not None
    loaded = load_nav2_params(nav2_file)
    assert loaded.errors == [] and loaded.velocity_smoother is not None
    server = loaded.controller_server
    params = dataclasses.replace(server.controllers["FollowPath"], **mppi_changes)
    checker = SimpleGoalChecker(server.goal_checkers["general_goal_checker"])
    smoother = VelocitySmoother(loaded.velocity_smoother)
    robot = yaml.safe_load(robot_file.read_text())
    dt = robot["timestep"]
    gain = dt / robot["drive"]["response_time"]
    acc = [a * dt for a in robot["drive"]["max_accel"]]
    gx, gy, gyaw = 1.2, -1.0, 1.571
    s = np.arange(0.0, 1.0 + 1e-9, 0.025)
    plan = np.column_stack([0.2 + s, np.full_like(s, gy), np.zeros_like(s)])
    plan[-1, 2] = gyaw
    ctl = MPPIController(params, ControllerSetup(seed=1, robot_radius=0.22, controller_frequency=20.0))
    cm = CostmapGrid(CostmapParams(width=6, height=6, resolution=0.05, origin_x=-3.0, origin_y=-3.0, robot_radius=0.22))
    x, y, yaw, vx, wz = 0.2, gy, 0.0, 0.3, 0.0
    past = 0.0
    steps = round(0.05 / dt)
    for k in range(200):  # 10 s at 20 Hz
        if k % 20 == 0:  # the 1 Hz replan: a new plan resets the goal checker
            ctl.set_plan(plan)
            checker.reset()
        if checker.is_goal_reached((x, y, yaw), (gx, gy, gyaw), (vx, 0.0, wz)):
            return k * 0.05, past
        cmd = ctl.compute_velocity_commands((x, y, yaw), (vx, 0.0, wz), ControlContext(0, cm, np.eye(3), checker)).cmd
        smoother.set_command(cmd, k * 50_000_000)
        out = smoother.tick(k * 50_000_000)
        assert out is not None
        for _ in range(steps):
            vx += min(max(gain * (out.values[0] - vx), -acc[0]), acc[0])
            wz += min(max(gain * (out.values[2] - wz), -acc[2]), acc[2])
            x, y, yaw = x + vx * math.cos(yaw) * dt, y + vx * math.sin(yaw) * dt, yaw + wz * dt
            past = max(past, x - gx)
    return None, past


def test_go2_file_stops_on_a_turned_goal_and_turns_there():
    reached, past = _go2_turns_into_a_goal()
    assert reached is not None and reached < 6.0  # within 0.15 m and 0.25 rad of the goal
    assert past < 0.1


def test_go2_accelerations_in_the_motion_model_run_past_a_turned_goal():
    # the Go2's accelerations clamp the sampled controls: it arcs past the goal while turning and stays beside it
    reached, past = _go2_turns_into_a_goal(ax_max=1.0, ax_min=-1.0, az_max=2.0)
    assert past > 0.15
    assert reached is None
