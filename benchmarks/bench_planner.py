"""NavFn and costmap update timings against Nav2's targets (50 ms per plan, 5 ms per costmap update).

Run: .venv/bin/python benchmarks/bench_planner.py
A 20 x 20 m world at 0.05 m (400 x 400 cells) with 120 random boxes (seed 7), inflated as Nav2 does
(robot radius 0.22, inflation 0.55, k 3); start (1, 1) m, goal (19, 19) m. Prints medians and ratios, with the
process CPU time beside the wall clock and the load average (the machine may be shared).
"""

from __future__ import annotations

import os
import statistics
import time

import numpy as np

from navlog.replay import messages as m
from navlog.replay.nav2.costmap import (
    Costmap2D,
    CostmapParams,
    InflationLayerParams,
    Observation,
    ObservationSourceParams,
    ObstacleLayerParams,
    StaticLayerParams,
    scan_points,
)
from navlog.replay.nav2.planners.navfn import (
    NavfnParams,
    NavfnPlanner,
    navfn_costs,
    potential_exact,
    potential_wavefront,
)
from navlog.replay.occupancy_map import OccupancyMap


def world() -> OccupancyMap:
    rng = np.random.default_rng(7)
    data = np.zeros((400, 400), dtype=np.int8)
    for _ in range(120):
        x, y = rng.integers(0, 380, 2)
        w, h = rng.integers(3, 15, 2)
        data[y : y + h, x : x + w] = 100
    data[:40, :40] = 0
    data[360:, 360:] = 0
    return OccupancyMap(data, 0.05, (0.0, 0.0, 0.0))


def median_ms(fn, n: int) -> float:
    return timed(fn, n)[0]


def timed(fn, n: int) -> tuple[float, float]:
    """(median wall-clock ms, median process CPU ms) over n calls; CPU time shows the one-core cost on a busy machine."""
    wall, cpu = [], []
    for _ in range(n):
        t, c = time.perf_counter(), time.process_time()
        fn()
        cpu.append((time.process_time() - c) * 1000)
        wall.append((time.perf_counter() - t) * 1000)
    return statistics.median(wall), statistics.median(cpu)


def load() -> str:
    return "load average " + " ".join(f"{v:.2f}" for v in os.getloadavg()) + f" on {os.cpu_count()} cores"


def main() -> None:
    occ = world()
    params = CostmapParams(
        resolution=0.05,
        robot_radius=0.22,
        plugins=("static_layer", "inflation_layer"),
        layers={"static_layer": StaticLayerParams(), "inflation_layer": InflationLayerParams(cost_scaling_factor=3.0)},
    )
    cm = Costmap2D(params)
    cm.set_static_map(occ)
    cm.update(1.0, 1.0)
    start, goal = (1.0, 1.0, 0.0), (19.0, 19.0, 0.0)
    print(
        f"grid {cm.size_x} x {cm.size_y} cells ({cm.size_x * cm.resolution:.0f} x {cm.size_y * cm.resolution:.0f} m "
        f"at {cm.resolution} m), {int((cm.costs == 254).sum())} lethal cells"
    )
    print(load())
    for potential, n in (("wavefront", 15), ("exact", 3)):
        planner = NavfnPlanner(NavfnParams(), potential=potential)
        plan = planner.plan(cm, start, goal)
        ms, cpu = timed(lambda: planner.plan(cm, start, goal), n)
        print(
            f"NavFn ({potential:9s}) median {ms:7.1f} ms (CPU {cpu:6.1f} ms) over {n} runs; target 50 ms: "
            f"ratio {ms / 50:.2f}; path {plan.length:.2f} m, cost {plan.cost:.2f}, {len(plan.poses)} poses"
        )
    c = navfn_costs(cm.costs)
    a = potential_exact(c, (20, 20), (380, 380))
    b = potential_wavefront(c, (20, 20), (380, 380))
    both = (a < 1e9) & (b < 1e9)
    rel = np.abs(a[both] - b[both]) / np.maximum(a[both], 1.0)
    print(
        f"wavefront vs exact potential: median {np.median(rel) * 100:.2f} %, 99th pct {np.percentile(rel, 99) * 100:.2f} %,"
        f" at the goal {(b[380, 380] / a[380, 380] - 1) * 100:+.2f} %"
    )

    # costmap update: one 720-beam scan (6 m range) into an obstacle + inflation layer
    src = ObservationSourceParams(
        topic="/scan",
        data_type="LaserScan",
        clearing=True,
        marking=True,
        max_obstacle_height=2.0,
        obstacle_max_range=5.5,
        raytrace_max_range=6.0,
    )
    p2 = CostmapParams(
        resolution=0.05,
        width=20,
        height=20,
        robot_radius=0.22,
        plugins=("static_layer", "obstacle_layer", "inflation_layer"),
        layers={
            "static_layer": StaticLayerParams(),
            "obstacle_layer": ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}),
            "inflation_layer": InflationLayerParams(cost_scaling_factor=3.0),
        },
    )
    cm2 = Costmap2D(p2)
    cm2.set_static_map(occ)
    cm2.update(10.0, 10.0)
    rng = np.random.default_rng(3)
    scan = m.msg_class(m.LASER_SCAN)(
        header=m.header(0, "laser"),
        angle_min=-np.pi,
        angle_max=np.pi,
        angle_increment=2 * np.pi / 720,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.12,
        range_max=6.0,
        ranges=rng.uniform(0.5, 6.5, 720).astype(np.float32),
        intensities=np.zeros(720, np.float32),
    )
    pts = scan_points(scan) + np.array([10.0, 10.0, 0.1])

    def one_update():
        cm2.add_observation(Observation(np.array([10.0, 10.0, 0.1]), pts, "scan"))
        cm2.update(10.0, 10.0)

    ms, cpu = timed(one_update, 41)
    print(
        f"costmap update (720-beam scan, clearing + marking + inflation) on {cm2.size_x} x {cm2.size_y}: "
        f"median {ms:.2f} ms (CPU {cpu:.2f} ms); target 5 ms: ratio {ms / 5:.2f}"
    )
    print(load())


if __name__ == "__main__":
    main()
