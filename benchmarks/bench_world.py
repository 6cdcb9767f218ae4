"""Loading and compiling a Gazebo SDF world: Nav2's getting-started sandbox (tb3_sandbox.sdf.xacro).

Each run is a fresh process (imports included, as `navlog record` pays them): expand the xacro,
resolve ``model://turtlebot3_world``, read the DAE meshes, split and classify them
(``load_world``), then build and compile the MuJoCo model (``build_spec``). Printed: the median of
the runs, its ratio to the 2 s ceiling, and the load average.

    .venv/bin/python benchmarks/bench_world.py [--runs 5] [--world PATH]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

CEILING_S = 2.0
SANDBOX = (
    Path(__file__).resolve().parents[2]
    / "shared/external-data/nav2_sim/nav2_minimal_tb3_sim/worlds/tb3_sandbox.sdf.xacro"
)
CHILD = """
import sys, time
t0 = time.perf_counter()
from navlog.recorder.world import build_spec, load_world
world = load_world(sys.argv[1])
t1 = time.perf_counter()
model = build_spec(world).compile()
t2 = time.perf_counter()
print(t1 - t0, t2 - t1, len(world.solids), model.ngeom)
"""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--world", type=Path, default=SANDBOX)
    args = ap.parse_args()
    if not args.world.is_file():
        print(f"no world at {args.world}", file=sys.stderr)
        return 2
    loads, compiles = [], []
    for _ in range(args.runs):
        out = subprocess.run([sys.executable, "-c", CHILD, str(args.world)], capture_output=True, text=True, check=True)
        load_s, compile_s, solids, geoms = out.stdout.split()
        loads.append(float(load_s))
        compiles.append(float(compile_s))
    total = statistics.median(a + b for a, b in zip(loads, compiles))
    print(f"world {args.world.name}: {solids} solids, {geoms} MuJoCo geoms")
    print(
        f"load {statistics.median(loads):.3f} s + compile {statistics.median(compiles):.3f} s = {total:.3f} s "
        f"(median of {args.runs}); ceiling {CEILING_S} s, ratio {total / CEILING_S:.2f}"
    )
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    return 0 if total <= CEILING_S else 1


if __name__ == "__main__":
    sys.exit(main())
