"""`navlog diff` of two replays of the 138 s mapping log, against the 5 s target.

The log is recorded with `navlog record --scenario mapping --seed 7` (indoor_room, go2) and replayed
twice through the full mapping pipeline (2D map and 3D LiDAR mapper): once with the defaults, once
with `--set occupancy.grid.resolution=0.1`. Then `navlog diff A B` runs `--repeat` times as a
subprocess (the wall time a user sees, start-up included) and once in-process with a breakdown:
manifest fast path, the map comparator, and replay.mcap topic by topic. Also the diff of A with an
identical replay (everything EQUAL from the manifest hashes). Prints the load average with the
numbers; nothing is asserted.

    .venv/bin/python benchmarks/bench_diff.py [--workdir DIR] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 5.0


def run(cmd: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=False, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workdir", type=Path, help="keep (and reuse) the log and the replays here")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    work = args.workdir or Path(tempfile.mkdtemp(prefix="navlog-bench-diff-"))
    work.mkdir(parents=True, exist_ok=True)
    navlog = str(Path(sys.executable).with_name("navlog"))
    try:
        log = work / "mapping.mcap"
        if not log.is_file():
            subprocess.run([navlog, "-q", "record", "--scenario", "mapping", "--seed", "7", "-o", str(log)], check=True)
        runs = {"a": [], "a_again": [], "b": ["--set", "occupancy.grid.resolution=0.1"]}
        for name, extra in runs.items():
            if not (work / name / "manifest.json").is_file():
                cmd = [navlog, "-q", "replay", str(log), "--pipeline", "mapping", "-o", str(work / name), "--force"]
                subprocess.run([*cmd, *extra], check=True, stdout=subprocess.DEVNULL)
        a, a2, b = (str(work / n) for n in runs)

        changed = [run([navlog, "diff", a, b, "--json", str(work / "diff.json")]) for _ in range(args.repeat)]
        equal = [run([navlog, "diff", a, a2]) for _ in range(args.repeat)]

        from navlog.analysis.diff import diff
        from navlog.analysis.diff.artifacts import compare_map_files
        from navlog.analysis.diff.logs import compare_logs
        from navlog.analysis.diff.tolerances import DiffTolerances

        tol = DiffTolerances()
        t0 = time.perf_counter()
        report = diff(a, b)
        t_lib = time.perf_counter() - t0
        t0 = time.perf_counter()
        compare_map_files("map.yaml", Path(a) / "map.yaml", Path(b) / "map.yaml", tol)
        t_map = time.perf_counter() - t0
        t0 = time.perf_counter()
        compare_logs(Path(a) / "replay.mcap", Path(b) / "replay.mcap", tol)
        t_log = time.perf_counter() - t0

        size = (Path(a) / "replay.mcap").stat().st_size / 1e6
        print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())} on {os.cpu_count()} CPUs")
        print(f"mapping log: {log.stat().st_size / 1e6:.1f} MB; replay.mcap {size:.1f} MB per replay")
        print(
            f"navlog diff A B (resolution 0.05 vs 0.1 m): best {min(changed):.2f} s, median "
            f"{sorted(changed)[len(changed) // 2]:.2f} s of {len(changed)} -> {min(changed) / TARGET_S:.0%} of "
            f"the {TARGET_S:g} s target; exit {report.exit_code}"
        )
        print(f"navlog diff A A' (same parameters, manifest hashes only): best {min(equal):.2f} s")
        print(
            f"in-process: diff() {t_lib:.2f} s = map.yaml grid {t_map:.2f} s + replay.mcap topics {t_log:.2f} s "
            "+ manifests"
        )
        for c in report.checks:
            print(f"  {c.verdict.value:8s} {c.name:20s} {c.detail}")
        if report.first_divergence:
            print(f"  first divergence: {report.first_divergence.describe()}")
    finally:
        if args.workdir is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
