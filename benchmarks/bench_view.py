"""`navlog view --save` and `navlog export` speed on a 2-minute mapping log, against the floor and a peer.

The log is recorded with `navlog record --world indoor_room --robot go2 --scenario mapping` (about
138 s of sim time: scan 10 Hz x 720 beams, 3D LiDAR 10 Hz, IMU 200 Hz, odometry and TF 50 Hz, clock
100 Hz). Pass `--log FILE` to use an existing log instead. Prints, best of `--repeat` runs:

- the floor: reading and decoding every message the view draws (LogReader, no Rerun);
- `navlog view --save`: wall seconds, its ratio to the 30 s budget and to sim time; the .rrd size and
  its ratio to the log's size (ceiling 1.0: the recording is no larger than the log), and the
  biggest entities (the 3D LiDAR history, thinned to one cloud per 0.5 s, leads);
- the peer: `rerun mcap convert` (Rerun's own MCAP import, which stores scans, odometry and twists as
  generic columns without drawing them), and navlog's ratio to it;
- `navlog export --to rosbag2` for sqlite3 and MCAP storage: wall seconds and MB/s.

    .venv/bin/python benchmarks/bench_view.py [--log run.mcap] [--repeat 3] [--keep DIR]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from navlog.analysis.export import BagOptions, export_rosbag2
from navlog.analysis.view import save_view
from navlog.replay.io import open_log

BUDGET_S = 30.0
SIZE_CEILING = 1.0  # .rrd bytes / log bytes


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def biggest_entities(rrd: Path, n: int) -> list[tuple[str, float]]:
    """The ``n`` entities holding the most bytes of an .rrd (MB, as Arrow record batches)."""
    from rerun.chunk import RrdReader

    sizes: dict[str, int] = {}
    for ch in RrdReader(rrd).stream().collect().stream():
        sizes[ch.entity_path] = sizes.get(ch.entity_path, 0) + ch.to_record_batch().nbytes
    return [(e, b / 1e6) for e, b in sorted(sizes.items(), key=lambda kv: -kv[1])[:n]]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", type=Path, help="an existing log (default: record a 2-minute mapping log)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--keep", type=Path, help="keep the outputs in this folder")
    args = ap.parse_args()
    work = Path(tempfile.mkdtemp(prefix="navlog-bench-view-")) if args.keep is None else args.keep
    work.mkdir(parents=True, exist_ok=True)
    navlog = Path(sys.executable).with_name("navlog")
    rerun = Path(sys.executable).with_name("rerun")
    try:
        log = args.log
        if log is None:
            log = work / "mapping.mcap"
            cmd = [
                str(navlog),
                "record",
                "--world",
                "indoor_room",
                "--robot",
                "go2",
                "--scenario",
                "mapping",
                "-o",
                str(log),
                "--force",
            ]
            print("recording:", " ".join(cmd[1:]), flush=True)
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True)
            print(f"  recorded in {time.perf_counter() - t0:.1f} s")
        with open_log(log) as r:
            sim_s = r.duration_ns / 1e9
            size_mb = r.size_bytes / 1e6
            counts = {t.name: t.count for t in r.topics.values()}
        print(f"log: {log} ({size_mb:.1f} MB, {sim_s:.1f} s sim time, {sum(counts.values())} messages)")
        for name in sorted(counts):
            print(f"  {name:<22} {counts[name]:>7}")

        def floor() -> None:
            with open_log(log) as r:
                for _ in r.messages([t for t in r.topics if t != "/clock"]):
                    pass

        rrd = work / "view.rrd"

        def view() -> None:
            save_view(log, rrd, force=True)

        peer_rrd = work / "peer.rrd"

        def peer() -> None:
            peer_rrd.unlink(missing_ok=True)
            subprocess.run(
                [str(rerun), "mcap", "convert", str(log), "-o", str(peer_rrd)], check=True, capture_output=True
            )

        t_floor = best(floor, args.repeat)
        t_view = best(view, args.repeat)
        verify = subprocess.run([str(rerun), "rrd", "verify", str(rrd)], capture_output=True, text=True)
        t_peer = best(peer, args.repeat)
        print()
        print(f"read + decode (floor):        {t_floor:7.2f} s")
        print(
            f"navlog view --save:           {t_view:7.2f} s   {t_view / BUDGET_S:.2f} x the {BUDGET_S:.0f} s budget, "
            f"{sim_s / t_view:.1f} x real time, {t_view / t_floor:.2f} x the floor, "
            f".rrd {rrd.stat().st_size / 1e6:.1f} MB, verify {'ok' if verify.returncode == 0 else 'FAILED'}"
        )
        rrd_mb = rrd.stat().st_size / 1e6
        print(
            f"  .rrd / log size:            {rrd_mb / size_mb:7.2f}     ({rrd_mb:.1f} MB / {size_mb:.1f} MB, "
            f"ceiling {SIZE_CEILING:.1f}: {'ok' if rrd_mb / size_mb <= SIZE_CEILING else 'OVER'})"
        )
        for ent, mb in biggest_entities(rrd, 4):
            print(f"    {ent:<32} {mb:7.1f} MB")
        print(
            f"rerun mcap convert (peer):    {t_peer:7.2f} s   navlog/peer = {t_view / t_peer:.2f}, "
            f".rrd {peer_rrd.stat().st_size / 1e6:.1f} MB (scans, odometry, twist not drawn)"
        )
        for storage in ("sqlite3", "mcap"):
            out = work / f"bag_{storage}"

            def export() -> None:
                with open_log(log) as r:
                    export_rosbag2(r, out, BagOptions(storage=storage, distro="humble"), force=True)

            t_exp = best(export, args.repeat)
            print(
                f"navlog export rosbag2 {storage:<7} {t_exp:7.2f} s   {size_mb / t_exp:.0f} MB/s, {t_exp / t_floor:.2f} x the floor"
            )
        print(f"\ncommand: navlog view {log} --save {rrd}")
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
