"""The layered costmap: rolling window, its message, windowed updates equal to full ones."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.replay.nav2.costmap import (
    FREE_SPACE,
    LETHAL,
    Costmap2D,
    InflationLayerParams,
    Observation,
    ObservationSourceParams,
    ObstacleLayerParams,
    StaticLayerParams,
)
from tests.replay.nav2.costmap.grids import costmap_params, observation, static_map


def test_rolling_window_keeps_overlap():
    src = ObservationSourceParams(topic="/scan", data_type="LaserScan", max_obstacle_height=2.0)
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    cm = Costmap2D(
        costmap_params(width=4, height=4, resolution=0.1, rolling_window=True, layers={"obstacle_layer": layer})
    )
    cm.update(0.0, 0.0)
    assert (cm.origin_x, cm.origin_y) == pytest.approx((-2.0, -2.0))
    cm.add_observation(observation([[1.05, 0.05, 0.1]], origin=(0.0, 0.0, 0.1)))
    cm.update(0.0, 0.0)
    assert cm.cost_at(1.05, 0.05) == LETHAL
    cm.update(0.537, 0.0)  # moves by 5.37 cells: snapped to 5
    assert cm.origin_x == pytest.approx(-1.5)
    assert cm.cost_at(1.05, 0.05) == LETHAL
    assert cm.cost_at(2.45, 0.05) == FREE_SPACE  # newly uncovered


def test_windowed_scan_update_equals_a_full_recompute():
    data = np.zeros((160, 160), dtype=np.int8)
    data[40:44, 20:120] = 100
    data[100:140, 90:94] = 100
    src = ObservationSourceParams(
        topic="/scan",
        data_type="LaserScan",
        clearing=True,
        marking=True,
        max_obstacle_height=2.0,
        obstacle_max_range=2.5,
        raytrace_max_range=3.0,
    )
    cm = Costmap2D(
        costmap_params(
            resolution=0.05,
            robot_radius=0.22,
            layers={
                "static_layer": StaticLayerParams(),
                "obstacle_layer": ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}),
                "inflation_layer": InflationLayerParams(cost_scaling_factor=3.0),
            },
        )
    )
    cm.set_static_map(static_map(data))
    cm.update(4.0, 4.0)
    rng = np.random.default_rng(2)
    for step, (x, y) in enumerate([(4.0, 4.0), (4.6, 3.8), (5.3, 4.4)]):
        ang = np.linspace(-np.pi, np.pi, 360, endpoint=False)
        rr = rng.uniform(0.3, 3.5, 360)
        pts = np.column_stack([x + rr * np.cos(ang), y + rr * np.sin(ang), np.full(360, 0.1)])
        cm.add_observation(Observation(np.array([x, y, 0.1]), pts, "scan"))
        before = cm.costs.copy()
        x0, y0, x1, y1 = cm.update(x, y)
        # a 3.0 m ray clears 60 cells out; the bounds grow by the 0.55 m (11-cell) inflation radius
        assert x1 - x0 <= 2 * (60 + 11) + 2 and y1 - y0 <= 2 * (60 + 11) + 2
        outside = np.ones(cm.costs.shape, dtype=bool)
        outside[y0:y1, x0:x1] = False
        assert np.array_equal(cm.costs[outside], before[outside])
        windowed = cm.costs.copy()
        cm.initialized = False  # the next update recomputes every cell from the layers
        assert cm.update(x, y) == (0, 0, 160, 160)
        assert np.array_equal(cm.costs, windowed), step
        assert (windowed == LETHAL).sum() > (data == 100).sum()  # the scan marked cells
