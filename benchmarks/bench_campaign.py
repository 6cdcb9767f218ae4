"""Navigation campaign throughput: runs per minute of the small campaign on one process and on 2 workers.

Runs ``examples/campaigns/small.yaml`` (3 generated rooms x 2 seeds x 2 variants: 12 recorded Go2
navigation runs of 10-60 s sim time) into fresh folders, first in this process, then on a pool of
2 worker processes, and prints for each the wall time, the runs per minute, the sim seconds per wall
second (the real-time factor of the whole campaign), the ratio of the two, and whether both gave the
same ``campaign.json`` bytes (the rows do not depend on the executor). The issue's figure: navlog
records navigation at 5-50x real time. Nothing is asserted; on a shared machine compare ratios, and
read the load printed before and after.

    .venv/bin/python benchmarks/bench_campaign.py [--workers 2] [--skip-serial]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from navlog.campaign.runner import run_campaign

SMALL = Path(__file__).parents[1] / "examples" / "campaigns" / "small.yaml"


def once(out: Path, workers: int) -> tuple[float, float, int, bytes]:
    start = time.perf_counter()
    res = run_campaign(SMALL, out, workers=workers, progress=False)
    wall = time.perf_counter() - start
    sim = sum(r.get("sim_s", 0.0) for r in res.rows)
    return wall, sim, len(res.rows), (out / "campaign.json").read_bytes()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--skip-serial", action="store_true", help="only the pool")
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        results = {}
        for workers in ([] if args.skip_serial else [1]) + [args.workers]:
            wall, sim, runs, report = once(Path(tmp) / f"w{workers}", workers)
            results[workers] = (wall, report)
            print(
                f"{workers} worker(s): {runs} runs in {wall:.1f} s = {runs / wall * 60:.1f} runs/min, "
                f"{sim:.0f} sim s: {sim / wall:.1f}x real time"
            )
        if len(results) == 2:
            (w1, r1), (w2, r2) = results[1], results[args.workers]
            print(f"pool speed-up: {w1 / w2:.2f}x (target on 2 cores: >= 1.7x); same campaign.json: {r1 == r2}")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
