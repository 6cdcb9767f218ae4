"""Nav2's costmap cost values and their mapping to and from nav_msgs/OccupancyGrid values.

Costs are uint8: 0 FREE_SPACE, 1..252 inflated, 253 INSCRIBED, 254 LETHAL, 255 NO_INFORMATION.
"""

from __future__ import annotations

import numpy as np

FREE_SPACE = 0
INSCRIBED = 253
LETHAL = 254
NO_INFORMATION = 255


def occupancy_values(costs: np.ndarray) -> np.ndarray:
    """Nav2's cost -> OccupancyGrid value table: 0->0, 253->99, 254->100, 255->-1, c->1+(97(c-1))/251."""
    table = np.zeros(256, dtype=np.int16)
    c = np.arange(1, 253)
    table[1:253] = 1 + (97 * (c - 1)) // 251
    table[253], table[254], table[255] = 99, 100, -1
    return table[np.asarray(costs, dtype=np.uint8)].astype(np.int8)


def costs_from_occupancy(values: np.ndarray) -> np.ndarray:
    """OccupancyGrid value -> cost as Nav2 reads a costmap message: -1 -> 255, v -> round(v * 254 / 100)."""
    v = np.asarray(values, dtype=np.int16)
    out = np.rint(np.clip(v, 0, 100) * 254.0 / 100.0).astype(np.uint8)
    out[v < 0] = NO_INFORMATION
    return out
