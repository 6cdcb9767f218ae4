"""The compiled costmap kernels against their NumPy/SciPy oracles: the same bits on random, edge and layer input."""

from __future__ import annotations

import numpy as np
import pytest

import navlog.replay.nav2.costmap.inflation_layer as inflation_module
import navlog.replay.nav2.costmap.obstacle_layer as obstacle_module
from navlog.replay.nav2.costmap import (
    FREE_SPACE,
    INSCRIBED,
    LETHAL,
    NO_INFORMATION,
    Costmap2D,
    InflationLayerParams,
    ObservationSourceParams,
    ObstacleLayerParams,
    StaticLayerParams,
)
from navlog.replay.nav2.costmap.kernels import Kernels, inflate_window, kernels
from navlog.replay.nav2.costmap.kernels import clear_rays as clear_rays_python
from navlog.replay.nav2.costmap.raytrace import ray_steps
from tests.replay.nav2.costmap.grids import SQUARE_02, costmap_params, observation, static_map
from tests.replay.nav2.costmap.oracles import numpy_clear_rays, numpy_inflate_window

COMPILED = kernels()
ORACLES = Kernels(numpy_inflate_window, numpy_clear_rays)


def random_region(rng: np.random.Generator, h: int, w: int, lethal: float) -> np.ndarray:
    """Lethal cells, unknown cells and costs below lethal, mixed."""
    kind = rng.random((h, w))
    costs = rng.integers(0, LETHAL, (h, w))
    return np.where(kind < lethal, LETHAL, np.where(kind < lethal + 0.2, NO_INFORMATION, costs)).astype(np.uint8)


