"""Safety filters' timings: the velocity smoother (and the collision monitor) against Nav2's control period.

Run: .venv/bin/python benchmarks/bench_safety.py [--workdir DIR]
Velocity smoother: KiBot's limits (20 Hz, OPEN_LOOP, scale_velocities on); one tick of the pure algorithm, and
a replay on the executor of 10 minutes of controller commands at 20 Hz (a sine on vx and wz) through the node.
The ceiling is Nav2's smoothing period, 50 ms per tick; the ratio is that period over the measured cost, and
the replay's real-time factor is sim time over wall time. Process CPU time is printed beside the wall clock
(the machine may be shared).
Safety replay: the safety pipeline (KiBot's parameters) over the commands of the 138 s mapping log (go2 in
indoor_room, seed 7, recorded into --workdir or a temporary folder, reused when there), read as /cmd_vel_nav
with --remap /cmd_vel_nav=/cmd_vel; real-time factor = log seconds / replay wall seconds (the replay's span,
``ReplayResult.wall_s``), target 200x; the whole call's time (set-up, the input's digest, the manifest) beside it.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from navlog.replay import messages as m
from navlog.replay.nav2.velocity_smoother import VelocitySmoother, VelocitySmootherParams
from navlog.replay.nodes import VelocitySmootherNode
from navlog.replay.runtime.executor import Envelope, Executor

KIBOT_SMOOTHER = VelocitySmootherParams(
    scale_velocities=True,
    max_velocity=(0.45, 0.0, 1.2),
    min_velocity=(-0.20, 0.0, -1.2),
    max_accel=(0.8, 0.0, 1.5),
    max_decel=(-0.8, 0.0, -1.5),
)
PERIOD_NS = 50_000_000


def bench_velocity_smoother() -> None:
    smoother = VelocitySmoother(KIBOT_SMOOTHER)
    n = 20_000
    t, c = time.perf_counter(), time.process_time()
    for k in range(n):
        now = k * PERIOD_NS
        smoother.set_command((0.45 * math.sin(k / 40), 0.0, 1.2 * math.cos(k / 25)), now)
        smoother.tick(now)
    tick_us = (time.perf_counter() - t) / n * 1e6
    tick_cpu_us = (time.process_time() - c) / n * 1e6
    print(
        f"velocity smoother tick: {tick_us:.1f} us (cpu {tick_cpu_us:.1f} us); "
        f"ceiling 50 ms -> ratio {50_000 / tick_us:.0f}x"
    )

    seconds = 600
    envs = [
        Envelope("/cmd_vel_nav", m.TWIST, k * PERIOD_NS, m.twist(0.45 * math.sin(k / 40), 0.0, 1.2 * math.cos(k / 25)))
        for k in range(seconds * 20)
    ]
    walls, cpus = [], []
    for _ in range(3):
        ex = Executor()
        ex.add_source(envs)
        node = VelocitySmootherNode(KIBOT_SMOOTHER)
        ex.add_node(node)
        t, c = time.perf_counter(), time.process_time()
        ex.run()
        walls.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    wall, cpu = statistics.median(walls), statistics.median(cpus)
    print(
        f"velocity smoother replay: {seconds} s of 20 Hz commands, {node.published} outputs in {wall:.2f} s "
        f"(cpu {cpu:.2f} s): real-time factor {seconds / wall:.0f}x"
    )


THREE_POLYGONS = """collision_monitor:
  ros__parameters:
    polygons: [Stop, SlowDown, FootprintApproach]
    observation_sources: [scan]
    scan: {type: scan, topic: scan}
    Stop: {type: polygon, points: "[[0.4, 0.3], [0.4, -0.3], [-0.4, -0.3], [-0.4, 0.3]]", action_type: stop}
    SlowDown: {type: polygon, points: "[[0.8, 0.5], [0.8, -0.5], [-0.6, -0.5], [-0.6, 0.5]]", action_type: slowdown}
    FootprintApproach: {type: polygon, action_type: approach, time_before_collision: 1.2}
