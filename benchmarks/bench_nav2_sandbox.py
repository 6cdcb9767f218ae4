"""Nav2's getting-started simulation: loading the Waffle in the sandbox, and recording the navigation tour.

1. Load and compile: a fresh process (imports included, as `navlog record` pays them) loads
   ``tb3_sandbox.sdf.xacro`` and ``gz_waffle.sdf.xacro`` (xacro, ``model://``, DAE meshes) and compiles
   the MuJoCo model of both; the median of ``--runs`` against the 2 s ceiling.
2. Record: ``navlog record --scenario nav2_tb3_sandbox --localization amcl`` (Nav2's nav2_params.yaml:
   MPPI with 2000 samples of 56 steps at 20 Hz, AMCL with up to 2000 particles), sim seconds per wall
   second and per CPU second of the process against the 20x target; with ``--profile``, where the CPU
   time goes (the top functions by own time).

    .venv/bin/python benchmarks/bench_nav2_sandbox.py [--runs 3] [--skip-record] [--profile]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LOAD_CEILING_S = 2.0
RECORD_TARGET = 20.0  # x real time
DATA = Path(__file__).resolve().parents[2] / "shared" / "external-data"
CHILD = """
import logging, sys, time
t0 = time.perf_counter()
from navlog.recorder.description import load_robot
from navlog.recorder.sim import add_to_spec
from navlog.recorder.world import build_spec, load_world
world = load_world(sys.argv[1])
robot = load_robot(sys.argv[2])
t1 = time.perf_counter()
spec = build_spec(world)
add_to_spec(spec, robot, (-2.0, -0.5, 0.0))
model = spec.compile()
t2 = time.perf_counter()
print(t1 - t0, t2 - t1, model.ngeom)
"""


def load_and_compile(runs: int) -> None:
    sim = DATA / "nav2_sim" / "nav2_minimal_tb3_sim"
    world, robot = sim / "worlds" / "tb3_sandbox.sdf.xacro", sim / "urdf" / "gz_waffle.sdf.xacro"
    loads, compiles, geoms = [], [], "?"
    for _ in range(runs):
        out = subprocess.run(
            [sys.executable, "-c", CHILD, str(world), str(robot)], capture_output=True, text=True, check=True
        )
        load_s, compile_s, geoms = out.stdout.split()
        loads.append(float(load_s))
        compiles.append(float(compile_s))
    total = statistics.median(a + b for a, b in zip(loads, compiles))
    print(
        f"load + compile, Waffle in the sandbox ({geoms} geoms): load {statistics.median(loads):.3f} s + compile "
        f"{statistics.median(compiles):.3f} s = {total:.3f} s (median of {runs}); ceiling {LOAD_CEILING_S} s, "
        f"ratio {total / LOAD_CEILING_S:.2f}"
    )


def record_tour(profile: bool) -> None:
    import logging

    from navlog.recorder.record import prepare, record

    logging.disable(logging.WARNING)
    setup = prepare(None, None, "nav2_tb3_sandbox", localization="amcl", package_paths=[DATA])
    with tempfile.TemporaryDirectory() as tmp:
        cpu0 = resource.getrusage(resource.RUSAGE_SELF).ru_utime + resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
        wall0 = time.perf_counter()
        if profile:
            import cProfile
            import pstats

            prof = cProfile.Profile()
            res = prof.runcall(record, setup, Path(tmp) / "nav.mcap", progress=False)
        else:
            res = record(setup, Path(tmp) / "nav.mcap", progress=False)
        wall = time.perf_counter() - wall0
        usage = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = usage[0].ru_utime + usage[1].ru_utime - cpu0
    reached = sum(g["status"] == "succeeded" for g in (res.navigation or {}).get("goals", []))
    print(
        f"record nav2_tb3_sandbox: {res.sim_s:.1f} sim s, {reached} goals reached, {res.collisions} contacts; "
        f"wall {wall:.1f} s = {res.sim_s / wall:.1f}x real time, CPU {cpu:.1f} s = {res.sim_s / cpu:.1f}x "
        f"(target {RECORD_TARGET:.0f}x)"
    )
    if profile:
        pstats.Stats(prof).sort_stats("tottime").print_stats(15)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--skip-record", action="store_true", help="only load and compile")
    ap.add_argument("--profile", action="store_true", help="profile the recording")
    args = ap.parse_args()
    if not DATA.is_dir():
        print(f"no external data at {DATA}", file=sys.stderr)
        return 2
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    load_and_compile(args.runs)
    if not args.skip_record:
        record_tour(args.profile)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
