"""The compiled MPPI kernels against their NumPy oracles (``oracles.py``) on a real cycle's batch.

The clamp, the furthest reached path point and the CostCritic's sums give the oracles' bits; the poses
differ from NumPy's in the last bits of float32 (numba's cos and sin are not NumPy's), and the other
critics' per-trajectory sums are taken in float64 in order where NumPy sums float32 pairwise.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.controllers.base import ControllerSetup
from navlog.replay.nav2.controllers.mppi.critic_data import CriticData, compiled_furthest_reached_index
from navlog.replay.nav2.controllers.mppi.optimizer import Optimizer
from navlog.replay.nav2.costmap.inflation_layer import inflation_costs
from tests.replay.nav2.controllers.mppi.oracles import (
    numpy_cost_critic,
    numpy_furthest_reached,
    numpy_path_align,
    numpy_per_trajectory,
    numpy_rollouts,
)
from tests.replay.nav2.controllers.mppi.unit_setup import JAZZY_ARTICLE, local_costmap, make_critic

POSE, SPEED = (0.3, -0.2, 0.4), (0.25, 0.1, -0.3)
PATH = np.column_stack([np.linspace(0.3, 2.3, 41), np.linspace(-0.2, 0.6, 41), np.full(41, 0.38)])


def _optimizer(model: str) -> Optimizer:
    params = dataclasses.replace(
        load_nav2_params(JAZZY_ARTICLE).controller_server.controllers["FollowPath"], batch_size=400, motion_model=model
    )
    o = Optimizer(params, ControllerSetup(controller_frequency=30.0, seed=7), [])
    for _ in range(2):  # a control sequence away from zero
        o.eval_control(POSE, SPEED, PATH, (2.3, 0.6), local_costmap())
    o.noises = o.noises * np.float32(3.0)  # rows beyond the acceleration limits, some reversing
    return o


def _costmap():
    cm = local_costmap()
    yy, xx = np.mgrid[0 : cm.size_y, 0 : cm.size_x]
    d = np.hypot(xx - 80, yy - 62)  # a lethal cell at (1.0, 0.1), inflated to 0.7 m
    costs = inflation_costs(d, cm.resolution, 0.22, 3.0)
    costs[d * cm.resolution > 0.7] = 0
    cm.costs[:] = costs
    cm.costs[:, 110:] = 255  # unknown beyond x = 2.5
    return cm


@pytest.mark.parametrize("model", ["DiffDrive", "Omni"])
def test_rollout_kernel_against_the_numpy_oracle(model):
    o = _optimizer(model)
    oracle_cv, oracle_state, oracle_traj = numpy_rollouts(o, POSE, SPEED)
    cv, state, traj = o._noised_controls(POSE, SPEED)
    assert cv.tobytes() == oracle_cv.tobytes() and state.tobytes() == oracle_state.tobytes()
    assert np.abs(np.diff(state[0], axis=1)).max() <= o.p.ax_max * o.p.model_dt + 1e-6  # the clamp bit
    assert np.abs(traj - oracle_traj).max() < 2e-6  # float32 cos/sin last bits, summed over 56 steps
    assert np.abs(traj[:, :, 0] - np.float32(POSE)[:, None]).max() < 0.03  # one step from the pose
    assert o.integrate(POSE, state).tobytes() == traj.tobytes()  # integrate: the fused pass's arithmetic


def _data(o: Optimizer) -> CriticData:
    _, state, traj = o._noised_controls(POSE, SPEED)
    return CriticData(
        pose=POSE,
        goal=(2.3, 0.6),
        path=PATH,
        vx=state[0],
        vy=state[1],
        wz=state[2],
        x=traj[0],
        y=traj[1],
        yaw=traj[2],
        model_dt=o.p.model_dt,
        costmap=_costmap(),
        goal_xy_tolerance=0.25,
        holonomic=o.holonomic,
        costs=np.zeros(o.p.batch_size, dtype=np.float32),
    )


def test_furthest_reached_kernel_gives_the_oracle_index():
    data = _data(_optimizer("DiffDrive"))
    got = data.furthest_reached()
    assert got == numpy_furthest_reached(PATH, data.x[:, -1], data.y[:, -1]) and 0 < got < len(PATH) - 1
    shuffled = np.random.default_rng(3).permutation(len(data.x))  # the order of the rows matters
    ends = data.x[shuffled, -1], data.y[shuffled, -1]
    path = np.ascontiguousarray(PATH[:, :2].T)
    assert compiled_furthest_reached_index()(path[0], path[1], *ends) == numpy_furthest_reached(PATH, *ends)


def test_cost_critic_kernel_gives_the_oracle_sums():
    data = _data(_optimizer("DiffDrive"))
    critic = make_critic("CostCritic", trajectory_point_step=2, near_goal_distance=0.5)
    expected, fail = numpy_cost_critic(critic, data)
    critic.score(data)
    assert data.costs.tobytes() == (expected * (critic.p.cost_weight / 254.0)).astype(np.float32).tobytes()
    assert data.fail_flag == fail
    assert (expected == 1e6 / 28).any() and (expected < 1e6 / 28).any()  # some collide, some pass


@pytest.mark.parametrize("orientations", [False, True])
def test_path_align_kernel_against_the_oracle(orientations):
    data = _data(_optimizer("DiffDrive"))
    data.costmap.costs[:] = 0
    critic = make_critic("PathAlignCritic", offset_from_furthest=2, use_path_orientations=orientations)
    expected = numpy_path_align(critic, data)
    critic.score(data)
    assert expected.max() > 0.05
    np.testing.assert_allclose(data.costs, expected * critic.p.cost_weight, rtol=1e-6)


@pytest.mark.parametrize(
    ("name", "model"),
    [
        ("GoalCritic", "DiffDrive"),
        ("PreferForwardCritic", "DiffDrive"),
        ("TwirlingCritic", "DiffDrive"),
        ("VelocityDeadbandCritic", "Omni"),
        ("ConstraintCritic", "DiffDrive"),
        ("ConstraintCritic", "Omni"),
    ],
)
def test_batch_critic_kernels_against_the_oracles(name, model):
    o = _optimizer(model)
    data = _data(o)
    data.pose = (2.0, 0.5, 0.0)  # near the goal: every critic scores
    params = {"threshold_to_consider": 0.5} if name == "PreferForwardCritic" else {}
    if name == "VelocityDeadbandCritic":
        params = {"deadband_velocities": (0.05, 0.05, 0.07)}
    if name == "PreferForwardCritic":
        data.pose = POSE
    critic = make_critic(name, o.p, **params)
    expected = numpy_per_trajectory(name, critic, data)
    critic.score(data)
    assert expected.max() > 1e-3
    np.testing.assert_allclose(data.costs, expected * critic.p.cost_weight, rtol=2e-6, atol=1e-7)
