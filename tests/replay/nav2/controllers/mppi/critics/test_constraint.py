"""``ConstraintCritic``: Nav2's test vectors (critics_tests.cpp)."""

from __future__ import annotations

import math

import pytest

from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from tests.replay.nav2.controllers.mppi.unit_setup import DT, T, critic_data, full, make_critic


def test_constraint_critic_vectors():
    # the unit test has no optimizer: vy_max falls back to 0, so vmax = vx_max = 0.5
    c = make_critic("ConstraintCritic", MPPIParams(vy_max=0.0))
    d = critic_data(vx=full(0.4), wz=full(1.0))
    c.score(d)
    assert d.costs.sum() == pytest.approx(0.0, abs=1e-6)
    vx = full(0.4)
    vx[-1] = 0.6
    d = critic_data(vx=vx)
    c.score(d)
    assert d.costs[-1] == pytest.approx(1.2, abs=1e-4)  # 4.0 * 0.1 excess * 0.1 dt * 30
    assert d.costs[:-1].sum() == 0.0
    vx[-1] = -0.45
    d = critic_data(vx=vx)
    c.score(d)
    assert d.costs[-1] == pytest.approx(1.2, abs=1e-4)


def test_constraint_critic_in_the_controller_counts_vy_max():
    # in the controller the optimizer declares vy_max 0.5 first: vmax = hypot(0.5, 0.5) even for DiffDrive
    c = make_critic("ConstraintCritic")
    d = critic_data(vx=full(0.6))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = critic_data(vx=full(0.75))
    c.score(d)
    assert d.costs[0] == pytest.approx(4.0 * (0.75 - math.sqrt(0.5)) * DT * T, abs=1e-4)


def test_constraint_critic_ackermann():
    c = make_critic("ConstraintCritic", MPPIParams(motion_model="Ackermann", vy_max=0.0))
    d = critic_data(vx=full(0.4), wz=full(2.5))
    c.score(d)
    assert d.costs[1] == pytest.approx(0.48, abs=1e-4)  # (0.2 - 0.4 / 2.5) * 0.1 * 30 * 4
