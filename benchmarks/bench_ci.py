"""`navlog ci run` of the shipped suite (config/suites/navlog.yaml): wall time cold and warm.

Cold: an empty cache, so the golden logs are recorded from their recipes and every case replays.
Warm: the same cache, so recordings and replays are reused and only the input checks and the
comparisons run. Prints per step (record, input check, replay, compare) the time summed over the
cases and the share of the suite's time replaying versus comparing, with `--workers 1` and 2, and
the load average with the numbers; nothing is asserted.

    .venv/bin/python benchmarks/bench_ci.py [--workers 1 2]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from navlog.analysis.ci import run_suite

SUITE = Path(__file__).resolve().parents[1] / "config" / "suites" / "navlog.yaml"


def measure(cache: Path, workers: int) -> tuple[float, dict[str, float], int]:
    t0 = time.perf_counter()
    result = run_suite(SUITE, cache_dir=cache, workers=workers)
    wall = time.perf_counter() - t0
    steps: dict[str, float] = {}
    seen_logs: set[str] = set()
    for case in result.cases:
        for step, seconds in case.timings.items():
            if step == "log":  # one recording serves every case of the recipe
                if case.source in seen_logs:
                    continue
                seen_logs.add(case.source)
            steps[step] = steps.get(step, 0.0) + seconds
    return wall, steps, result.exit_code


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    print(f"suite {SUITE}  (load average {os.getloadavg()[0]:.2f})")
    for workers in args.workers:
        with tempfile.TemporaryDirectory(prefix="navlog-bench-ci-") as tmp:
            for label in ("cold", "warm"):
                wall, steps, code = measure(Path(tmp), workers)
                total = sum(steps.values()) or 1.0
                shares = ", ".join(f"{k} {v:.2f} s ({v / total:.0%})" for k, v in sorted(steps.items()))
                print(f"workers {workers} {label}: {wall:.2f} s wall, exit {code}; summed over cases: {shares}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
