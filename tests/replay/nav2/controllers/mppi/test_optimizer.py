"""The MPPI ``Optimizer``: Nav2's optimizer test vectors (optimizer_unit_tests.cpp), the motion model's kernel."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.controllers.base import ControllerSetup
from navlog.replay.nav2.controllers.mppi.optimizer import Optimizer
from navlog.replay.workers.background import SerialThread
from tests.replay.nav2.controllers.mppi.oracles import numpy_clamp_rollouts
from tests.replay.nav2.controllers.mppi.unit_setup import JAZZY_ARTICLE, make_optimizer, nav2_test_costmap


def test_speed_limit_vectors():
    o = make_optimizer()
    o.set_speed_limit(50.0, True)
    assert (o.vx_max, o.vx_min) == pytest.approx((0.25, -0.175))
    o.set_speed_limit(0.75, False)
    assert (o.vx_max, o.vx_min) == pytest.approx((0.75, -0.525))
    o.set_speed_limit(0.0, True)
    assert (o.vx_max, o.vx_min, o.vy_max, o.wz_max) == pytest.approx((0.5, -0.35, 0.5, 1.9))


def test_apply_control_sequence_constraints_vector():
    o = make_optimizer(motion_model="Omni", vx_max=1.0, vy_max=0.75, wz_max=2.0)
    o.u[:] = 5.0
    o.apply_constraints()
    assert np.allclose(o.u[0], 1.0) and np.allclose(o.u[1], 0.75) and np.allclose(o.u[2], 2.0)


def test_apply_constraints_acceleration_along_the_sequence():
    o = make_optimizer(time_steps=5, model_dt=0.05)
    o.u[0] = [0.0, 0.5, 0.5, -0.3, -0.3]
    o.apply_constraints()
    assert o.u[0] == pytest.approx([0.0, 0.15, 0.3, 0.15, 0.0], abs=1e-6)  # ax 3.0 * dt 0.05 a step


def test_integrate_state_velocities_vectors():
    o = make_optimizer(batch_size=1000, time_steps=50, model_dt=0.1)
    state = np.zeros((3, 1000, 50), dtype=np.float32)
    state[0, :, 1:] = 0.1
    x, y, yaw = o.integrate((0.0, 0.0, 0.0), state)
    assert np.allclose(x[1], np.arange(50) * 0.1 * 0.1, atol=1e-3) and not y.any() and not yaw.any()
    state[2, :, 1:] = 0.2
    x, y, yaw = o.integrate((0.0, 0.0, 0.0), state)
    i = np.arange(1, 50)
    assert np.allclose(x[1, 1:], np.cumsum(0.1 * np.cos(0.02 * (i - 1)) * 0.1), atol=1e-6)
    assert np.allclose(y[1, 1:], np.cumsum(0.1 * np.sin(0.02 * (i - 1)) * 0.1), atol=1e-6)
    omni = make_optimizer(batch_size=1000, time_steps=50, model_dt=0.1, motion_model="Omni")
    state = np.zeros((3, 1000, 50), dtype=np.float32)
    state[0, :, 1:], state[1, :, 1:] = 0.1, 0.2
    x, y, _ = omni.integrate((0.0, 0.0, 0.0), state)
    assert np.allclose(x[1], np.arange(50) * 0.01, atol=1e-3) and np.allclose(y[1], np.arange(50) * 0.02, atol=1e-3)


def test_predict_clamps_to_the_acceleration_limits():
    o = make_optimizer(batch_size=2, time_steps=6, model_dt=0.05)
    cv = np.ones((3, 2, 6), dtype=np.float32)
    state = o.predict(cv, (0.0, 0.0, 0.0))
    assert state[0, 0] == pytest.approx([0.0, 0.15, 0.3, 0.45, 0.6, 0.75], abs=1e-6)
    assert state[2, 0] == pytest.approx([0.0, 0.175, 0.35, 0.525, 0.7, 0.875], abs=1e-6)  # az 3.5 * 0.05
    assert cv[0, 0, :5] == pytest.approx(state[0, 0, 1:])  # the noised controls are overwritten
    cv = np.full((3, 2, 6), -1.0, dtype=np.float32)
    state = o.predict(cv, (0.3, 0.0, 0.0))  # braking from 0.3 m/s: decelerate by ax_min
    assert state[0, 0] == pytest.approx([0.3, 0.15, 0.0, -0.15, -0.3, -0.45], abs=1e-6)


@pytest.mark.parametrize("model", ["DiffDrive", "Omni"])
def test_predict_kernel_gives_the_numpy_oracle_bits(model):
    # the noised controls of real cycles: the seed-001 file's optimizer after two cycles on a straight plan
    params = dataclasses.replace(
        load_nav2_params(JAZZY_ARTICLE).controller_server.controllers["FollowPath"],
        batch_size=300,
        motion_model=model,
    )
    o = Optimizer(params, ControllerSetup(controller_frequency=30.0, seed=4), [])
    path = np.column_stack([np.arange(0.0, 2.0, 0.05), np.zeros(40), np.zeros(40)])
    for _ in range(2):
        o.eval_control((0.0, 0.0, 0.0), (0.2, 0.0, 0.1), path, (2.0, 0.0), nav2_test_costmap())
    noised = o.u[:, None, :] + o.noises
    noised[:, :10] *= 4.0  # some rows far beyond the acceleration limits, some reversing
    speed = (0.3, 0.1, -0.2)
    compiled_cv = noised.copy()
    compiled_state = o.predict(compiled_cv, speed)
    oracle_cv = noised.copy()
    oracle_state = np.zeros_like(oracle_cv)
    oracle_state[:, :, 0] = np.float32([speed[0], speed[1] if model == "Omni" else 0.0, speed[2]])[:, None]
    numpy_clamp_rollouts(oracle_cv, oracle_state, *o._clamp_limits())
    assert compiled_cv.tobytes() == oracle_cv.tobytes() and compiled_state.tobytes() == oracle_state.tobytes()
    assert not np.array_equal(compiled_cv, noised)  # the clamp bit
    dt = params.model_dt
    assert np.abs(np.diff(oracle_state[0], axis=1)).max() <= params.ax_max * dt + 1e-6
    assert np.abs(np.diff(oracle_state[2], axis=1)).max() <= params.az_max * dt + 1e-6


def test_softmax_update_with_injected_noise():
    # two rollouts, 10 steps (no smoothing), 30 Hz (no shift): row 0 reverses at 0.1 m/s, row 1 stands
    o = make_optimizer(batch_size=2, time_steps=10, model_dt=0.05, critics=("PreferForwardCritic",))
    vx = np.zeros((2, 10))
    vx[0] = -0.1
    o.set_noises(vx, np.zeros((2, 10)), np.zeros((2, 10)))
    path = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    cmd = o.eval_control((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), path, (3.0, 0.0), nav2_test_costmap())
    cost0 = 5.0 * 0.1 * 9 * 0.05  # PreferForward: weight * reverse speed * 9 steps * dt; no control cost (u = 0)
    w0 = math.exp(-cost0 / 0.3) / (1.0 + math.exp(-cost0 / 0.3))
    assert cmd[0] == pytest.approx(-0.1 * w0, abs=1e-6)
    assert cmd[1:] == (0.0, 0.0)


def test_savitzky_golay_smoothing_and_shift():
    # 20 Hz with model_dt 0.05: shift on, the command is element 1; zero history pulls the start down
    o = make_optimizer(freq=20.0, batch_size=4, time_steps=25, model_dt=0.05)
    assert o.shift
    o.u[0] = 0.3
    o.set_noises(np.zeros((4, 25)), np.zeros((4, 25)), np.zeros((4, 25)))
    cmd = o.eval_control((0.0, 0.0, 0.0), (0.3, 0.0, 0.0), np.zeros((2, 3)), (3.0, 0.0), nav2_test_costmap())
    assert cmd[0] == pytest.approx(0.3 * (54 + 59 + 54 + 39 + 14 - 21) / 231, abs=1e-6)  # 3 zeros of history
    assert o.history[-1, 0] == pytest.approx(cmd[0])
    assert o.u[0, -1] == pytest.approx(0.3) and o.u[0, -2] == pytest.approx(0.3)  # rolled, last duplicated


def test_controller_frequency_rule():
    assert not make_optimizer(freq=30.0).shift  # period below model_dt: no shift
    with pytest.raises(ConfigError, match="controller_frequency to 20 Hz"):
        make_optimizer(freq=10.0)


def test_noise_drawn_beside_the_cycle_gives_the_same_commands():
    # regenerate_noises: the next cycle's noise drawn in a thread (the navigation node's runner) or at once
    params = dataclasses.replace(
        load_nav2_params(JAZZY_ARTICLE).controller_server.controllers["FollowPath"],
        batch_size=200,
        regenerate_noises=True,
        retry_attempt_limit=1,
    )
    path = np.column_stack([np.arange(0.0, 2.0, 0.05), np.zeros(40), np.zeros(40)])
    runs = []
    for background in (None, SerialThread()):
        o = Optimizer(params, ControllerSetup(controller_frequency=30.0, seed=9, background=background), [])
        cmds = [o.eval_control((0.0, 0.0, 0.0), (0.2, 0.0, 0.1), path, (2.0, 0.0), nav2_test_costmap())]
        o.reset()  # a reset draws again, after the noise being drawn
        cmds += [
            o.eval_control((0.1, 0.0, 0.0), (0.2, 0.0, 0.0), path, (2.0, 0.0), nav2_test_costmap()) for _ in range(3)
        ]
        o._await_noises()  # the last draw ended: the generators stand at the same place
        runs.append((cmds, o.u.tobytes(), o.noises.tobytes(), o.rng.bit_generator.state["state"]["state"]))
    assert runs[0] == runs[1]
    assert len(set(runs[0][0])) == 4  # the commands move
