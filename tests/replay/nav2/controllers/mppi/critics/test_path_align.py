"""``PathAlignCritic``: Nav2's test vectors (critics_tests.cpp) and the integrated length."""

from __future__ import annotations

import numpy as np
import pytest

from tests.replay.nav2.controllers.mppi.unit_setup import B, T, critic_data, full, make_critic


def test_path_align_critic_vectors():
    c = make_critic("PathAlignCritic")
    path = np.zeros((22, 3))
    path[:10, 0] = np.arange(10) * 0.1
    path[10:, 0] = 0.9
    # furthest reached point 0 < offset_from_furthest 20: nothing
    d = critic_data(goal=(0.9, 0.0), path=path, x=full(0.66))
    c.score(d)
    assert d.costs.sum() == 0.0
    d = critic_data(goal=(0.9, 0.0), path=path, x=full(0.66))
    d.furthest = 21
    c.score(d)
    assert d.costs.sum() == pytest.approx(6600.0, rel=1e-5)  # 0.66 * 10 weight * 1000
    # the path blocked by a lethal island: too many invalid points, nothing
    d = critic_data(goal=(1.5, 0.0), path=np.full((22, 3), 1.5), x=full(0.66))
    d.costmap.costs[11:31, 11:31] = 254
    d.furthest = 21
    c.score(d)
    assert d.costs.sum() == 0.0


def test_path_align_follows_integrated_length():
    # trajectories moving along x at 0.1 m per step on a path along x: aligned, so no cost;
    # the same trajectories 0.3 m to the side cost 0.3 * weight
    c = make_critic("PathAlignCritic", offset_from_furthest=0)
    path = np.zeros((40, 3))
    path[:, 0] = np.arange(40) * 0.1
    x = np.tile(np.arange(T, dtype=np.float32) * 0.1, (B, 1))
    d = critic_data(goal=(3.9, 0.0), path=path, x=x)
    d.furthest = 30
    c.score(d)
    assert d.costs.max() == pytest.approx(0.0, abs=1e-4)
    d = critic_data(goal=(3.9, 0.0), path=path, x=x, y=full(0.3))
    d.furthest = 30
    c.score(d)
    assert d.costs[0] == pytest.approx(3.0, abs=1e-4)
