"""Nav2's cost values and their OccupancyGrid mapping."""

from __future__ import annotations

import numpy as np

from navlog.replay.nav2.costmap import costs_from_occupancy, occupancy_values


def test_occupancy_value_mapping():
    costs = np.array([0, 1, 100, 200, 252, 253, 254, 255], dtype=np.uint8)
    # 1 + 97 * (c - 1) // 251: 100 -> 39, 200 -> 77, 252 -> 98
    assert occupancy_values(costs).tolist() == [0, 1, 39, 77, 98, 99, 100, -1]
    assert costs_from_occupancy(np.array([-1, 0, 50, 99, 100])).tolist() == [255, 0, 127, 251, 254]
