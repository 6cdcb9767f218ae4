"""Loading and compiling a robot from its description file: Nav2's TurtleBot3 Waffle (and the TurtleBot4).

For each robot, in a fresh interpreter each time (``--runs`` of them, the median printed): the wall
time of the imports navlog needs (MuJoCo, xacro, trimesh), of ``load_robot`` (xacro expansion,
parsing, meshes read), and of building and compiling the MuJoCo model of the robot in a world
(``--world``, a navlog world; default walled_room); then the same load and compile again in the same
process (warm: the imports and the mesh cache done). The issue's budget: <= 2 s for the Waffle.

    .venv/bin/python benchmarks/bench_robot.py [--runs 5] [--world walled_room] [--shared ../shared]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ROBOTS = {
    "waffle (gz_waffle.sdf.xacro)": "nav2_sim/nav2_minimal_tb3_sim/urdf/gz_waffle.sdf.xacro",
    "turtlebot4 (turtlebot4.urdf.xacro)": "nav2_sim/nav2_minimal_tb4_description/urdf/standard/turtlebot4.urdf.xacro",
}

CHILD = r"""
import json, logging, sys, time
t0 = time.perf_counter()
from navlog.recorder.world import import_mujoco, load_world, build_spec
mujoco = import_mujoco()
import xacro, trimesh  # noqa: F401
from navlog.recorder.robot import load_robot, add_to_spec
t1 = time.perf_counter()
logging.disable(logging.WARNING)
world = load_world(sys.argv[2])
robot = load_robot(sys.argv[1])
t2 = time.perf_counter()
spec = build_spec(world); add_to_spec(spec, robot, (0.0, 0.0, 0.0)); model = spec.compile()
t3 = time.perf_counter()
robot = load_robot(sys.argv[1])
spec = build_spec(world); add_to_spec(spec, robot, (0.0, 0.0, 0.0)); model = spec.compile()
t4 = time.perf_counter()
print(json.dumps({"imports": t1 - t0, "load": t2 - t1, "compile": t3 - t2, "warm": t4 - t3, "nbody": model.nbody}))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--world", default="walled_room")
    ap.add_argument("--shared", type=Path, default=REPO.parent / "shared")
    args = ap.parse_args()
    data = args.shared / "external-data"
    print(f"load average {os.getloadavg()[0]:.2f} (1 min), {os.cpu_count()} CPUs; world {args.world}")
    print(f"{'robot':38} {'imports':>8} {'load':>8} {'compile':>8} {'total':>8} {'warm':>8}  bodies")
    for name, rel in ROBOTS.items():
        path = data / rel
        if not path.is_file():
            print(f"{name:38} (not found: {path})")
            continue
        runs = []
        for _ in range(args.runs):
            out = subprocess.run(
                [sys.executable, "-c", CHILD, str(path), args.world], capture_output=True, text=True, check=True
            )
            runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
        med = {k: statistics.median(r[k] for r in runs) for k in ("imports", "load", "compile", "warm")}
        total = med["imports"] + med["load"] + med["compile"]
        print(
            f"{name:38} {med['imports']:7.2f}s {med['load']:7.2f}s {med['compile']:7.2f}s {total:7.2f}s "
            f"{med['warm']:7.3f}s  {runs[0]['nbody']}"
        )
    print(f"load average {os.getloadavg()[0]:.2f} (1 min) after; median of {args.runs} fresh processes each")


if __name__ == "__main__":
    main()
