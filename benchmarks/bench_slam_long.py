"""2D SLAM on a 2 km log: does its time per lap stay flat as the travel grows?

The log is made from the Intel bag of the external data (``external-data/carmen/intel``: 500 m, 910
real scans, real wheel odometry): played forward, then backward (the robot driving the same path
back), then forward, then backward: ``--laps`` laps (default 4) of one continuous trajectory, written
as an MCAP with the bag's topics and schemas by navlog's writer (``tests/replay/mapping/lap_logs.py``).
With ``--forward`` every lap is forward (the tour repeated, as a patrolling robot drives it; the
reference's 1.2 m from the tour's end back to its start is one odometry step between the laps).
Driving back with a forward-facing 180-degree laser, each scan sees near ground the keyframes ahead
of it never saw: the backward laps are the harder log.
It is replayed in this process through the real path, ``--pipeline mapping --set pose_source=slam``
(``lidar_mapper=off``), as ``bench_slam_datasets.py`` replays the bags.

Time per lap: one replay of the whole log, its wall and CPU time read at every second of log time
(the replay's progress updates, taken by a stand-in for its progress bar) and cut at the laps'
boundaries; the final map and the outputs written after the last message are shown apart
(``finish``). ``--prefixes`` instead replays the first 1, 2, ... N laps as separate logs and takes
the differences of their total times (N (N + 1) / 2 laps of work).

Printed per lap: travel, keyframes and loop closures added in it, wall and CPU seconds, x real time;
then the last lap's time over the first's, the load average, and the ATE of the whole estimate (RMSE
of the positions after SE(2) alignment) against the Intel reference repeated the same way
(``intel.reference.tum`` at the scan stamps of every lap), with each lap's share of it.

    .venv/bin/python benchmarks/bench_slam_long.py [--laps N] [--forward] [--prefixes] [--shared DIR] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, ClassVar
from unittest import mock

import numpy as np

from navlog.analysis.metrics import align_planar
from navlog.replay import session
from navlog.replay.geometry import planar_matrix
from navlog.replay.io.formats import open_log
from navlog.replay.runtime.progress import Progress
from navlog.replay.session import run_replay

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests/ holds the log builder
from benchmarks.bench_slam_datasets import load
from tests.replay.mapping.lap_logs import LapTime, write_laps
from tests.replay.mapping.planar_logs import planar_tum
from tests.shared_data import default_shared_dir

SOURCE = "intel"


class _Clock(Progress):
    """The replay's progress bar, drawing nothing: (log s, wall s, CPU s) at every update."""

    marks: ClassVar[list[tuple[float, float, float]]] = []

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **{**kwargs, "enabled": False})
        _Clock.marks = [(0.0, time.perf_counter(), time.process_time())]

    def update(self, done: float, total: float | None = None) -> None:
        _Clock.marks.append((float(done), time.perf_counter(), time.process_time()))


def replay(log: Path, out: Path, sets: list[str]) -> tuple[float, float, list[tuple[float, float, float]]]:
    """Wall and CPU seconds of the replay of ``log`` into ``out``, and its progress marks."""
    start, cpu = time.perf_counter(), time.process_time()
    with mock.patch.object(session, "Progress", _Clock):
        run_replay(log, "mapping", out, overrides=["pose_source=slam", "lidar_mapper=off", *sets], progress=False)
    return time.perf_counter() - start, time.process_time() - cpu, list(_Clock.marks)


def lap_ends(times: list[LapTime], source_instants: list[int]) -> list[int]:
    """The log time (ns) of each lap's last instant."""
    return [when(when.instants(source_instants)[-1]) for when in times]


