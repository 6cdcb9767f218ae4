"""Navigation campaign throughput and executor independence, against the campaign targets.

Two parts (each runs its campaign into fresh folders; nothing is asserted, every target is printed
with the measured value; on a shared machine read the load averages printed before and after):

- ``executors`` (default): a campaign in this process, on a pool of 2 worker processes and on a local
  Ray instance of 2 CPUs, in that order, ``--repeat`` times alternating: by default ``barn_like``'s DWB
  variant (50 runs; ``--variant`` picks others), or with ``--campaign small`` ``small.yaml`` (3
  generated rooms x 2 seeds x 2 variants: 12 short Go2 runs, where starting the workers and planning
  the campaign weigh more than the runs). Targets: the pool >= 1.7x one process; Ray's wall time within
  15 % of the pool's; the same deterministic rows whichever executor ran (the bytes of
  ``campaign.json`` and ``campaign.csv`` compared).
- ``barn``: ``examples/campaigns/barn_like.yaml`` (50 generated BARN-style fields x 1 seed; the three
  variants RPP, MPPI and DWB, or those given with ``--variant``) on a pool of 2 workers. Target: at
  most 10 minutes on 2 cores for the 50 worlds of one seed.

    .venv/bin/python benchmarks/bench_campaign.py [executors] [--campaign barn|small] [--variant dwb] [--repeat 1] [--no-ray]
    .venv/bin/python benchmarks/bench_campaign.py barn [--variant rpp] [--workers 2]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from navlog.campaign.runner import make_executor, run_campaign

CAMPAIGNS = Path(__file__).parents[1] / "examples" / "campaigns"
SMALL, BARN = CAMPAIGNS / "small.yaml", CAMPAIGNS / "barn_like.yaml"
POOL_SPEEDUP, RAY_WITHIN, BARN_CEILING_S = 1.7, 0.15, 600.0


def load() -> str:
    return ", ".join(f"{x:.2f}" for x in os.getloadavg())


def once(campaign: Path, out: Path, executor, only=()) -> tuple[float, float, int, bytes]:
    """Wall s, sim s, runs, and the deterministic reports' bytes of one campaign run into ``out``."""
    start = time.perf_counter()
    res = run_campaign(campaign, out, executor=executor, progress=False, only=only)
    wall = time.perf_counter() - start
    sim = sum(r.get("sim_s", 0.0) for r in res.rows)
    return wall, sim, len(res.rows), (out / "campaign.json").read_bytes() + (out / "campaign.csv").read_bytes()


def executors(args: argparse.Namespace) -> None:
    from navlog.analysis.fleet.executors import InProcess, ProcessPool, RayPool

    makers = {"1 process": InProcess, "pool of 2": lambda: ProcessPool(2)}
    if not args.no_ray:
        makers["Ray, 2 CPUs"] = lambda: RayPool(local_cpus=2)
    walls: dict[str, list[float]] = {k: [] for k in makers}
    reports: dict[str, bytes] = {}
    campaign, only = (SMALL, ()) if args.campaign == "small" else (BARN, tuple(args.variant) or ("dwb",))
    print(f"campaign {campaign.name}" + (f", variants {', '.join(only)}" if only else ""))
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(args.repeat):
            for name, make in makers.items():
                ex = make()
                try:
                    wall, sim, runs, report = once(campaign, Path(tmp) / f"{rep}-{name}", ex, only=only)
                finally:
                    ex.close()
                walls[name].append(wall)
                reports[name] = report
                print(f"{name}: {runs} runs in {wall:.1f} s = {runs / wall * 60:.1f} runs/min, {sim / wall:.1f}x real "
                      f"time (load {load()})")  # fmt: skip
    best = {k: min(v) for k, v in walls.items()}
    speedup = best["1 process"] / best["pool of 2"]
    print(
        f"pool of 2 vs 1 process: {speedup:.2f}x (target >= {POOL_SPEEDUP}x): {'MET' if speedup >= POOL_SPEEDUP else 'MISSED'}"
    )
    if "Ray, 2 CPUs" in best:
        gap = best["Ray, 2 CPUs"] / best["pool of 2"] - 1
        print(
            f"Ray vs pool of 2: {gap:+.1%} wall time (target within {RAY_WITHIN:.0%}): {'MET' if abs(gap) <= RAY_WITHIN else 'MISSED'}"
        )
    same = len(set(reports.values())) == 1
    print(f"same campaign.json and campaign.csv bytes from {', '.join(reports)}: {same}")


def barn(args: argparse.Namespace) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        ex = make_executor(args.workers)
        try:
            wall, sim, runs, _ = once(BARN, Path(tmp) / "barn", ex, only=args.variant)
        finally:
            ex.close()
    which = ", ".join(args.variant) or "rpp, mppi, dwb"
    print(f"barn_like ({which}), {args.workers} workers: {runs} runs in {wall:.0f} s, {sim / wall:.1f}x real time")
    print(
        f"50 worlds x 1 seed: {wall:.0f} s vs the ceiling {BARN_CEILING_S:.0f} s: {'MET' if wall <= BARN_CEILING_S else 'MISSED'}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", nargs="?", default="executors", choices=("executors", "barn"))
    ap.add_argument("--repeat", type=int, default=1, help="executors: rounds, alternating the executors")
    ap.add_argument("--no-ray", action="store_true", help="executors: leave Ray out")
    ap.add_argument("--campaign", choices=("barn", "small"), default="barn", help="executors: the campaign run")
    ap.add_argument("--variant", action="append", default=[], help="only this variant (repeatable; executors: dwb)")
    ap.add_argument("--workers", type=int, default=2, help="barn: worker processes")
    args = ap.parse_args()
    print(f"load average before: {load()} ({os.cpu_count()} CPUs)")
    (barn if args.part == "barn" else executors)(args)
    print(f"load average after: {load()}")


if __name__ == "__main__":
    main()
