"""MPPI: Nav2's critic and optimizer test vectors (nav2_mppi_controller/test), reproducibility, closed loop."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2 import load_nav2_params, parse_nav2_text
from navlog.replay.nav2.controllers import mppi
from navlog.replay.nav2.controllers.base import ControlContext, ControllerSetup, NoValidControl
from navlog.replay.nav2.controllers.mppi import (
    CRITICS,
    CostCriticParams,
    CriticData,
    InvalidPath,
    MPPIController,
    MPPIParams,
    Optimizer,
)
from navlog.replay.nav2.controllers.registry import CONTROLLERS
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
from navlog.replay.nav2.costmap.inflation_layer import InflationLayerParams, inflation_costs

DATA = Path(__file__).resolve().parents[1] / "data"
JAZZY_ARTICLE = Path(__file__).resolve().parents[4] / "config" / "nav2" / "simple_robot_jazzy.yaml"  # seed 001's file
B, T, DT = 1000, 30, 0.1  # the critic tests' batch, time steps and model_dt


class Tolerance:
    xy_goal_tolerance = 0.25  # Nav2's TestGoalChecker
    yaw_goal_tolerance = 0.25


def _nav2_test_costmap() -> CostmapGrid:
    """Nav2's dummy costmap of the unit tests: 5 x 5 m at 0.1 m, origin (0, 0), free."""
    return CostmapGrid(CostmapParams(width=5, height=5, resolution=0.1))


def _data(pose=(0.0, 0.0, 0.0), goal=(0.0, 0.0), path=None, holonomic=False, **arrays) -> CriticData:
    zeros = np.zeros((B, T), dtype=np.float32)
    a = {k: arrays.get(k, zeros).astype(np.float32) for k in ("vx", "vy", "wz", "x", "y", "yaw")}
    path = np.zeros((10, 3)) if path is None else path
    return CriticData(
        pose=pose,
        goal=goal,
        path=path,
        model_dt=DT,
        costmap=_nav2_test_costmap(),
        goal_xy_tolerance=Tolerance.xy_goal_tolerance,
        holonomic=holonomic,
        **a,
    )


def _critic(name: str, mppi: MPPIParams | None = None, **params):
    ptype, ctype = CRITICS[name]
    return ctype(ptype(**params), mppi or MPPIParams(), ControllerSetup())


def _full(value: float) -> np.ndarray:
    return np.full((B, T), value, dtype=np.float32)


# ---------------------------------------------------------------- critics (critics_tests.cpp)


def test_constraint_critic_vectors():
    # the unit test has no optimizer: vy_max falls back to 0, so vmax = vx_max = 0.5
    c = _critic("ConstraintCritic", MPPIParams(vy_max=0.0))
    d = _data(vx=_full(0.4), wz=_full(1.0))
    c.score(d)
    assert d.costs.sum() == pytest.approx(0.0, abs=1e-6)
    vx = _full(0.4)
    vx[-1] = 0.6
    d = _data(vx=vx)
    c.score(d)
    assert d.costs[-1] == pytest.approx(1.2, abs=1e-4)  # 4.0 * 0.1 excess * 0.1 dt * 30
    assert d.costs[:-1].sum() == 0.0
    vx[-1] = -0.45
    d = _data(vx=vx)
    c.score(d)
    assert d.costs[-1] == pytest.approx(1.2, abs=1e-4)


def test_constraint_critic_in_the_controller_counts_vy_max():
    # in the controller the optimizer declares vy_max 0.5 first: vmax = hypot(0.5, 0.5) even for DiffDrive
    c = _critic("ConstraintCritic")
    d = _data(vx=_full(0.6))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = _data(vx=_full(0.75))
    c.score(d)
    assert d.costs[0] == pytest.approx(4.0 * (0.75 - math.sqrt(0.5)) * DT * T, abs=1e-4)


def test_constraint_critic_ackermann():
    c = _critic("ConstraintCritic", MPPIParams(motion_model="Ackermann", vy_max=0.0))
    d = _data(vx=_full(0.4), wz=_full(2.5))
    c.score(d)
    assert d.costs[1] == pytest.approx(0.48, abs=1e-4)  # (0.2 - 0.4 / 2.5) * 0.1 * 30 * 4


