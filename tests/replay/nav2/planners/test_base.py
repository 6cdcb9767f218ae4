"""What planners share: the cost of a path over a cost grid."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.nav2.planners import path_cost
from tests.replay.nav2.planners.grids import RES


def test_path_cost_of_known_segments():
    # 20 x 5 cells at 0.1 m: cost 50 (one unit per metre) for x < 1.0 m, 100 (two units) beyond
    cell_cost = np.full((5, 20), 50, dtype=np.int16)
    cell_cost[:, 10:] = 100
    xs = np.linspace(0.2, 1.8, 33)  # 32 steps of 0.05 m: 16 on each side of x = 1.0
    fine = np.column_stack([xs, np.full(33, 0.25), np.zeros(33)])
    assert path_cost(fine, cell_cost, RES, (0.0, 0.0), 50.0) == pytest.approx(0.8 * 1 + 0.8 * 2, rel=1e-12)
    # one 1.6 m segment: 64 samples, 32 on each side
    assert path_cost(fine[[0, -1]], cell_cost, RES, (0.0, 0.0), 50.0) == pytest.approx(1.6 * 75 / 50, rel=1e-12)
    # repeated points add nothing; a single point costs nothing
    doubled = np.repeat(fine, 2, axis=0)
    assert path_cost(doubled, cell_cost, RES, (0.0, 0.0), 50.0) == path_cost(fine, cell_cost, RES, (0.0, 0.0), 50.0)
    assert path_cost(fine[:1], cell_cost, RES, (0.0, 0.0), 50.0) == 0.0
