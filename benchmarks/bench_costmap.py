"""The compiled costmap kernels against NumPy/SciPy forms of the same arithmetic, in the same run.

Run: .venv/bin/python benchmarks/bench_costmap.py [--runs 15]

Cases: the inflation layer's update over a whole 400 x 400 and 1000 x 1000 costmap (0.05 m, 120-box
clutter, Nav2's defaults: radius 0.55 m, scaling 10, a 0.4 m square robot) and the obstacle layer's
ray clearing of a 720-beam scan (returns 0.5 to 8 m, a 20 x 20 m costmap). Each is timed with the
compiled kernel (numba) and with the tests' NumPy oracles (``tests/replay/nav2/costmap/oracles.py``),
median of ``--runs``, after one untimed call (the compilation, or loading it from numba's cache); the
outputs of both are checked to be identical.
Prints the machine and its load average with the table.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import navlog.replay.nav2.costmap.inflation_layer as inflation_module
import navlog.replay.nav2.costmap.obstacle_layer as obstacle_module
from navlog.replay.nav2.costmap import (
    Costmap2D,
    CostmapParams,
    InflationLayerParams,
    ObservationSourceParams,
    ObstacleLayerParams,
    StaticLayerParams,
)
from navlog.replay.nav2.costmap.kernels import Kernels
from navlog.replay.nav2.costmap.kernels import kernels as costmap_kernels
from navlog.replay.occupancy_map import OccupancyMap

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository: tests/ holds the maps
from tests.replay.nav2.costmap.oracles import numpy_clear_rays, numpy_inflate_window
from tests.replay.nav2.planners.navfn_maps import clutter

COSTMAP_ORACLES = Kernels(numpy_inflate_window, numpy_clear_rays)

SQUARE = "[[0.2, 0.2], [0.2, -0.2], [-0.2, -0.2], [-0.2, 0.2]]"


def cpu_name() -> str:
    """The processor's model name (Linux), else what the platform module knows."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def median_ms(fn: Callable[[], Any], runs: int) -> float:
    fn()  # compiles, or loads the compiled code from the cache
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times) * 1e3


def both(
    module: Any, compiled: Any, numpy: Any, case: Callable[[], Callable[[], Any]], runs: int
) -> tuple[float, float]:
    """(compiled ms, NumPy ms) of the function ``case()`` builds, with ``module.kernels`` swapped; same outputs."""
    results, times = [], []
    for use in (lambda: compiled, lambda: numpy):
        module.kernels = use
        fn = case()
        times.append(median_ms(fn, runs))
        results.append(fn())
    module.kernels = lambda: compiled
    for a, b in zip(*results):
        if not np.array_equal(a, b):
            raise SystemExit(f"{module.__name__}: the compiled and NumPy outputs differ")
    return times[0], times[1]


def inflation_case(n: int) -> Callable[[], Callable[[], Any]]:
    layers = {"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams()}
    params = CostmapParams(plugins=tuple(layers), layers=layers, footprint=SQUARE, resolution=0.05)
    grid = clutter(n)

    def build() -> Callable[[], Any]:
        cm = Costmap2D(params)
        cm.set_static_map(OccupancyMap(data=grid, resolution=0.05, origin=(0.0, 0.0, 0.0)))
        layer = cm.layers[1]
        base = np.where(grid == 100, 254, 0).astype(np.uint8)

        def run() -> tuple[np.ndarray]:
            master = base.copy()
            layer.update_costs(master, (0, 0, n, n))
            return (master,)

        return run

    return build


def scan(rng: np.random.Generator, far: float) -> tuple[np.ndarray, np.ndarray]:
    ang = -np.pi + 2 * np.pi * np.arange(720) / 720
    return ang, rng.uniform(0.5, far, 720)


def raytrace_case() -> Callable[[], Callable[[], Any]]:
    src = ObservationSourceParams(
        topic="/scan", data_type="LaserScan", clearing=True, max_obstacle_height=2.0, raytrace_max_range=10.0
    )
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    params = CostmapParams(
        plugins=("obstacle_layer",),
        layers={"obstacle_layer": layer},
        width=20,
        height=20,
        resolution=0.05,
        track_unknown_space=True,
    )
    ang, r = scan(np.random.default_rng(1), 8.0)
    pts = np.column_stack([10 + r * np.cos(ang), 10 + r * np.sin(ang), np.full(720, 0.2)])
    origin = np.array([10.0, 10.0, 0.2])

    def build() -> Callable[[], Any]:
        obstacles = Costmap2D(params).layers[0]

        def run() -> tuple[np.ndarray, np.ndarray]:
            bounds = obstacles._raytrace(origin, pts, src)
            return np.array(bounds), obstacles.grid

        return run

    return build


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=15)
    args = ap.parse_args()
    compiled_costmap = costmap_kernels()
    oracles = COSTMAP_ORACLES
    cases = [
        ("inflation 400 x 400", inflation_module, compiled_costmap, oracles, inflation_case(400)),
        ("inflation 1000 x 1000", inflation_module, compiled_costmap, oracles, inflation_case(1000)),
        ("obstacle ray clearing, 720 beams", obstacle_module, compiled_costmap, oracles, raytrace_case()),
    ]
    print(f"machine: {cpu_name()}, {os.cpu_count()} cores, Python {platform.python_version()}")
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    print(f"{'case':34s} {'numba ms':>9s} {'NumPy ms':>9s} {'speed-up':>9s}")
    for name, module, compiled, numpy, case in cases:
        fast, slow = both(module, compiled, numpy, case, args.runs)
        print(f"{name:34s} {fast:9.2f} {slow:9.2f} {slow / fast:8.1f}x")
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