def inflation_cases(seed: int, n: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        h, w = (int(v) for v in rng.integers(1, 30, 2))
        region = random_region(rng, h, w, float(rng.uniform(0.0, 0.15)))
        r0, r1 = sorted(int(v) for v in rng.integers(0, h + 1, 2))
        c0, c1 = sorted(int(v) for v in rng.integers(0, w + 1, 2))
        radius = int(rng.integers(0, 10))
        # a random table: every squared distance must pick its own entry
        table = np.append(rng.integers(0, 256, radius * radius + 1), FREE_SPACE).astype(np.uint8)
        yield region, (r0, r1, c0, c1, table, bool(rng.integers(2)), bool(rng.integers(2)))


def test_compiled_inflation_equals_the_distance_transform_oracle_on_random_regions():
    for region, args in inflation_cases(seed=1, n=400):
        want = region.copy()
        numpy_inflate_window(want, *args)
        got = region.copy()
        COMPILED.inflate_window(got, *args)
        assert got.tobytes() == want.tobytes(), args[:4]
        # a window into a larger grid (strided rows), as the layer passes it
        big = np.full((region.shape[0] + 3, region.shape[1] + 5), 7, dtype=np.uint8)
        big[1:-2, 2:-3] = region
        COMPILED.inflate_window(big[1:-2, 2:-3], *args)
        assert big[1:-2, 2:-3].tobytes() == want.tobytes()
        assert (big[0] == 7).all() and (big[:, :2] == 7).all()


def test_the_plain_python_kernel_is_the_same_function():
    for region, args in inflation_cases(seed=2, n=40):
        want = region.copy()
        numpy_inflate_window(want, *args)
        got = region.copy()
        inflate_window(got, *args)
        assert got.tobytes() == want.tobytes()


def test_inflation_kernel_exact_distances_around_one_cell_and_no_source():
    region = np.zeros((9, 9), dtype=np.uint8)
    region[0, 8] = LETHAL  # a corner cell: distances up to 8^2 + 8^2
    table = np.arange(129, dtype=np.uint8)  # entry d2 = d2, below lethal
    inflate_window(region, 0, 9, 0, 9, np.append(table, np.uint8(0)), False, False)
    ys, xs = np.mgrid[0:9, 0:9]
    want = np.minimum(ys**2 + (xs - 8) ** 2, 128)
    want[0, 8] = LETHAL  # max(lethal, its own entry 0)
    assert (region == want).all()
    empty = np.full((4, 5), NO_INFORMATION, dtype=np.uint8)
    inflate_window(empty, 0, 4, 0, 5, np.array([254, 0], np.uint8), False, True)
    assert (empty == NO_INFORMATION).all()  # no lethal cell: nothing changes


@pytest.mark.parametrize(
    ("radius", "around_unknown", "inflate_unknown", "track_unknown"),
    [(0.55, False, False, False), (0.0, False, False, True), (0.3, True, True, True), (1.0, False, True, True)],
)
def test_inflation_layer_same_costs_with_the_kernel_and_the_oracle(
    monkeypatch, radius, around_unknown, inflate_unknown, track_unknown
):
    rng = np.random.default_rng(5)
    data = np.where(rng.random((60, 45)) < 0.03, 100, 0).astype(np.int8)
    data[rng.random(data.shape) < 0.1] = -1
    data[0, :] = 100  # lethal cells on the border
    data[:, -1] = 100
    params = costmap_params(
        footprint=SQUARE_02,
        track_unknown_space=track_unknown,
        resolution=0.05,
        layers={
            "static_layer": StaticLayerParams(),
            "inflation_layer": InflationLayerParams(
                inflation_radius=radius, inflate_around_unknown=around_unknown, inflate_unknown=inflate_unknown
            ),
        },
    )
    costs = []
    for compiled in (True, False):
        if not compiled:
            monkeypatch.setattr(inflation_module, "kernels", lambda: ORACLES)
        cm = Costmap2D(params)
        cm.set_static_map(static_map(data))
        cm.update(1.0, 1.0)
        costs.append(cm.costs.copy())
    assert costs[0].tobytes() == costs[1].tobytes()
    assert (costs[0][data == 100] == LETHAL).all()
    assert (costs[0] == INSCRIBED).any() == (radius > 0)  # a zero radius inflates nothing


def random_rays(rng: np.random.Generator, w: int, h: int, n: int):
    x0, y0 = int(rng.integers(0, w)), int(rng.integers(0, h))
    x1 = rng.integers(-20, w + 20, n)  # some ends outside the grid
    y1 = rng.integers(-20, h + 20, n)
    x1[:3], y1[:3] = x0, y0  # zero-length rays
    return x0, y0, x1, y1


def test_compiled_ray_clearing_equals_the_numpy_oracle_on_random_rays():
    rng = np.random.default_rng(3)
    for trial in range(200):
        w, h = (int(v) for v in rng.integers(1, 50, 2))
        x0, y0, x1, y1 = random_rays(rng, w, h, int(rng.integers(0, 60)))
        steps = ray_steps(x0, y0, x1, y1, float(rng.uniform(0, 60)), float(rng.choice([0.0, 2.0, 5.0])))
        grids = [np.full((h, w), NO_INFORMATION, dtype=np.uint8) for _ in range(3)]
        results = [
            numpy_clear_rays(grids[0], *steps, FREE_SPACE),
            COMPILED.clear_rays(grids[1], *steps, FREE_SPACE),
            clear_rays_python(grids[2], *steps, FREE_SPACE)
            if trial < 30
            else numpy_clear_rays(grids[2], *steps, FREE_SPACE),
        ]
        assert results[1] == results[0] == results[2]
        assert grids[1].tobytes() == grids[0].tobytes() == grids[2].tobytes()


def test_ray_clearing_counts_and_bounds_a_known_ray():
    grid = np.full((5, 8), NO_INFORMATION, dtype=np.uint8)
    steps = ray_steps(1, 1, np.array([7, 20]), np.array([3, 1]), 100.0, 0.0)
    # (1,1)->(7,3): 7 cells; (1,1)->(20,1): 20 cells, 7 of them inside (x 1..7)
    assert clear_rays_python(grid, *steps, FREE_SPACE) == (14, 1, 1, 7, 3)
    assert (grid[1, 1:8] == FREE_SPACE).all() and grid[3, 7] == FREE_SPACE and grid[0].tolist() == [255] * 8
    assert clear_rays_python(grid, *ray_steps(1, 1, np.array([-5]), np.array([-5]), 100.0, 3.0), 0) == (0, 0, 0, 0, 0)


def test_obstacle_layer_same_grid_and_bounds_with_the_kernel_and_the_oracle(monkeypatch):
    rng = np.random.default_rng(11)
    src = ObservationSourceParams(
        topic="/scan",
        data_type="LaserScan",
        marking=True,
        clearing=True,
        max_obstacle_height=2.0,
        raytrace_max_range=4.0,
        raytrace_min_range=0.2,
    )
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    params = costmap_params(
        width=6, height=5, resolution=0.05, track_unknown_space=True, layers={"obstacle_layer": layer}
    )
    ang = np.linspace(-np.pi, np.pi, 720, endpoint=False)
    r = rng.uniform(0.1, 9.0, 720)  # many beams leave the 6 x 5 m map
    pts = np.column_stack([3.02 + r * np.cos(ang), 2.51 + r * np.sin(ang), np.full(720, 0.1)])
    pts = np.vstack([pts, [[0.0, 0.0, 0.1], [5.999, 4.999, 0.1], [3.02, 2.51, 0.1]]])  # corner cells, the origin cell
    grids, bounds = [], []
    for compiled in (True, False):
        if not compiled:
            monkeypatch.setattr(obstacle_module, "kernels", lambda: ORACLES)
        cm = Costmap2D(params)
        ol = cm.layers[0]
        bounds.append(ol._raytrace(np.array([3.02, 2.51, 0.1]), pts, src))
        cm.add_observation(observation(pts, origin=(3.02, 2.51, 0.1)))
        cm.update(3.0, 2.5)
        grids.append((ol.grid.copy(), cm.costs.copy()))
    assert bounds[0] == bounds[1] == (0, 0, 120, 100)
    assert grids[0][0].tobytes() == grids[1][0].tobytes() and grids[0][1].tobytes() == grids[1][1].tobytes()
    assert (grids[0][0] == FREE_SPACE).sum() > 5000