def test_goal_angle_critic_vector():
    path = np.zeros((10, 3))
    path[9] = (10.0, 0.0, 3.14)
    c = _critic("GoalAngleCritic")
    for x, expected in ((1.0, 0.0), (9.2, 0.0), (9.7, 9.42)):
        d = _data(pose=(x, 0.0, 0.0), goal=(10.0, 0.0), path=path)
        c.score(d)
        assert d.costs[0] == pytest.approx(expected, abs=0.02)


def test_goal_critic_vector():
    c = _critic("GoalCritic")
    d = _data(pose=(1.0, 0.0, 0.0), goal=(0.5, 0.0))
    c.score(d)
    assert d.costs[0] == pytest.approx(2.5, abs=1e-5)  # 0.5 m * weight 5
    assert d.costs.sum() == pytest.approx(2500.0, rel=1e-5)
    d = _data(pose=(10.0, 0.0, 0.0), goal=(0.5, 0.0))  # beyond threshold_to_consider 1.4
    c.score(d)
    assert d.costs.sum() == 0.0


def test_path_angle_critic_vectors():
    path = np.zeros((10, 3))
    path[9, 0] = 0.95
    cases = [(0, (1.0, 0.0), 0.0), (0, (-1.0, 4.0), 3.9947), (1, (1.0, 0.0), 0.0), (1, (-1.0, 0.0), 0.0)]
    cases += [(1, (-1.0, 4.0), 2.9167), (2, (1.0, 0.0), 0.0), (2, (-1.0, 0.0), 0.0), (2, (-1.0, 4.0), 2.9167)]
    for mode, point, expected in cases:
        path[6, :2] = point
        c = _critic("PathAngleCritic", mode=mode)
        d = _data(goal=(0.95, 0.0), path=path.copy())
        d.furthest = 2  # so it takes point 2 + offset_from_furthest 4 = 6
        c.score(d)
        assert d.costs[0] == pytest.approx(expected, abs=1e-2), (mode, point)
    # within the goal's threshold it does nothing
    d = _data(goal=(0.15, 0.0), path=path.copy())
    _critic("PathAngleCritic").score(d)
    assert d.costs.sum() == 0.0


def test_path_angle_mode_1_without_reversing_is_forward_preference():
    c = _critic("PathAngleCritic", MPPIParams(vx_min=0.0), mode=1)
    assert c.mode == 0


def test_prefer_forward_critic_vector():
    path = np.zeros((10, 3))
    c = _critic("PreferForwardCritic")
    d = _data(pose=(1.0, 0.0, 0.0), goal=(0.15, 0.0), path=path, vx=_full(1.0))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = _data(pose=(1.0, 0.0, 0.0), goal=(0.15, 0.0), path=path, vx=_full(-1.0))
    c.score(d)
    assert d.costs[0] == pytest.approx(15.0, abs=1e-3)  # 1.0 * 0.1 dt * 5.0 weight * 30


def test_twirling_critic_vector():
    c = _critic("TwirlingCritic")
    wz = np.zeros((B, T), dtype=np.float32)
    wz[0] = 10.0
    d = _data(pose=(1.0, 0.0, 0.0), goal=(0.15, 0.0), wz=wz)
    c.score(d)
    assert d.costs[0] == pytest.approx(100.0, abs=1e-4)
    assert d.costs[1:].sum() == 0.0
    d = _data(pose=(0.2, 0.0, 0.0), goal=(0.15, 0.0), wz=wz)  # inside the goal checker's 0.25 m
    c.score(d)
    assert d.costs.sum() == 0.0


def test_path_follow_critic_vector():
    c = _critic("PathFollowCritic")
    path = np.zeros((6, 3))
    path[5, 0] = 1.8
    d = _data(pose=(2.0, 0.0, 0.0), goal=(1.8, 0.0), path=path.copy())
    c.score(d)
    assert d.costs.sum() == 0.0
    path[5, 0] = 0.15
    d = _data(pose=(2.0, 0.0, 0.0), goal=(0.15, 0.0), path=path)
    c.score(d)
    assert d.costs.sum() == pytest.approx(750.0, abs=1e-2)  # 0.15 * 5 weight * 1000


def test_path_align_critic_vectors():
    c = _critic("PathAlignCritic")
    path = np.zeros((22, 3))
    path[:10, 0] = np.arange(10) * 0.1
    path[10:, 0] = 0.9
    # furthest reached point 0 < offset_from_furthest 20: nothing
    d = _data(goal=(0.9, 0.0), path=path, x=_full(0.66))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = _data(goal=(0.9, 0.0), path=path, x=_full(0.66))
    d.furthest = 21
    c.score(d)
    assert d.costs.sum() == pytest.approx(6600.0, rel=1e-5)  # 0.66 * 10 weight * 1000
    # the path blocked by a lethal island: too many invalid points, nothing
    d = _data(goal=(1.5, 0.0), path=np.full((22, 3), 1.5), x=_full(0.66))
    d.costmap.costs[11:31, 11:31] = 254
    d.furthest = 21
    c.score(d)
    assert d.costs.sum() == 0.0


