"""``CriticData``: the furthest reached path point."""

from __future__ import annotations

import numpy as np

from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
from tests.replay.nav2.controllers.mppi.unit_setup import DT, T


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
