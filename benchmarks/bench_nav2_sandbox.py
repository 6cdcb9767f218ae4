"""Nav2's getting-started simulation: loading the Waffle in the sandbox, and recording its two runs.

1. Load and compile: a fresh process (imports included, as `navlog record` pays them) loads
   ``tb3_sandbox.sdf.xacro`` and ``gz_waffle.sdf.xacro`` (xacro, ``model://``, DAE meshes) and compiles
   the MuJoCo model of both; the median of ``--runs`` against the 2 s ceiling.
2. The sandbox tour, the run issue 31's 20x target names ("recording the sandbox tour >= 20x real time
   on 2 cores with the mesh world"): ``navlog record --scenario tb3_sandbox_mapping --localization none``
   (the Waffle driven along waypoints, the laser cast against the sandbox's meshes, no navigation
   stack); sim seconds per wall second and per CPU second of the process (its sensor worker included),
   the median of ``--runs``, against the 20x target.
3. The navigation run, beside it with its own figure and no ceiling: ``navlog record --scenario
   nav2_tb3_sandbox --localization amcl`` (Nav2's nav2_params.yaml unchanged: MPPI with 2000 samples of
   56 steps at 20 Hz, AMCL with up to 2000 particles, the global and local costmaps, the planner, the
   velocity smoother and the collision monitor, five goals); the same figures, the median of ``--runs``.

Each recording runs in this process (the first run of each pays numba's cache load and the world's
meshes), the load average printed beside each. With ``--profile``, one more recording of each run under
cProfile: where the CPU time goes (the top functions by own time). The external data is taken from
``--shared`` (default ``$NAVLOG_SHARED_DIR``, else ``shared`` beside the repository), as the tests do.

    .venv/bin/python benchmarks/bench_nav2_sandbox.py [--runs 3] [--only load|tour|nav] [--profile] [--shared DIR]
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

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests.shared_data
from tests.shared_data import default_shared_dir

LOAD_CEILING_S = 2.0
TOUR_TARGET = 20.0  # x real time, issue 31: the sandbox tour on 2 cores with the mesh world
RUNS = {  # name -> (scenario, localization, what it runs)
    "tour": ("tb3_sandbox_mapping", "none", "the sandbox tour: waypoints, laser cast against the meshes"),
    "nav": ("nav2_tb3_sandbox", "amcl", "the navigation run: MPPI 2000 x 56 at 20 Hz, AMCL, costmaps"),
}
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


def _load() -> str:
    return f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs"


def load_and_compile(data: Path, runs: int) -> None:
    sim = data / "nav2_sim" / "nav2_minimal_tb3_sim"
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
        f"ratio {total / LOAD_CEILING_S:.2f} ({_load()})"
    )


def _cpu_s() -> float:
    return sum(
        resource.getrusage(who).ru_utime + resource.getrusage(who).ru_stime
        for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)
    )


def record_once(data: Path, name: str, profile: bool = False) -> tuple[float, float, float, str]:
    """One recording of run ``name``: (sim s, wall s, CPU s, what it reached)."""
    from navlog.recorder.record import prepare, record

    scenario, localization, _ = RUNS[name]
    setup = prepare(None, None, scenario, localization=localization, package_paths=[data])
    with tempfile.TemporaryDirectory() as tmp:
        cpu0, wall0 = _cpu_s(), time.perf_counter()
        if profile:
            import cProfile
            import pstats

            prof = cProfile.Profile()
            res = prof.runcall(record, setup, Path(tmp) / "run.mcap", progress=False)
        else:
            res = record(setup, Path(tmp) / "run.mcap", progress=False)
        wall, cpu = time.perf_counter() - wall0, _cpu_s() - cpu0
    goals = (res.navigation or {}).get("goals", [])
    reached = f"{sum(g['status'] == 'succeeded' for g in goals)} of {len(goals)} goals reached, " if goals else ""
    if profile:
        pstats.Stats(prof).sort_stats("tottime").print_stats(25)
    return res.sim_s, wall, cpu, f"{reached}{res.collisions} contacts"


def record_run(data: Path, name: str, runs: int) -> None:
    scenario, localization, what = RUNS[name]
    walls, cpus, sim_s, reached = [], [], 0.0, ""
    for i in range(runs):
        load = os.getloadavg()[0]
        sim_s, wall, cpu, reached = record_once(data, name)
        walls.append(wall)
        cpus.append(cpu)
        print(
            f"  run {i + 1}: {sim_s:.1f} sim s, wall {wall:.2f} s = {sim_s / wall:.1f}x, CPU {cpu:.2f} s = "
            f"{sim_s / cpu:.1f}x (load average {load:.2f} before, {os.getloadavg()[0]:.2f} after)"
        )
    wall, cpu = statistics.median(walls), statistics.median(cpus)
    target = (
        f"target {TOUR_TARGET:.0f}x, {'met' if sim_s / wall >= TOUR_TARGET else 'not met'}"
        if name == "tour"
        else "no target"
    )
    print(
        f"record {scenario} --localization {localization} ({what}): {sim_s:.1f} sim s, {reached}; median of "
        f"{runs}: {sim_s / wall:.1f}x real time (wall {wall:.2f} s), {sim_s / cpu:.1f}x per CPU s "
        f"(CPU {cpu:.2f} s); {target} ({_load()})"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--only", choices=["load", "tour", "nav"], help="measure one part only")
    ap.add_argument("--profile", action="store_true", help="one more recording of each run under cProfile")
    ap.add_argument("--shared", type=Path, default=default_shared_dir(), help="the external data folder")
    args = ap.parse_args()
    data = args.shared / "external-data"
    if not (data / "nav2_sim").is_dir():
        print(f"no Nav2 simulation files at {data / 'nav2_sim'} (set --shared or NAVLOG_SHARED_DIR)", file=sys.stderr)
        return 2
    import logging

    logging.disable(logging.WARNING)
    print(_load())
    if args.only in (None, "load"):
        load_and_compile(data, args.runs)
    for name in ("tour", "nav"):
        if args.only in (None, name):
            record_run(data, name, args.runs)
            if args.profile:
                print(f"profile of one recording of the {name} run:")
                record_once(data, name, profile=True)
    print(_load())
    return 0


if __name__ == "__main__":
    sys.exit(main())
