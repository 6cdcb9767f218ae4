"""NavFn side by side with Nav2's own navfn.cpp, and a costmap update against Nav2's 5 ms target.

Run: .venv/bin/python benchmarks/bench_planner.py [--nav2-src DIR] [--runs 15] [--small] [--write-reference NPZ]

The maps are the four of ``tests/replay/nav2/planners/navfn_maps.py`` (120-box clutter, empty and maze
at 400 x 400 cells, 120-box clutter at 1000 x 1000; 0.05 m, inflated as Nav2's global costmap), each
planned with Dijkstra and with A*. navlog's time is a whole ``NavfnPlanner.plan`` call (median of
``--runs``). With ``--nav2-src`` (a navigation2 source tree: the directory holding
``nav2_navfn_planner/``) a small harness around that tree's ``navfn.cpp`` is built with ``g++ -O2``
in a temporary directory; it times what Nav2's ``makePlan`` does with NavFn (``setNavArr``,
``setCostmap``, the propagation, ``calcPath``) on the same costs, cells and step limit, and the table
adds Nav2's time, the ratio, the path length and cost differences and the Hausdorff distance between
the two paths (in cells), plus the largest relative difference between the two potentials. Without
``--nav2-src`` it prints navlog's figures alone. The project ships no Nav2 code: the harness reads
the tree the user points to. ``--write-reference`` stores Nav2's paths and potentials (every 20th
cell) for the tests (``tests/replay/nav2/planners/nav2_navfn_reference.npz``).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.distance import directed_hausdorff

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
from navlog.replay.nav2.planners.base import path_cost, path_length
from navlog.replay.nav2.planners.navfn import (
    COST_NEUTRAL,
    NavfnParams,
    NavfnPlanner,
    navfn_costs,
    poses_from_cells,
)
from navlog.replay.occupancy_map import OccupancyMap

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # the repository: tests/ holds the maps
from tests.replay.nav2.planners.navfn_maps import BenchMap, bench_maps, clutter

# stand-ins for the two ROS headers navfn.cpp includes: logging macros that do nothing, and the exception
STUB_RCLCPP = """#pragma once
#define RCLCPP_DEBUG(...) ((void)0)
#define RCLCPP_WARN(...) ((void)0)
#define RCLCPP_ERROR(...) ((void)0)
"""
STUB_EXCEPTIONS = """#pragma once
#include <stdexcept>
namespace nav2_core {
struct PlannerCancelled : std::runtime_error { using std::runtime_error::runtime_error; };
}
"""
# reads one case, plans it `runs` times as NavfnPlanner::makePlan drives NavFn, writes times, potential and path
HARNESS = r"""
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>
#include "nav2_navfn_planner/navfn.hpp"