def per_lap_from_marks(
    marks: list[tuple[float, float, float]], ends_s: list[float], wall: float, cpu: float
) -> tuple[list[tuple[float, float]], tuple[float, float]]:
    """(wall, CPU) seconds of each lap, from the progress marks cut at the laps' ends (log s from the start),
    and of what came after the last mark (the final map and the outputs)."""
    log_s = np.array([m[0] for m in marks])
    out, prev = [], marks[0]
    for end in ends_s:
        i = min(int(np.searchsorted(log_s, end)), len(marks) - 1)  # first mark at or past the lap's end
        out.append((marks[i][1] - prev[1], marks[i][2] - prev[2]))
        prev = marks[i]
    t0_wall, t0_cpu = marks[0][1], marks[0][2]
    return out, (wall - (prev[1] - t0_wall), cpu - (prev[2] - t0_cpu))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--laps", type=int, default=4, help="laps of the Intel bag (forward, backward, ...)")
    ap.add_argument(
        "--forward",
        action="store_true",
        help="every lap forward (the tour repeated; the reference's 1.2 m from the end back to the start as one step)",
    )
    ap.add_argument("--prefixes", action="store_true", help="time the first 1..N laps as separate logs")
    ap.add_argument("--shared", type=Path, default=default_shared_dir(), help="the external data folder")
    ap.add_argument("--set", action="append", default=[], help="a parameter override, e.g. slam.do_loop_closing=false")
    ap.add_argument("--keep", type=Path, help="write the log and the replay's outputs into this (new) folder")
    args = ap.parse_args()
    if args.laps < 1:
        ap.error("--laps must be at least 1")
    carmen = args.shared / "external-data" / "carmen"
    print(f"machine: {os.cpu_count()} cores, load average {load()}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp) if args.keep is None else args.keep
        if args.keep is not None:
            work.mkdir(parents=True, exist_ok=False)  # a new folder: nothing of another run mixed in
        ref_t, ref = planar_tum(carmen / f"{SOURCE}.reference.tum")
        back = None
        if args.forward:
            back = np.linalg.inv(planar_matrix(*ref[-1])) @ planar_matrix(*ref[0])
        log, times = write_laps(carmen / SOURCE, work / "laps.mcap", args.laps, back)
        with open_log(log) as reader:
            start_ns = reader.start_ns
            scan_ns = [env.time_ns for env in reader.messages(["/scan"])]
        with open_log(carmen / SOURCE) as reader:
            source_instants = sorted({env.time_ns for env in reader.messages(["/scan", "/odom", "/tf"])})
        ends = lap_ends(times, source_instants)
        before = load()
        if args.prefixes:
            totals = []
            for n in range(1, args.laps + 1):
                prefix, _ = write_laps(carmen / SOURCE, work / f"laps{n}.mcap", n, back)
                wall, cpu, _ = replay(prefix, work / f"out{n}", args.set)
                totals.append((wall, cpu))
                print(f"  first {n} lap(s): {wall:.1f} s wall, {cpu:.1f} s CPU (load {load()})", flush=True)
            laps = [(w - pw, c - pc) for (w, c), (pw, pc) in zip(totals, [(0.0, 0.0), *totals[:-1]], strict=True)]
            finish = None
            out = work / f"out{args.laps}"
        else:
            out = work / "out"
            wall, cpu, marks = replay(log, out, args.set)
            laps, finish = per_lap_from_marks(marks, [(e - start_ns) / 1e9 for e in ends], wall, cpu)
        after = load()

        # the reference repeated the same way: each lap's scan stamps carry the source stamp's reference pose
        ref_at = dict(zip(ref_t.tolist(), ref.tolist(), strict=True))
        rt, rp = [], []
        for when in times:
            for t in when.instants(source_instants):
                if t in ref_at:
                    rt.append(when(t))
                    rp.append(ref_at[t])
        est_t, est = planar_tum(out / "trajectory.tum")
        where = {t: i for i, t in enumerate(est_t.tolist())}
        keep = [i for i, t in enumerate(rt) if t in where]
        ref_poses = np.array([rp[i] for i in keep])
        stamps = np.array([rt[i] for i in keep])
        aligned = align_planar(est[[where[int(t)] for t in stamps]], ref_poses)
        sq = np.sum((aligned[:, :2] - ref_poses[:, :2]) ** 2, axis=1)
        graph = json.loads((out / "pose_graph.json").read_text())
        key_stamps = np.array([n["stamp_ns"] for n in graph["nodes"]])
        loop_stamps = np.array([graph["nodes"][e["target"]]["stamp_ns"] for e in graph["edges"] if e["kind"] == "loop"])
        print(
            f"log: {args.laps} laps of {SOURCE}, {len(scan_ns)} scans, {(scan_ns[-1] - scan_ns[0]) / 1e9:.0f} s;"
            f" method: {'prefixes' if args.prefixes else 'one replay, cut at the laps'}"
        )
        print(
            f"{'lap':<4} {'travel m':>9} {'keyframes':>10} {'loops':>6} {'wall s':>8} {'CPU s':>8} {'x real':>8} {'ATE m':>7}"
        )
        lap_start = start_ns
        for k, (end, (w, c)) in enumerate(zip(ends, laps, strict=True)):
            inside = (stamps > lap_start) & (stamps <= end) if k else stamps <= end
            travel = float(np.sum(np.linalg.norm(np.diff(ref_poses[inside, :2], axis=0), axis=1)))
            keys = int(np.sum((key_stamps > lap_start) & (key_stamps <= end))) if k else int(np.sum(key_stamps <= end))
            loops = (
                int(np.sum((loop_stamps > lap_start) & (loop_stamps <= end))) if k else int(np.sum(loop_stamps <= end))
            )
            ate = float(np.sqrt(np.mean(sq[inside])))
            print(
                f"{k + 1:<4} {travel:>9.0f} {keys:>10} {loops:>6} {w:>8.1f} {c:>8.1f} {(end - lap_start) / 1e9 / w:>7.1f}x"
                f" {ate:>7.3f}"
            )
            lap_start = end
        if finish is not None:
            print(f"{'finish':<26} {finish[0]:>15.1f} {finish[1]:>8.1f}   (final map, trajectory, pose graph)")
        travel = float(np.sum(np.linalg.norm(np.diff(ref_poses[:, :2], axis=0), axis=1)))
        total_wall = sum(w for w, _ in laps) + (finish[0] if finish else 0.0)
        total_cpu = sum(c for _, c in laps) + (finish[1] if finish else 0.0)
        duration = (end - start_ns) / 1e9
        print(
            f"whole: {travel:.0f} m, {len(graph['nodes'])} keyframes, {len(loop_stamps)} loops"
            f" ({graph['counts']['loops_global']} of them in {graph['counts']['global_searches']} global searches),"
            f" {total_wall:.1f} s wall ({duration / total_wall:.1f}x real time), {total_cpu:.1f} s CPU"
            f" ({duration / total_cpu:.1f}x); ATE {float(np.sqrt(np.mean(sq))):.3f} m"
            f" ({len(stamps)}/{len(rt)} reference poses)"
        )
        print(
            f"last lap / first lap: wall {laps[-1][0] / laps[0][0]:.2f}, CPU {laps[-1][1] / laps[0][1]:.2f};"
            f" load {before} -> {after}"
        )


if __name__ == "__main__":
    main()
