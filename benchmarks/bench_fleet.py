"""Fleet replay on one machine: 1 vs 2 worker processes, Ray vs the pool, memory per worker, overhead per log.

Records the teleop log (indoor_room + go2, scenario teleop, seed 3: 17 s of sim time) into a work
folder (a temporary one unless --workdir is given; a log already there is reused), makes a fleet of
--logs copies of it, and a fleet of short logs (the log's first chunks, recovered: about 1.6 s of
sim time each). Then prints, in one run:

(a) the fleet's wall time through the full mapping pipeline (2D and 3D mappers) on a pool of 1 and of
    2 worker processes, and their ratio; target: 2 workers >= 1.7x faster on 2 cores;
(b) the same fleet on a local Ray instance of 2 CPUs (started before the clock: `ray start` is a
    cluster's business), against the 2-worker pool; target: within 15 %;
(c) the peak resident memory of each worker (its ru_maxrss, as each log's result reports it);
(d) the overhead per log of each executor on the short logs: (fleet wall x workers - the replays' own
    wall time) / logs, i.e. what a log costs beyond its replay (process start and imports amortised,
    scheduling, passing the result back); in this process, in the pool and on Ray.

Every run writes a fresh output folder; the summary's metrics are left out (``metrics=False``) so the
figures are the replay's. The replays' CPU time against the workers' wall time shows how much of
the wall time the workers actually ran (on a loaded machine they wait for a core). Nothing is asserted; the script prints measured numbers and ratios, and the
machine's load before and after (on a shared machine, compare the ratios, not the seconds).

    .venv/bin/python benchmarks/bench_fleet.py [--logs 8] [--short 16] [--workdir DIR] [--skip-ray]
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def record_teleop(work: Path) -> Path:
    log = work / "teleop.mcap"
    if not log.exists():
        from navlog.recorder.record import prepare, record

        record(prepare("indoor_room", "go2", "teleop", seed=3), log, progress=False)
    return log


def short_log(log: Path, work: Path) -> Path:
    """The log's first chunks as a complete MCAP (``recover_mcap`` of a prefix)."""
    out = work / "short.mcap"
    if not out.exists():
        from navlog.replay.io.recovery import recover_mcap

        prefix = work / "short-prefix.mcap"
        prefix.write_bytes(log.read_bytes()[:3_000_000])
        recover_mcap(prefix, out)
        prefix.unlink()
    return out


def copies(log: Path, folder: Path, n: int) -> list[Path]:
    folder.mkdir(exist_ok=True)
    out = []
    for i in range(n):
        dest = folder / f"{log.stem}{i:02d}.mcap"
        if not dest.exists():
            os.link(log, dest)
        out.append(dest)
    return out


def run(logs, out: Path, *, overrides=(), **kw):
    from navlog.analysis.fleet import replay_fleet

    shutil.rmtree(out, ignore_errors=True)
    start = time.perf_counter()
    res = replay_fleet(logs, "mapping", out, overrides=overrides, metrics=False, progress=False, **kw)
    wall = time.perf_counter() - start
    failed = [r for r in res.results if not r.ok]
    if failed:
        raise SystemExit(f"{failed[0].name}: {failed[0].reason}")
    return wall, res


def overhead(wall: float, parallel: int, res) -> float:
    return (wall * parallel - sum(r.wall_s for r in res.results)) / len(res.results)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=8, help="logs in the fleet (default 8)")
    ap.add_argument("--short", type=int, default=16, help="short logs for the overhead figure (default 16)")
    ap.add_argument("--workdir", type=Path, help="keep the logs here (default: a temporary folder)")
    ap.add_argument("--skip-ray", action="store_true", help="leave Ray out")
    args = ap.parse_args()
    from navlog.analysis.fleet.executors import InProcess, ProcessPool, RayPool, start_local_ray

    work = args.workdir or Path(tempfile.mkdtemp(prefix="navlog-bench-fleet-"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"machine: {os.cpu_count()} CPUs, load average before {os.getloadavg()[0]:.2f}")
    log = record_teleop(work)
    fleet = copies(log, work / "fleet", args.logs)
    shorts = copies(short_log(log, work), work / "short", args.short)
    from navlog.replay.io import open_log

    with open_log(shorts[0]) as reader:
        short_s = reader.duration_ns / 1e9
    print(f"fleet: {len(fleet)} x teleop ({log.stat().st_size / 1e6:.0f} MB, 17 s of sim time), full mapping pipeline")

    one, res1 = run(fleet, work / "out-1", executor=ProcessPool(1))
    two, res2 = run(fleet, work / "out-2", executor=ProcessPool(2))
    print(
        f"(a) pool of 1 worker: {one:.1f} s   pool of 2 workers: {two:.1f} s   speed-up {one / two:.2f}x (target >= 1.7x)"
    )
    for name, wall, res, n in (("1 worker", one, res1, 1), ("2 workers", two, res2, 2)):
        cpu = sum(r.cpu_s for r in res.results)
        print(f"    {name}: the replays' CPU {cpu:.1f} s = {cpu / (wall * n):.0%} of the workers' wall time")
    same = all(a.outputs == b.outputs for a, b in zip(res1.results, res2.results, strict=True))
    print(f"    same output hashes in both runs: {same}")
    mem = {"pool": max(r.peak_rss_mb for r in res2.results)}

    if not args.skip_ray:
        t0 = time.perf_counter()
        ray = start_local_ray(2)
        print(f"    (local Ray instance started in {time.perf_counter() - t0:.1f} s, not counted)")
        on_ray, res_ray = run(fleet, work / "out-ray", executor=RayPool())
        print(
            f"(b) Ray (2 CPUs): {on_ray:.1f} s   pool of 2: {two:.1f} s   Ray / pool {on_ray / two:.2f} "
            f"(target <= 1.15)"
        )
        mem["ray"] = max(r.peak_rss_mb for r in res_ray.results)
    print("(c) peak resident memory per worker: " + ", ".join(f"{k} {v:.0f} MB" for k, v in mem.items()))

    print(f"(d) overhead per log on {len(shorts)} short logs ({short_s:.2f} s of sim time each), 2D mapping:")
    for name, parallel, make in [
        ("this process", 1, InProcess),
        ("pool of 2", 2, lambda: ProcessPool(2)),
        *([] if args.skip_ray else [("Ray (2 CPUs)", 2, RayPool)]),
    ]:
        wall, res = run(shorts, work / "out-short", overrides=["lidar_mapper=off"], executor=make())
        mean = sum(r.wall_s for r in res.results) / len(res.results)
        print(
            f"    {name:13s} fleet {wall:5.2f} s, replay {mean * 1000:6.0f} ms/log, "
            f"overhead {overhead(wall, parallel, res) * 1000:6.0f} ms/log"
        )
    if not args.skip_ray:
        ray.shutdown()
    print(f"load average after {os.getloadavg()[0]:.2f}")
    if args.workdir is None:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