int main(int argc, char ** argv) {
  FILE * in = std::fopen(argv[1], "rb");
  int h[9];  // nx, ny, robot x, y, goal x, y, use_astar, allow_unknown, max_cycles
  if (std::fread(h, sizeof(int), 9, in) != 9) return 2;
  int runs = 0;
  if (std::fread(&runs, sizeof(int), 1, in) != 1) return 2;
  std::vector<unsigned char> costs(static_cast<size_t>(h[0]) * h[1]);
  if (std::fread(costs.data(), 1, costs.size(), in) != costs.size()) return 2;
  std::fclose(in);
  nav2_navfn_planner::NavFn nav(h[0], h[1]);
  std::vector<double> ms;
  int len = 0;
  for (int r = 0; r < runs; r++) {
    auto t0 = std::chrono::steady_clock::now();
    nav.setNavArr(h[0], h[1]);
    nav.setCostmap(costs.data(), true, h[7] != 0);
    int robot[2] = {h[2], h[3]};
    int goal[2] = {h[4], h[5]};
    nav.setStart(goal);
    nav.setGoal(robot);
    if (h[6]) {
      nav.calcNavFnAstar([]() {return false;});
    } else {
      nav.calcNavFnDijkstra([]() {return false;}, true);
    }
    len = nav.calcPath(h[8]);
    auto t1 = std::chrono::steady_clock::now();
    ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  FILE * out = std::fopen(argv[2], "wb");
  std::fwrite(ms.data(), sizeof(double), ms.size(), out);
  std::fwrite(nav.potarr, sizeof(float), static_cast<size_t>(nav.ns), out);
  std::fwrite(&len, sizeof(int), 1, out);
  std::fwrite(nav.getPathX(), sizeof(float), len, out);
  std::fwrite(nav.getPathY(), sizeof(float), len, out);
  std::fclose(out);
  return 0;
}
"""


class Nav2Harness:
    """Nav2's navfn.cpp from a source tree, built once around HARNESS; ``run`` plans one case."""

    def __init__(self, nav2_src: Path, workdir: Path) -> None:
        pkg = nav2_src / "nav2_navfn_planner"
        if not (pkg / "src" / "navfn.cpp").is_file():
            sys.exit(f"--nav2-src {nav2_src}: no nav2_navfn_planner/src/navfn.cpp there (a navigation2 checkout?)")
        if shutil.which("g++") is None:
            sys.exit("--nav2-src needs g++ on PATH to build the Nav2 harness")
        stub = workdir / "stub"
        (stub / "rclcpp").mkdir(parents=True)
        (stub / "nav2_core").mkdir()
        (stub / "rclcpp" / "rclcpp.hpp").write_text(STUB_RCLCPP)
        (stub / "nav2_core" / "planner_exceptions.hpp").write_text(STUB_EXCEPTIONS)
        (workdir / "harness.cpp").write_text(HARNESS)
        self.exe = workdir / "navfn_harness"
        self.workdir = workdir
        cmd = ["g++", "-O2", "-std=c++17", f"-I{stub}", f"-I{pkg / 'include'}", str(pkg / "src" / "navfn.cpp")]
        subprocess.run([*cmd, str(workdir / "harness.cpp"), "-o", str(self.exe)], check=True)

    def run(self, costs: np.ndarray, robot, goal, use_astar: bool, allow_unknown: bool, max_cycles: int, runs: int):
        """(median ms, potential (ny, nx), path x, path y) of Nav2's NavFn on ROS costs ``costs``."""
        ny, nx = costs.shape
        case, result = self.workdir / "case.bin", self.workdir / "result.bin"
        header = [nx, ny, *robot, *goal, int(use_astar), int(allow_unknown), max_cycles, runs]
        case.write_bytes(np.array(header, dtype=np.int32).tobytes() + np.ascontiguousarray(costs).tobytes())
        subprocess.run([str(self.exe), str(case), str(result)], check=True)
        raw = result.read_bytes()
        ms = np.frombuffer(raw, np.float64, runs)
        off = 8 * runs
        pot = np.frombuffer(raw, np.float32, nx * ny, off).reshape(ny, nx)
        off += 4 * nx * ny
        n = int(np.frombuffer(raw, np.int32, 1, off)[0])
        xs = np.frombuffer(raw, np.float32, n, off + 4)
        ys = np.frombuffer(raw, np.float32, n, off + 4 + 4 * n)
        return float(np.median(ms)), pot, xs, ys


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


def hausdorff(a: np.ndarray, b: np.ndarray) -> float:
    return max(directed_hausdorff(a, b)[0], directed_hausdorff(b, a)[0])


def compare(
    bm: BenchMap, use_astar: bool, runs: int, harness: Nav2Harness | None, reference: dict[str, np.ndarray]
) -> str:
    """One table row: navlog's plan time and path, and Nav2's beside them when a harness is given.

    With a harness, Nav2's path (cells) and its potential on every 20th cell go into ``reference``.
    """
    cm = bm.costmap
    params = NavfnParams(use_astar=use_astar)
    planner = NavfnPlanner(params)
    plan = planner.plan(cm, bm.start, bm.goal)
    ms, _ = timed(lambda: planner.plan(cm, bm.start, bm.goal), runs)
    row = f"| {bm.name} | {'A*' if use_astar else 'Dijkstra'} | {ms:.2f} ms |"
    if harness is None:
        return row + f" {plan.length:.3f} m | {plan.cost:.3f} |"
    res, (ny, nx) = cm.resolution, cm.costs.shape
    cell = lambda x, y: (int(np.floor((x - cm.origin_x) / res + 0.5)), int(np.floor((y - cm.origin_y) / res + 0.5)))  # noqa: E731
    robot, goal = cell(*bm.start[:2]), cell(*bm.goal[:2])
    costs = cm.costs.copy()
    costs[robot[1], robot[0]] = 0  # Nav2 clears the robot's cell in the costmap before copying it
    max_cycles = params.max_cycles_factor * max(nx, ny)
    nav2_ms, pot, xs, ys = harness.run(costs, robot, goal, use_astar, params.allow_unknown, max_cycles, runs)
    ours = planner.last_potential
    assert ours is not None
    both = (pot < 1e10) & (ours < 1e10)
    same_cells = bool(np.array_equal(pot < 1e10, ours < 1e10))
    rel = float(np.max(np.abs(pot[both] - ours[both]) / np.maximum(pot[both], 1.0)))
    key = f"{bm.name.replace(' ', '_')}_{'astar' if use_astar else 'dijkstra'}"
    reference[f"{key}_x"], reference[f"{key}_y"] = xs, ys
    reference[f"{key}_potential"] = pot[::20, ::20].copy()
    theirs = poses_from_cells(xs, ys, cm, plan.goal_used)
    nav2_len = path_length(theirs)
    nav2_cost = path_cost(
        theirs, navfn_costs(costs), res, (cm.origin_x - 0.5 * res, cm.origin_y - 0.5 * res), COST_NEUTRAL
    )
    hd = hausdorff(plan.poses[:, :2], theirs[:, :2]) / res
    return (
        row + f" {nav2_ms:.2f} ms | {ms / nav2_ms:.2f} | {(plan.length / nav2_len - 1) * 100:+.4f} % |"
        f" {(plan.cost / nav2_cost - 1) * 100:+.4f} % | {hd:.3f} | {rel:.1e}{'' if same_cells else ' (cells differ)'} |"
    )


def costmap_update() -> str:
    """One 720-beam scan (6 m range) into an obstacle + inflation layer on a 20 x 20 m rolling costmap."""
    occ = OccupancyMap(clutter(400), 0.05, (0.0, 0.0, 0.0))
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
    return (
        f"costmap update (720-beam scan, clearing + marking + inflation) on {cm2.size_x} x {cm2.size_y}: "
        f"median {ms:.2f} ms (CPU {cpu:.2f} ms); target 5 ms: ratio {ms / 5:.2f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nav2-src", type=Path, help="a navigation2 source tree: build Nav2's navfn.cpp beside navlog")
    ap.add_argument("--runs", type=int, default=15, help="runs per map (median)")
    ap.add_argument("--small", action="store_true", help="leave out the 1000 x 1000 map")
    ap.add_argument(
        "--write-reference",
        type=Path,
        help="with --nav2-src: write Nav2's paths and sampled potentials to this .npz (the tests' reference)",
    )
    args = ap.parse_args()
    if args.write_reference and not args.nav2_src:
        ap.error("--write-reference needs --nav2-src (the reference is Nav2's own output)")
    maps = bench_maps(large=not args.small)
    t = time.perf_counter()
    NavfnPlanner(NavfnParams()).plan(maps[1].costmap, (1.0, 1.0, 0.0), (2.0, 2.0, 0.0))
    print(f"first plan in this process (loading the compiled kernels): {(time.perf_counter() - t) * 1000:.0f} ms")
    print(load())
    with tempfile.TemporaryDirectory(prefix="navfn-harness-") as tmp:
        harness = Nav2Harness(args.nav2_src, Path(tmp)) if args.nav2_src else None
        if harness:
            print(
                "| map | search | navlog | Nav2 C++ (g++ -O2) | ratio | length diff | cost diff "
                "| Hausdorff (cells) | potential max rel. diff |"
            )
            print("|---|---|---|---|---|---|---|---|---|")
        else:
            print("| map | search | navlog | length | cost |")
            print("|---|---|---|---|---|")
        reference: dict[str, np.ndarray] = {}
        for bm in maps:
            for use_astar in (False, True):
                print(compare(bm, use_astar, args.runs, harness, reference), flush=True)
    if args.write_reference:
        np.savez_compressed(args.write_reference, **reference)
        print(f"wrote {args.write_reference}")
    print(costmap_update())
    print(load())


if __name__ == "__main__":
    main()
