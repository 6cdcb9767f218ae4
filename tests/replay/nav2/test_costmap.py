"""Costmap 2D: Nav2's value mapping, inflation costs, static / obstacle layers, rolling window."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navlog.replay.io.map_server import OccupancyMap
from navlog.replay.nav2.costmap import (
    FREE_SPACE,
    INSCRIBED,
    LETHAL,
    NO_INFORMATION,
    Costmap2D,
    Observation,
    costs_from_occupancy,
    footprint_radii,
    inflation_costs,
    occupancy_values,
    radius_footprint,
)
from navlog.replay.nav2.params import (
    CostmapParams,
    InflationLayerParams,
    ObservationSourceParams,
    ObstacleLayerParams,
    StaticLayerParams,
)

SQUARE_02 = "[[0.2, 0.2], [0.2, -0.2], [-0.2, -0.2], [-0.2, 0.2]]"  # inscribed radius 0.2


def test_occupancy_value_mapping():
    costs = np.array([0, 1, 100, 200, 252, 253, 254, 255], dtype=np.uint8)
    # 1 + 97 * (c - 1) // 251: 100 -> 39, 200 -> 77, 252 -> 98
    assert occupancy_values(costs).tolist() == [0, 1, 39, 77, 98, 99, 100, -1]
    assert costs_from_occupancy(np.array([-1, 0, 50, 99, 100])).tolist() == [255, 0, 127, 251, 254]


def test_inflation_cost_function_example():
    # nav2.md §1: res 0.05, inscribed 0.2, k 10
    got = inflation_costs(np.array([0, 4, 5, 6, 8, 10]), 0.05, 0.2, 10.0)
    assert got.tolist() == [254, 253, 152, 92, 34, 12]


def test_footprint_radii():
    inscribed, circumscribed = footprint_radii(radius_footprint(0.34))
    assert inscribed == pytest.approx(0.9808 * 0.34, abs=1e-4)
    assert circumscribed == pytest.approx(0.34)
    assert footprint_radii([(0.2, 0.2), (0.2, -0.2), (-0.2, -0.2), (-0.2, 0.2)]) == pytest.approx(
        (0.2, 0.2 * math.sqrt(2))
    )


def _params(**kw) -> CostmapParams:
    layers = kw.pop("layers")
    return CostmapParams(plugins=tuple(layers), layers=layers, **kw)


def _static_map(data: np.ndarray, res: float = 0.05) -> OccupancyMap:
    return OccupancyMap(data=data.astype(np.int8), resolution=res, origin=(0.0, 0.0, 0.0))


def test_inflation_around_one_lethal_cell():
    data = np.zeros((41, 41), dtype=np.int8)
    data[20, 20] = 100
    cm = Costmap2D(
        _params(
            footprint=SQUARE_02,
            footprint_padding=0.0,
            resolution=0.05,
            layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams()},
        )
    )
    cm.set_static_map(_static_map(data))
    cm.update(0.5, 0.5)
    row = cm.costs[20, 20:35].tolist()
    # distances 0..14 cells; the radius 0.55 m covers ceil(0.55 / 0.05) = 11 cells
    assert row[:11] == [254, 253, 253, 253, 253, 152, 92, 56, 34, 20, 12]
    assert row[11] == 7 and row[12] == 0 and row[14] == 0
    assert cm.costs[24, 23] == 152  # (3, 4) offset: distance 5 cells
    assert cm.inscribed_radius == pytest.approx(0.2)


def test_static_layer_interpretation_and_unknown():
    data = np.array([[-1, 0, 50, 100]], dtype=np.int8)
    for track, trinary, expected in (
        (False, True, [0, 0, 0, 254]),
        (True, True, [255, 0, 0, 254]),
        (True, False, [255, 0, 127, 254]),
    ):
        cm = Costmap2D(
            _params(track_unknown_space=track, trinary_costmap=trinary, layers={"static_layer": StaticLayerParams()})
        )
        cm.set_static_map(_static_map(data, 0.1))
        cm.update(0.0, 0.0)
        assert cm.costs[0].tolist() == expected
        assert (cm.size_x, cm.size_y, cm.resolution) == (4, 1, 0.1)


def test_inflation_leaves_unknown_below_inscribed():
    data = np.full((1, 12), -1, dtype=np.int8)
    data[0, 0] = 100
    cm = Costmap2D(
        _params(
            track_unknown_space=True,
            footprint=SQUARE_02,
            footprint_padding=0.0,
            layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams()},
        )
    )
    cm.set_static_map(_static_map(data))
    cm.update(0.0, 0.0)
    # cells 1..4 are inscribed (>= 253): written over unknown; farther ones stay unknown
    assert cm.costs[0, :7].tolist() == [254, 253, 253, 253, 253, 255, 255]
    cm2 = Costmap2D(
        dataclasses.replace(
            cm.params,
            layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams(inflate_unknown=True)},
        )
    )
    cm2.set_static_map(_static_map(data))
    cm2.update(0.0, 0.0)
    assert cm2.costs[0, :7].tolist() == [254, 253, 253, 253, 253, 152, 92]


def _obstacle_costmap(**source_kw) -> Costmap2D:
    src = ObservationSourceParams(
        topic="/scan", data_type="LaserScan", marking=True, clearing=True, max_obstacle_height=2.0, **source_kw
    )
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    return Costmap2D(
        _params(width=10, height=10, resolution=0.1, track_unknown_space=True, layers={"obstacle_layer": layer})
    )


def _obs(points, origin=(5.05, 5.05, 0.2)):
    return Observation(origin=np.array(origin, float), points=np.array(points, float), source="scan")


def test_obstacle_marking_and_clearing():
    cm = _obstacle_costmap()
    assert cm.add_observation(_obs([[7.05, 5.05, 0.2]]))
    cm.update(5.0, 5.0)
    row = cm.costs[50]
    assert row[70] == LETHAL
    assert (row[50:70] == FREE_SPACE).all()  # the ray from the sensor cell is cleared
    assert row[71] == NO_INFORMATION and row[49] == NO_INFORMATION
    # the obstacle moves 0.4 m away: its old cell is cleared by the new ray
    cm.add_observation(_obs([[7.45, 5.05, 0.2]]))
    cm.update(5.0, 5.0)
    assert cm.costs[50, 70] == FREE_SPACE and cm.costs[50, 74] == LETHAL
    # 2.8 m away, beyond obstacle_max_range 2.5: not marked, but the ray clears (raytrace_max_range 3.0)
    cm.add_observation(_obs([[5.05, 2.25, 0.2]]))
    cm.update(5.0, 5.0)
    assert (cm.costs[22:50, 50] == FREE_SPACE).all()
    assert cm.costs[50, 74] == LETHAL  # not on any ray of this scan: kept
    # 3.5 m away: the ray is cut at ceil(3.0 / 0.1) = 30 cells
    cm.add_observation(_obs([[5.05, 8.55, 0.2]]))
    cm.update(5.0, 5.0)
    assert (cm.costs[50:81, 50] == FREE_SPACE).all() and cm.costs[81, 50] == NO_INFORMATION


def test_obstacle_ranges_and_height_filter():
    cm = _obstacle_costmap(raytrace_min_range=0.5, obstacle_min_range=0.3)
    cm.add_observation(_obs([[5.25, 5.05, 0.2], [5.05, 6.55, 0.2], [3.05, 5.05, 2.5]]))
    cm.update(5.0, 5.0)
    assert cm.costs[50, 52] == NO_INFORMATION  # 0.2 m: below obstacle_min_range, inside raytrace_min_range
    col = cm.costs[:, 50]
    assert col[65] == LETHAL
    assert (col[50:55] == NO_INFORMATION).all() and (col[55:65] == FREE_SPACE).all()
    assert (cm.costs[50, 30:50] == NO_INFORMATION).all()  # z = 2.5 above max_obstacle_height: dropped entirely


def test_height_trap_default_source_max():
    src = ObservationSourceParams(topic="/scan", data_type="LaserScan", clearing=True)  # max_obstacle_height 0.0
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    cm = Costmap2D(
        _params(width=10, height=10, resolution=0.1, track_unknown_space=True, layers={"obstacle_layer": layer})
    )
    cm.add_observation(_obs([[7.05, 5.05, 0.2]]))
    cm.update(5.0, 5.0)
    assert (cm.costs == NO_INFORMATION).all()


def test_footprint_clearing_and_published_footprint():
    src = ObservationSourceParams(topic="/scan", data_type="LaserScan", max_obstacle_height=2.0)
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src})
    cm = Costmap2D(_params(width=4, height=4, resolution=0.1, robot_radius=0.3, layers={"obstacle_layer": layer}))
    cm.add_observation(_obs([[2.05, 2.15, 0.1], [3.05, 2.05, 0.1]], origin=(2.0, 2.0, 0.1)))
    cm.update(2.0, 2.0)
    assert cm.costs[21, 20] == FREE_SPACE  # inside the footprint: cleared
    assert cm.costs[20, 30] == LETHAL
    msg = cm.footprint_msg(0, 2.0, 2.0, 0.0)
    assert len(msg.polygon.points) == 16 and msg.polygon.points[0].x == pytest.approx(2.31)


def test_rolling_window_keeps_overlap():
    src = ObservationSourceParams(topic="/scan", data_type="LaserScan", max_obstacle_height=2.0)
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    cm = Costmap2D(_params(width=4, height=4, resolution=0.1, rolling_window=True, layers={"obstacle_layer": layer}))
    cm.update(0.0, 0.0)
    assert (cm.origin_x, cm.origin_y) == pytest.approx((-2.0, -2.0))
    cm.add_observation(_obs([[1.05, 0.05, 0.1]], origin=(0.0, 0.0, 0.1)))
    cm.update(0.0, 0.0)
    assert cm.cost_at(1.05, 0.05) == LETHAL
    cm.update(0.537, 0.0)  # moves by 5.37 cells: snapped to 5
    assert cm.origin_x == pytest.approx(-1.5)
    assert cm.cost_at(1.05, 0.05) == LETHAL
    assert cm.cost_at(2.45, 0.05) == FREE_SPACE  # newly uncovered


def test_costmap_message():
    data = np.zeros((3, 3), dtype=np.int8)
    data[1, 1] = 100
    cm = Costmap2D(_params(layers={"static_layer": StaticLayerParams()}))
    cm.set_static_map(OccupancyMap(data, 0.5, (-1.0, 2.0, 0.0)))
    cm.update(0.0, 0.0)
    msg = cm.to_msg(7)
    assert msg.header.frame_id == "map" and msg.info.width == 3
    assert msg.data.tolist() == [0, 0, 0, 0, 100, 0, 0, 0, 0]
    assert msg.info.origin.position.x == -1.0


def _brute_force_inflation(
    static: np.ndarray, res: float, inscribed: float, k: float, radius: float, unknown_cost: int
) -> np.ndarray:
    """Nav2's inflation from first principles: every cell against every lethal cell (no distance transform)."""
    ny, nx = static.shape
    lethal = np.argwhere(static == LETHAL)
    gy, gx = np.mgrid[0:ny, 0:nx]
    d = np.sqrt(((gy[..., None] - lethal[:, 0]) ** 2 + (gx[..., None] - lethal[:, 1]) ** 2).min(axis=-1))
    cost = np.floor(252.0 * np.exp(-k * (d * res - inscribed)))
    cost = np.where(d * res <= inscribed, INSCRIBED, cost)
    cost = np.where(d == 0, LETHAL, cost).astype(np.int64)
    near = d <= math.ceil(radius / res)
    out = static.astype(np.int64).copy()
    known = static != NO_INFORMATION
    out[near & known] = np.maximum(static, cost)[near & known]
    take = near & ~known & (cost >= unknown_cost)
    out[take] = cost[take]
    return out.astype(np.uint8)


