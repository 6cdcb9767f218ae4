"""The inflation layer: Nav2's cost function, around one cell, over unknown, against a brute force."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import yaml

from navlog.errors import ConfigError
from navlog.replay.config import BoundError, from_mapping
from navlog.replay.nav2.costmap import (
    INSCRIBED,
    LETHAL,
    NO_INFORMATION,
    Costmap2D,
    InflationLayerParams,
    StaticLayerParams,
    inflation_costs,
)
from tests.replay.nav2.costmap.grids import SQUARE_02, costmap_params, static_map


def test_inflation_cost_function_example():
    # nav2.md §1: res 0.05, inscribed 0.2, k 10
    got = inflation_costs(np.array([0, 4, 5, 6, 8, 10]), 0.05, 0.2, 10.0)
    assert got.tolist() == [254, 253, 152, 92, 34, 12]


def test_inflation_around_one_lethal_cell():
    data = np.zeros((41, 41), dtype=np.int8)
    data[20, 20] = 100
    cm = Costmap2D(
        costmap_params(
            footprint=SQUARE_02,
            footprint_padding=0.0,
            resolution=0.05,
            layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams()},
        )
    )
    cm.set_static_map(static_map(data))
    cm.update(0.5, 0.5)
    row = cm.costs[20, 20:35].tolist()
    # distances 0..14 cells; the radius 0.55 m covers ceil(0.55 / 0.05) = 11 cells
    assert row[:11] == [254, 253, 253, 253, 253, 152, 92, 56, 34, 20, 12]
    assert row[11] == 7 and row[12] == 0 and row[14] == 0
    assert cm.costs[24, 23] == 152  # (3, 4) offset: distance 5 cells
    assert cm.inscribed_radius == pytest.approx(0.2)


def test_inflation_leaves_unknown_below_inscribed():
    data = np.full((1, 12), -1, dtype=np.int8)
    data[0, 0] = 100
    cm = Costmap2D(
        costmap_params(
            track_unknown_space=True,
            footprint=SQUARE_02,
            footprint_padding=0.0,
            layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams()},
        )
    )
    cm.set_static_map(static_map(data))
    cm.update(0.0, 0.0)
    # cells 1..4 are inscribed (>= 253): written over unknown; farther ones stay unknown
    assert cm.costs[0, :7].tolist() == [254, 253, 253, 253, 253, 255, 255]
    cm2 = Costmap2D(
        dataclasses.replace(
            cm.params,
            layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams(inflate_unknown=True)},
        )
    )
    cm2.set_static_map(static_map(data))
    cm2.update(0.0, 0.0)
    assert cm2.costs[0, :7].tolist() == [254, 253, 253, 253, 253, 152, 92]


@pytest.mark.parametrize("radius", ["51.0", ".inf", ".nan"])
def test_inflation_radius_beyond_50_m_or_not_finite_is_refused_by_key(radius):
    with pytest.raises(ConfigError, match=r"^inflation_radius: .* is out of range: must be (<= 50\.0|>= 0\.0)$"):
        from_mapping(InflationLayerParams, {"inflation_radius": yaml.safe_load(radius)})
    assert from_mapping(InflationLayerParams, {"inflation_radius": 50.0}).inflation_radius == 50.0


def test_inflation_radius_spans_at_most_1000_cells_of_the_costmap():
    data = np.zeros((41, 41), dtype=np.int8)
    data[20, 20] = 100
    layers = {
        "static_layer": StaticLayerParams(),
        "inflation_layer": InflationLayerParams(inflation_radius=50.0, cost_scaling_factor=0.1),
    }
    cm = Costmap2D(costmap_params(footprint=SQUARE_02, footprint_padding=0.0, resolution=0.05, layers=layers))
    cm.set_static_map(static_map(data, res=0.05))  # 50 m / 0.05 m: 1,000 cells, the most a radius spans
    cm.update(0.5, 0.5)
    assert cm.costs[20, 20] == LETHAL and cm.costs[20, 40] == 232  # 1 m away: floor(252 exp(-0.1 (1 - 0.2)))
    message = (
        r"^global_costmap\.inflation_layer\.inflation_radius: inflation_radius / resolution \(50\.0 m / 0\.01 m\) "
        r"= 5,000 cells exceeds navlog's budget of 1,000 cells; lower it$"
    )
    with pytest.raises(BoundError, match=message):
        cm.set_static_map(static_map(data, res=0.01))
    with pytest.raises(BoundError, match=message):
        Costmap2D(costmap_params(footprint=SQUARE_02, resolution=0.01, layers=layers))


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
        costmap_params(
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
    cm.set_static_map(static_map(data))
    cm.update(0.5, 0.5)
    static = cm.static_layers[0].map_costs
    expected = _brute_force_inflation(static, 0.05, 0.2, 10.0, 0.55, 1 if inflate_unknown else INSCRIBED)
    assert np.array_equal(cm.costs, expected)
    assert (cm.costs == 152).any() and (cm.costs == NO_INFORMATION).any()  # the reference is not trivial
