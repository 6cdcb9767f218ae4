"""The compiled MPPI kernels against their NumPy oracles (``oracles.py``) on real cycles' batches.

The rollouts (clamp, poses), the furthest reached path point and the CostCritic's sums give the oracles'
bits; the other critics' per-trajectory sums are taken in order where NumPy sums pairwise (float64 both).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.controllers.base import ControllerSetup
from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
from navlog.replay.nav2.controllers.mppi.optimizer import Optimizer
from navlog.replay.nav2.costmap.inflation_layer import inflation_costs
from tests.replay.nav2.controllers.mppi.oracles import oracle_factories
from tests.replay.nav2.controllers.mppi.unit_setup import JAZZY_ARTICLE, local_costmap, make_critic

POSE, SPEED = (0.3, -0.2, 0.4), (0.25, 0.1, -0.3)
PATH = np.column_stack([np.linspace(0.3, 2.3, 41), np.linspace(-0.2, 0.6, 41), np.full(41, 0.38)])


def _use_oracles(monkeypatch):
    for module, name, factory in oracle_factories():
        monkeypatch.setattr(module, name, factory)


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


def _data(o: Optimizer, pose=POSE) -> CriticData:
    _, state, traj = o._noised_controls(POSE, SPEED)
    return CriticData(
        pose=pose,
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


@pytest.mark.parametrize("model", ["DiffDrive", "Omni"])
def test_rollout_kernel_against_the_numpy_oracle(model, monkeypatch):
    o = _optimizer(model)
    noises = o.noises.copy()  # regenerated in place by the call
    cv, state, traj = (a.copy() for a in o._noised_controls(POSE, SPEED))  # the optimizer reuses its buffers
    _use_oracles(monkeypatch)
    o.noises = noises
    oracle_cv, oracle_state, oracle_traj = o._noised_controls(POSE, SPEED)
    assert cv.tobytes() == oracle_cv.tobytes() and state.tobytes() == oracle_state.tobytes()
    assert traj.tobytes() == oracle_traj.tobytes()
    assert np.abs(np.diff(state[0], axis=1)).max() <= o.p.ax_max * o.p.model_dt + 1e-6  # the clamp bit
    assert np.abs(traj[:, :, 0] - np.float32(POSE)[:, None]).max() < 0.03  # one step from the pose
    monkeypatch.undo()
    assert o.integrate(POSE, state).tobytes() == traj.tobytes()  # integrate: the fused pass's arithmetic


def test_furthest_reached_kernel_gives_the_oracle_index(monkeypatch):
    o = _optimizer("DiffDrive")
    compiled = _data(o)
    order = np.random.default_rng(3).permutation(o.p.batch_size)  # the order of the rows matters
    shuffled = dataclasses.replace(compiled, x=compiled.x[order], y=compiled.y[order], furthest=None)
    got = compiled.furthest_reached(), shuffled.furthest_reached()
    _use_oracles(monkeypatch)
    for data in (compiled, shuffled):
        data.furthest = None
    assert got == (compiled.furthest_reached(), shuffled.furthest_reached())
    assert 0 < got[0] < len(PATH) - 1


CASES = [
    ("CostCritic", "DiffDrive", {"trajectory_point_step": 2, "near_goal_distance": 0.5}, POSE),
    ("CostCritic", "DiffDrive", {"trajectory_point_step": 3, "near_goal_distance": 1.0}, (2.0, 0.5, 0.0)),
    ("PathAlignCritic", "DiffDrive", {"offset_from_furthest": 2}, POSE),
    ("PathAlignCritic", "DiffDrive", {"offset_from_furthest": 2, "use_path_orientations": True}, POSE),
    ("GoalCritic", "DiffDrive", {}, (2.0, 0.5, 0.0)),
    ("GoalAngleCritic", "DiffDrive", {}, (2.1, 0.5, 0.0)),
    ("GoalAngleCritic", "DiffDrive", {"symmetric_yaw_tolerance": True}, (2.1, 0.5, 0.0)),
    ("PreferForwardCritic", "DiffDrive", {}, POSE),
    ("TwirlingCritic", "DiffDrive", {}, POSE),
    ("VelocityDeadbandCritic", "Omni", {"deadband_velocities": (0.05, 0.05, 0.07)}, POSE),
    ("ConstraintCritic", "DiffDrive", {}, POSE),
    ("ConstraintCritic", "Omni", {}, POSE),
]


@pytest.mark.parametrize(("name", "model", "params", "pose"), CASES)
def test_critic_kernels_against_the_oracles(name, model, params, pose, monkeypatch):
    o = _optimizer(model)
    data = _data(o, pose)
    if name == "PathAlignCritic":
        data.costmap.costs[:] = 0  # the path valid throughout
    critic = make_critic(name, o.p, **params)
    oracle = dataclasses.replace(data, costs=data.costs.copy())
    critic.score(data)
    _use_oracles(monkeypatch)
    critic.score(oracle)
    assert data.costs.max() > 1e-3 and data.fail_flag == oracle.fail_flag
    if name == "CostCritic":  # integer sums: the same bits
        assert data.costs.tobytes() == oracle.costs.tobytes()
        n = 56 // params["trajectory_point_step"]
        collided = data.costs == np.float32(1e6 / n * 3.81 / 254.0)
        assert collided.any() and not collided.all()  # some trajectories collide, some pass
    else:
        np.testing.assert_allclose(data.costs, oracle.costs, rtol=1e-6, atol=1e-7)