def test_path_align_follows_integrated_length():
    # trajectories moving along x at 0.1 m per step on a path along x: aligned, so no cost;
    # the same trajectories 0.3 m to the side cost 0.3 * weight
    c = _critic("PathAlignCritic", offset_from_furthest=0)
    path = np.zeros((40, 3))
    path[:, 0] = np.arange(40) * 0.1
    x = np.tile(np.arange(T, dtype=np.float32) * 0.1, (B, 1))
    d = _data(goal=(3.9, 0.0), path=path, x=x)
    d.furthest = 30
    c.score(d)
    assert d.costs.max() == pytest.approx(0.0, abs=1e-4)
    d = _data(goal=(3.9, 0.0), path=path, x=x, y=_full(0.3))
    d.furthest = 30
    c.score(d)
    assert d.costs[0] == pytest.approx(3.0, abs=1e-4)


def test_velocity_deadband_critic_vector():
    c = _critic("VelocityDeadbandCritic", deadband_velocities=(0.08, 0.08, 0.08))
    d = _data(holonomic=True, vx=_full(0.8), vy=_full(0.6), wz=_full(0.8))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = _data(holonomic=True, vx=_full(0.01), vy=_full(0.02), wz=_full(0.021))
    c.score(d)
    assert d.costs[1] == pytest.approx(19.845, abs=0.01)  # 35 * 0.1 * (0.07 + 0.06 + 0.059) * 30


def test_furthest_reached_point_searches_from_the_running_maximum():
    path = np.zeros((5, 3))
    path[:, 0] = [0.0, 1.0, 2.0, 3.0, 4.0]
    x = np.zeros((3, T), dtype=np.float32)
    x[:, -1] = [2.1, 0.2, 3.2]  # nearest 2; then 0.2 searched from 2 -> 2; then 3
    d = CriticData((0, 0, 0), (4, 0), path, x * 0, x * 0, x * 0, x, x * 0, x * 0, DT)
    assert d.furthest_reached() == 3
    x[:, -1] = [2.1, 0.2, 0.1]
    d = CriticData((0, 0, 0), (4, 0), path, x * 0, x * 0, x * 0, x, x * 0, x * 0, DT)
    assert d.furthest_reached() == 2


# ---------------------------------------------------------------- cost critic


def test_cost_critic_costs_collisions_and_fail_flag():
    c = _critic("CostCritic")
    cm = _nav2_test_costmap()
    cm.costs[:, 20:25] = 100  # a band of inflation at x 2.0-2.5 m
    cm.costs[:, 40:42] = 254  # a wall at x 4.0-4.2 m
    x = np.full((B, T), 2.2, dtype=np.float32)
    x[1] = 0.5  # free
    x[2, 20:] = 4.1  # ends in the wall
    y = np.full((B, T), 1.0, dtype=np.float32)
    d = _data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=x, y=y)
    d.costmap = cm
    c.score(d)
    assert d.costs[0] == pytest.approx(3.81 / 254 * 100, rel=1e-5)  # every sampled point at 100
    assert d.costs[1] == 0.0
    assert d.costs[2] == pytest.approx(3.81 / 254 * 1e6 / 15, rel=1e-5)  # collision_cost / 15 samples
    assert d.fail_flag is False
    d = _data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=_full(4.1), y=y)
    d.costmap = cm
    c.score(d)
    assert d.fail_flag is True
    # near the goal, plain cost adds nothing; off the map is a collision (unknown space not tracked)
    d = _data(pose=(2.2, 1.0, 0.0), goal=(2.3, 1.0), x=x, y=y)
    d.costmap = cm
    c.score(d)
    assert d.costs[0] == 0.0
    d = _data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=_full(-1.0), y=y)
    c.score(d)
    assert d.fail_flag is True


