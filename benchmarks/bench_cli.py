"""How long a user waits for `navlog --help` and `navlog COMMAND --help`, against a 0.5 s ceiling.

Run: .venv/bin/python benchmarks/bench_cli.py [--runs 7]
Each command is a fresh process; the bare interpreter start (`python -c pass`) is timed in the same run
as the floor, so the ratio says what navlog adds to it. The load average is printed with the numbers.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

CEILING_S = 0.5


def timed(argv: list[str], runs: int) -> tuple[float, float]:
    """(best, median) wall seconds of a fresh process running argv."""
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=True, timeout=120)
        times.append(time.perf_counter() - t0)
    return min(times), statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=7)
    args = parser.parse_args()
    from navlog.cli import COMMANDS

    print(f"load average {os.getloadavg()[0]:.2f}, {os.cpu_count()} CPUs, {args.runs} runs each")
    floor_best, floor_med = timed([sys.executable, "-c", "pass"], args.runs)
    print(f"{'python -c pass':32s} best {floor_best * 1e3:6.0f} ms  median {floor_med * 1e3:6.0f} ms  (floor)")
    worst = 0.0
    for cmd in [[], *[[c] for c in COMMANDS]]:
        best, med = timed([sys.executable, "-m", "navlog", *cmd, "--help"], args.runs)
        worst = max(worst, med)
        label = "navlog " + " ".join([*cmd, "--help"])
        print(
            f"{label:32s} best {best * 1e3:6.0f} ms  median {med * 1e3:6.0f} ms  "
            f"ceiling ratio {med / CEILING_S:.2f}  floor ratio {med / floor_med:.1f}x"
        )
    print(f"slowest median {worst:.3f} s against the {CEILING_S} s ceiling: ratio {worst / CEILING_S:.2f}")


if __name__ == "__main__":
    main()