@pytest.mark.parametrize("inflate_unknown", [False, True])
def test_inflation_matches_a_brute_force_reference(inflate_unknown):
    rng = np.random.default_rng(5)
    data = np.zeros((45, 60), dtype=np.int8)
    data[rng.random(data.shape) < 0.01] = 100
    data[30:33, 10:25] = 100
    data[5:15, 40:50] = -1
    cm = Costmap2D(
        _params(
            footprint=SQUARE_02,
            footprint_padding=0.0,
            resolution=0.05,
            track_unknown_space=True,
            layers={
                "static_layer": StaticLayerParams(),
                "inflation_layer": InflationLayerParams(inflate_unknown=inflate_unknown),
            },
        )
    )
    cm.set_static_map(_static_map(data))
    cm.update(0.5, 0.5)
    static = cm.static_layers[0].map_costs
    expected = _brute_force_inflation(static, 0.05, 0.2, 10.0, 0.55, 1 if inflate_unknown else INSCRIBED)
    assert np.array_equal(cm.costs, expected)
    assert (cm.costs == 152).any() and (cm.costs == NO_INFORMATION).any()  # the reference is not trivial


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
        _params(
            resolution=0.05,
            robot_radius=0.22,
            layers={
                "static_layer": StaticLayerParams(),
                "obstacle_layer": ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}),
                "inflation_layer": InflationLayerParams(cost_scaling_factor=3.0),
            },
        )
    )
    cm.set_static_map(_static_map(data))
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