def test_cost_critic_footprint_check_lets_a_polygon_pass_beside_an_inscribed_cell():
    # a 0.2 x 0.2 m square robot; an inscribed (253) cell under its centre but nothing under its outline
    setup = ControllerSetup(footprint=np.array([[0.1, 0.1], [0.1, -0.1], [-0.1, -0.1], [-0.1, 0.1]]))
    params = CostCriticParams(consider_footprint=True)
    critic = CRITICS["CostCritic"][1](params, MPPIParams(), setup)
    d = _data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=_full(2.05), y=_full(2.05))
    d.costmap.costs[20, 20] = 253
    critic.score(d)
    assert d.fail_flag is False and d.costs[0] == pytest.approx(3.81 / 254 * 300, rel=1e-5)  # critical_cost
    d = _data(pose=(0.2, 1.0, 0.0), goal=(4.5, 1.0), x=_full(2.05), y=_full(2.05))
    d.costmap.costs[20, 20] = 253
    d.costmap.costs[21, 19:23] = 254  # a lethal row under the square's top edge (y = 2.15)
    critic.score(d)
    assert d.fail_flag is True


# ---------------------------------------------------------------- optimizer (optimizer_unit_tests.cpp)


def _optimizer(freq: float = 30.0, critics=(), **params) -> Optimizer:
    p = MPPIParams(**params)
    setup = ControllerSetup(controller_frequency=freq)
    return Optimizer(p, setup, [_critic(n, p) for n in critics])


def test_speed_limit_vectors():
    o = _optimizer()
    o.set_speed_limit(50.0, True)
    assert (o.vx_max, o.vx_min) == pytest.approx((0.25, -0.175))
    o.set_speed_limit(0.75, False)
    assert (o.vx_max, o.vx_min) == pytest.approx((0.75, -0.525))
    o.set_speed_limit(0.0, True)
    assert (o.vx_max, o.vx_min, o.vy_max, o.wz_max) == pytest.approx((0.5, -0.35, 0.5, 1.9))


def test_apply_control_sequence_constraints_vector():
    o = _optimizer(motion_model="Omni", vx_max=1.0, vy_max=0.75, wz_max=2.0)
    o.u[:] = 5.0
    o.apply_constraints()
    assert np.allclose(o.u[0], 1.0) and np.allclose(o.u[1], 0.75) and np.allclose(o.u[2], 2.0)


def test_apply_constraints_acceleration_along_the_sequence():
    o = _optimizer(time_steps=5, model_dt=0.05)
    o.u[0] = [0.0, 0.5, 0.5, -0.3, -0.3]
    o.apply_constraints()
    assert o.u[0] == pytest.approx([0.0, 0.15, 0.3, 0.15, 0.0], abs=1e-6)  # ax 3.0 * dt 0.05 a step


def test_integrate_state_velocities_vectors():
    o = _optimizer(batch_size=1000, time_steps=50, model_dt=0.1)
    state = np.zeros((3, 1000, 50), dtype=np.float32)
    state[0, :, 1:] = 0.1
    x, y, yaw = o.integrate((0.0, 0.0, 0.0), state)
    assert np.allclose(x[1], np.arange(50) * 0.1 * 0.1, atol=1e-3) and not y.any() and not yaw.any()
    state[2, :, 1:] = 0.2
    x, y, yaw = o.integrate((0.0, 0.0, 0.0), state)
    i = np.arange(1, 50)
    assert np.allclose(x[1, 1:], np.cumsum(0.1 * np.cos(0.02 * (i - 1)) * 0.1), atol=1e-6)
    assert np.allclose(y[1, 1:], np.cumsum(0.1 * np.sin(0.02 * (i - 1)) * 0.1), atol=1e-6)
    omni = _optimizer(batch_size=1000, time_steps=50, model_dt=0.1, motion_model="Omni")
    state = np.zeros((3, 1000, 50), dtype=np.float32)
    state[0, :, 1:], state[1, :, 1:] = 0.1, 0.2
    x, y, _ = omni.integrate((0.0, 0.0, 0.0), state)
    assert np.allclose(x[1], np.arange(50) * 0.01, atol=1e-3) and np.allclose(y[1], np.arange(50) * 0.02, atol=1e-3)