"""


def bench_collision_monitor() -> None:
    """One decision of the collision monitor per command: a 720-beam Go2 scan (0.12-6.0 m) of a corridor
    1.2 m wide with a wall 1.0 m ahead, three polygons (stop, slowdown, and KiBot's FootprintApproach: radius 0.34 + 0.01
    padding, 1.2 s ahead in 0.1 s steps), command 0.3 m/s; the ceiling is Nav2's 1 ms target per command."""
    from navlog.replay.nav2 import parse_nav2_text
    from navlog.replay.nav2.collision_monitor import CollisionMonitor, Velocity, scan_points
    from navlog.replay.nav2.costmap import pad_footprint, radius_footprint

    params = parse_nav2_text(THREE_POLYGONS).collision_monitor
    assert params is not None
    monitor = CollisionMonitor(params, pad_footprint(radius_footprint(0.34), 0.01))
    angles = -math.pi + np.arange(720) * (2 * math.pi / 720)
    with np.errstate(divide="ignore"):
        ahead = np.where(np.cos(angles) > 0, 1.0 / np.cos(angles), np.inf)
        sides = 0.6 / np.abs(np.sin(angles))
    ranges = np.minimum(ahead, sides)
    cmd = Velocity(0.3, 0.0, 0.2)

    def decide(k: int) -> None:
        pts = scan_points(ranges, -math.pi, 2 * math.pi / 720, 0.12, 6.0)[:, :2]
        monitor.process(cmd, k * PERIOD_NS, {"scan": pts})

    times = []
    for k in range(2000):
        t = time.perf_counter()
        decide(k)
        times.append((time.perf_counter() - t) * 1e3)
    median, best = statistics.median(times), min(times)
    print(
        f"collision monitor decision (720 beams, 3 polygons): median {median:.3f} ms, best {best:.3f} ms; "
        f"target 1 ms -> ratio {1.0 / median:.1f}x (best {1.0 / best:.1f}x)"
    )


def bench_safety_replay(workdir: Path | None, repeat: int = 5) -> None:
    """The safety replay of the mapping log's commands (see the module docstring)."""
    from navlog.recorder.record import prepare, record
    from navlog.replay.session import run_replay

    work = workdir or Path(tempfile.mkdtemp(prefix="navlog-bench-safety-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        log = work / "mapping.mcap"
        if not log.exists():
            print(f"recording {log} (indoor_room, go2, mapping, seed 7) ...", flush=True)
            record(prepare("indoor_room", "go2", "mapping", seed=7), log, progress=False)
        walls, cpus, threads, calls = [], [], [], []
        for _ in range(repeat):
            c, th, t = time.process_time(), time.thread_time(), time.perf_counter()
            res = run_replay(
                log, "safety", work / "out", remap={"/cmd_vel_nav": "/cmd_vel"}, force=True, progress=False
            )
            calls.append(time.perf_counter() - t)
            walls.append(res.wall_s)
            cpus.append(time.process_time() - c)
            threads.append(time.thread_time() - th)
        summary = json.loads((res.out_dir / "safety.json").read_text())
        best, median = res.log_s / min(walls), res.log_s / statistics.median(walls)
        print(
            f"safety replay of the mapping log's commands: {res.log_s:.1f} s of log, {summary['commands_in']} commands, "
            f"{res.manifest['log']['messages_read']} messages read; wall {min(walls):.2f} s best "
            f"(cpu {min(cpus):.2f} s, the whole call): {best:.0f}x real time best, {median:.0f}x median "
            f"of {repeat}; target 200x -> median/target {median / 200:.2f}"
        )
        print(
            f"  the replay's thread: {statistics.median(threads):.2f} s CPU median, {min(threads):.2f} s best "
            f"(wall beyond it is waiting for a core: load average now {os.getloadavg()[0]:.2f})"
        )
        print(
            f"  the whole call (set-up, the input's digest, manifest): {statistics.median(calls):.2f} s median, "
            f"{min(calls):.2f} s best -> {res.log_s / statistics.median(calls):.0f}x median"
        )
    finally:
        if workdir is None:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--workdir", type=Path, help="keep the mapping log here (and reuse it); default: a temporary folder"
    )
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}")
    bench_velocity_smoother()
    bench_collision_monitor()
    bench_safety_replay(args.workdir)
