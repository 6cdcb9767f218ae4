"""Navigation runs recorded with the whole stack: real-time factor per controller, against the 5x target.

Run: .venv/bin/python benchmarks/bench_navigation.py [--controllers rpp dwb mppi] [--repeat 1]

Each run is `navlog record --scenario nav_tour` (Go2 in indoor_room, the article's four waypoints and back,
NavFn, the controller, velocity smoother and collision monitor live) with config/nav2/nav_go2.yaml (RPP),
nav_go2_dwb.yaml or nav_go2_mppi.yaml, in this process, one after the other. Printed per controller: sim
seconds, wall seconds (best of --repeat), real-time factor = sim / wall and its ratio to the 5x target, the
goals reached and the recoveries; the process CPU time beside the wall clock and the load average, since
the machine may be shared. MPPI's own cycle time: benchmarks/bench_mppi.py.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from navlog.recorder.navigation import navigation_pipeline
from navlog.recorder.record import prepare, record

FILES = {"rpp": "nav_go2", "dwb": "nav_go2_dwb", "mppi": "nav_go2_mppi"}
TARGET = 5.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--controllers", nargs="+", choices=sorted(FILES), default=["rpp", "dwb", "mppi"])
    ap.add_argument("--repeat", type=int, default=1, help="runs per controller; the best wall time counts")
    args = ap.parse_args()
    print(f"load average before: {' '.join(f'{v:.2f}' for v in os.getloadavg())}; {os.cpu_count()} CPUs")
    setup = prepare(None, None, "nav_tour", seed=0)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.controllers:
            best = None
            for k in range(args.repeat):
                nav = navigation_pipeline(setup.scenario, setup.seed, FILES[name])
                cpu = time.process_time()
                res = record(setup, Path(tmp) / f"{name}-{k}.mcap", progress=False, navigation=nav, force=True)
                cpu = time.process_time() - cpu
                if best is None or res.wall_s < best[0].wall_s:
                    best = (res, cpu)
            assert best is not None
            res, cpu = best
            goals = res.navigation["goals"] if res.navigation else []
            reached = sum(g["status"] == "succeeded" for g in goals)
            recoveries = sum(g["recoveries"] for g in goals)
            rows.append((name, res.sim_s, res.wall_s, cpu, res.real_time_factor, reached, len(goals), recoveries))
    print(f"{'controller':<10} {'sim s':>7} {'wall s':>7} {'cpu s':>7} {'RTF':>6} {'/5x':>5}  goals  recoveries")
    for name, sim, wall, cpu, rtf, reached, total, rec in rows:
        print(
            f"{name:<10} {sim:7.1f} {wall:7.2f} {cpu:7.2f} {rtf:5.1f}x {rtf / TARGET:5.2f}  {reached}/{total}"
            f"  {rec:>10}"
        )
    print(f"load average after: {' '.join(f'{v:.2f}' for v in os.getloadavg())}")


if __name__ == "__main__":
    main()