def test_predict_clamps_to_the_acceleration_limits():
    o = _optimizer(batch_size=2, time_steps=6, model_dt=0.05)
    cv = np.ones((3, 2, 6), dtype=np.float32)
    state = o.predict(cv, (0.0, 0.0, 0.0))
    assert state[0, 0] == pytest.approx([0.0, 0.15, 0.3, 0.45, 0.6, 0.75], abs=1e-6)
    assert state[2, 0] == pytest.approx([0.0, 0.175, 0.35, 0.525, 0.7, 0.875], abs=1e-6)  # az 3.5 * 0.05
    assert cv[0, 0, :5] == pytest.approx(state[0, 0, 1:])  # the noised controls are overwritten
    cv = np.full((3, 2, 6), -1.0, dtype=np.float32)
    state = o.predict(cv, (0.3, 0.0, 0.0))  # braking from 0.3 m/s: decelerate by ax_min
    assert state[0, 0] == pytest.approx([0.3, 0.15, 0.0, -0.15, -0.3, -0.45], abs=1e-6)


@pytest.mark.parametrize("model", ["DiffDrive", "Omni"])
def test_compiled_predict_gives_the_numpy_bits(model, monkeypatch):
    o = _optimizer(batch_size=300, time_steps=56, model_dt=0.05, motion_model=model)
    cv = (np.random.default_rng(5).standard_normal((3, 300, 56)) * 0.5).astype(np.float32)
    compiled_cv = cv.copy()
    compiled_state = o.predict(compiled_cv, (0.3, 0.1, -0.2))
    monkeypatch.setattr(mppi, "_kernels", lambda: None)
    numpy_cv = cv.copy()
    numpy_state = o.predict(numpy_cv, (0.3, 0.1, -0.2))
    assert np.array_equal(compiled_cv, numpy_cv) and np.array_equal(compiled_state, numpy_state)
    assert np.abs(np.diff(numpy_state[0], axis=1)).max() <= 3.0 * 0.05 + 1e-6  # ax_max * dt a step


def test_softmax_update_with_injected_noise():
    # two rollouts, 10 steps (no smoothing), 30 Hz (no shift): row 0 reverses at 0.1 m/s, row 1 stands
    o = _optimizer(batch_size=2, time_steps=10, model_dt=0.05, critics=("PreferForwardCritic",))
    vx = np.zeros((2, 10))
    vx[0] = -0.1
    o.set_noises(vx, np.zeros((2, 10)), np.zeros((2, 10)))
    path = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    cmd = o.eval_control((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), path, (3.0, 0.0), _nav2_test_costmap())
    cost0 = 5.0 * 0.1 * 9 * 0.05  # PreferForward: weight * reverse speed * 9 steps * dt; no control cost (u = 0)
    w0 = math.exp(-cost0 / 0.3) / (1.0 + math.exp(-cost0 / 0.3))
    assert cmd[0] == pytest.approx(-0.1 * w0, abs=1e-6)
    assert cmd[1:] == (0.0, 0.0)


def test_savitzky_golay_smoothing_and_shift():
    # 20 Hz with model_dt 0.05: shift on, the command is element 1; zero history pulls the start down
    o = _optimizer(freq=20.0, batch_size=4, time_steps=25, model_dt=0.05)
    assert o.shift
    o.u[0] = 0.3
    o.set_noises(np.zeros((4, 25)), np.zeros((4, 25)), np.zeros((4, 25)))
    cmd = o.eval_control((0.0, 0.0, 0.0), (0.3, 0.0, 0.0), np.zeros((2, 3)), (3.0, 0.0), _nav2_test_costmap())
    assert cmd[0] == pytest.approx(0.3 * (54 + 59 + 54 + 39 + 14 - 21) / 231, abs=1e-6)  # 3 zeros of history
    assert o.history[-1, 0] == pytest.approx(cmd[0])
    assert o.u[0, -1] == pytest.approx(0.3) and o.u[0, -2] == pytest.approx(0.3)  # rolled, last duplicated


def test_controller_frequency_rule():
    assert not _optimizer(freq=30.0).shift  # period below model_dt: no shift
    with pytest.raises(ConfigError, match="controller_frequency to 20 Hz"):
        _optimizer(freq=10.0)


def _costmap(size: float = 6.0, res: float = 0.05, origin=(-3.0, -3.0)) -> CostmapGrid:
    params = CostmapParams(
        width=int(size), height=int(size), resolution=res, origin_x=origin[0], origin_y=origin[1], robot_radius=0.22
    )
    params = dataclasses.replace(
        params, layers={"inflation_layer": InflationLayerParams(inflation_radius=0.7, cost_scaling_factor=3.0)}
    )
    return CostmapGrid(params)


