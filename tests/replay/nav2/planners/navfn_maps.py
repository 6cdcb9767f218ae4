"""The four NavFn benchmark maps: 120-box clutter, empty, maze (400 x 400) and 120-box clutter (1000 x 1000).

The maze (2 m corridors, seed 3) is planned to its middle: a 35 m path, within NavFn's default step
limit (4 x 400 half-cell steps).

Each is a static map inflated as Nav2's global costmap does (robot radius 0.22 m, inflation radius
0.55 m, cost_scaling_factor 3) at 0.05 m, with a start and a goal pose; the tests compare navlog's
NavFn with Nav2's on them, and ``benchmarks/bench_planner.py`` times both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from navlog.replay.nav2.costmap import Costmap2D, CostmapParams, InflationLayerParams, StaticLayerParams
from navlog.replay.nav2.planners.base import Pose2D
from navlog.replay.occupancy_map import OccupancyMap

RES = 0.05


@dataclass
class BenchMap:
    name: str
    costmap: Costmap2D
    start: Pose2D
    goal: Pose2D


def clutter(n: int, boxes: int = 120, seed: int = 7) -> np.ndarray:
    """n x n cells of free space with ``boxes`` random boxes (3..14 cells), the two corners kept free."""
    rng = np.random.default_rng(seed)
    data = np.zeros((n, n), dtype=np.int8)
    scale = n / 400
    for _ in range(boxes):
        x, y = rng.integers(0, n - 20, 2)
        w, h = (rng.integers(3, 15, 2) * scale).astype(int)
        data[y : y + h, x : x + w] = 100
    k = n // 10
    data[:k, :k] = 0
    data[-k:, -k:] = 0
    return data


def maze(n: int, corridor: int = 40, seed: int = 3) -> np.ndarray:
    """A perfect maze (depth-first, seeded) of corridor-wide passages with 3-cell walls, n x n cells."""
    rng = np.random.default_rng(seed)
    m = n // corridor
    data = np.full((n, n), 100, dtype=np.int8)
    wall = 3
    seen = np.zeros((m, m), dtype=bool)
    stack = [(0, 0)]
    seen[0, 0] = True

    def carve(i: int, j: int) -> None:
        data[j * corridor + wall : (j + 1) * corridor, i * corridor + wall : (i + 1) * corridor] = 0

    carve(0, 0)
    while stack:
        i, j = stack[-1]
        options = [
            (i + di, j + dj)
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1))
            if 0 <= i + di < m and 0 <= j + dj < m and not seen[j + dj, i + di]
        ]
        if not options:
            stack.pop()
            continue
        a, b = options[int(rng.integers(len(options)))]
        seen[b, a] = True
        carve(a, b)
        # open the wall between (i, j) and (a, b)
        x0, x1 = sorted((i, a))
        y0, y1 = sorted((j, b))
        data[y0 * corridor + wall : (y1 + 1) * corridor, x0 * corridor + wall : (x1 + 1) * corridor] = 0
        stack.append((a, b))
    return data


def inflated(data: np.ndarray) -> Costmap2D:
    """A global costmap (static + inflation layers) over ``data``."""
    params = CostmapParams(
        resolution=RES,
        robot_radius=0.22,
        plugins=("static_layer", "inflation_layer"),
        layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams(cost_scaling_factor=3.0)},
    )
    cm = Costmap2D(params)
    cm.set_static_map(OccupancyMap(data, RES, (0.0, 0.0, 0.0)))
    cm.update(1.0, 1.0)
    return cm


def bench_maps(large: bool = True) -> list[BenchMap]:
    """The benchmark maps (the 1000 x 1000 one only if ``large``)."""
    maps = [
        BenchMap("clutter 400", inflated(clutter(400)), (1.0, 1.0, 0.0), (19.0, 19.0, 0.0)),
        BenchMap("empty 400", inflated(np.zeros((400, 400), dtype=np.int8)), (1.0, 1.0, 0.0), (19.0, 19.0, 0.0)),
        BenchMap("maze 400", inflated(maze(400)), (1.0, 1.0, 0.0), (11.0, 11.0, 0.0)),
    ]
    if large:
        maps.append(BenchMap("clutter 1000", inflated(clutter(1000)), (1.0, 1.0, 0.0), (49.0, 49.0, 0.0)))
    return maps