def test_all_trajectories_colliding_is_no_valid_control_after_the_retries():
    ctl = MPPIController(MPPIParams(critics=("CostCritic",), batch_size=50), ControllerSetup())
    cm = _costmap()
    cm.costs[:] = 254
    ctl.set_plan(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    ctx = ControlContext(0, cm, np.eye(3), Tolerance())
    with pytest.raises(NoValidControl) as err:
        ctl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ctx)
    assert err.value.code == 106


def test_path_handler_prunes_and_cuts_at_the_costmap():
    params = MPPIParams(critics=("PathFollowCritic",), batch_size=10, prune_distance=1.45)
    ctl = MPPIController(params, ControllerSetup())
    path = np.column_stack([np.arange(0, 5.0, 0.1), np.zeros(50), np.zeros(50)])
    ctl.set_plan(path)
    ctx = ControlContext(0, _costmap(), np.eye(3), Tolerance())
    result = ctl.compute_velocity_commands((1.02, 0.1, 0.0), (0.0, 0.0, 0.0), ctx)
    local = result.local_plan
    assert local[0, 0] == pytest.approx(1.0)  # the closest pose
    assert local[-1, 0] == pytest.approx(2.4)  # up to (not with) the first pose beyond prune_distance
    assert ctl.path_handler.plan[0, 0] == pytest.approx(1.0)  # the plan behind the robot is dropped
    # a plan in a frame moved by (-2.5, 0): its poses beyond the costmap (x >= 3) are cut
    shift = np.array([[1.0, 0.0, 2.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    ctl.set_plan(path)
    result = ctl.compute_velocity_commands(
        (2.0, 0.0, 0.0), (0.0, 0.0, 0.0), ControlContext(0, _costmap(), shift, Tolerance())
    )
    assert result.local_plan[-1, 0] < 3.0
    ctl.set_plan(np.zeros((0, 3)))
    with pytest.raises(InvalidPath) as err:
        ctl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ctx)
    assert err.value.code == 103


# ---------------------------------------------------------------- parameters


def test_seed_001_file_reads_every_critic_section_checked():
    p = load_nav2_params(JAZZY_ARTICLE)
    assert p.errors == []
    mppi = p.controller_server.controllers["FollowPath"]
    assert isinstance(mppi, MPPIParams) and mppi.batch_size == 2000 and mppi.regenerate_noises
    cost = mppi.critic_params["CostCritic"]
    assert isinstance(cost, CostCriticParams) and cost.consider_footprint and cost.near_goal_distance == 1.0
    assert mppi.critic_params["PathAlignCritic"].cost_weight == 14.0
    assert mppi.critic_params["PathAngleCritic"].max_angle_to_furthest == 1.0
    assert mppi.ackermann.min_turning_r == 0.2
    assert CONTROLLERS.implementation("nav2_mppi_controller::MPPIController") is MPPIController


def test_critic_typos_and_bad_values_are_reported():
    text = """
controller_server:
  ros__parameters:
    FollowPath:
      plugin: nav2_mppi_controller::MPPIController
      critics: [CostCritic, GoalCritik]
      CostCritic:
        cost_wieght: 3.0
        trajectory_point_step: 0
        near_collision_cost: 260
"""
    p = parse_nav2_text(text)
    msgs = {x.path.split("FollowPath.")[-1]: x.message for x in p.problems if x.severity == "error"}
    assert "did you mean 'GoalCritic'?" in msgs["critics"]
    assert "did you mean 'cost_weight'?" in msgs["CostCritic.cost_wieght"]
    assert "must be >= 1" in msgs["CostCritic.trajectory_point_step"]
    warnings = {x.path.split("FollowPath.")[-1]: x.message for x in p.problems if x.severity == "warning"}
    assert "critical_cost is never added" in warnings["CostCritic.near_collision_cost"]


def test_a_critic_navlog_does_not_run_is_a_clear_error():
    with pytest.raises(ConfigError, match="ObstaclesCritic' is read, not implemented by navlog; use one of"):
        MPPIController(MPPIParams(critics=("ObstaclesCritic",)), ControllerSetup())


# ---------------------------------------------------------------- determinism and closed loop


def _run(params: MPPIParams, seed: int, cycles: int) -> list[tuple[float, float, float]]:
    ctl = MPPIController(params, ControllerSetup(seed=seed))
    ctl.set_plan(np.column_stack([np.arange(0, 2.0, 0.05), np.zeros(40), np.zeros(40)]))
    ctx = ControlContext(0, _costmap(), np.eye(3), Tolerance())
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

    cm = _costmap()
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
