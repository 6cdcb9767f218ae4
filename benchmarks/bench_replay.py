"""Replay speed and memory of the mapping pipeline (the issue's Speed and Memory targets), in one run.

Records its logs with `navlog record` in a work folder (a temporary one unless --workdir is given;
logs already there are reused):

- the mapping log: indoor_room + go2 + scenario mapping, seed 7 (138 s of sim time, ~230 MB);
- a 1-minute and a 10-minute log of scenario patrol (config/scenarios/patrol.yaml, the mapping loop
  driven six times; the 1-minute log is a copy of it with max_duration 60), seed 7. The 10-minute
  log is ~1 GB and takes a minute or two to record.

Then prints, each replay in a fresh child process:

(a) 2D mapping replay (`--set lidar_mapper=off`) of the mapping log: real-time factor = log seconds
    / wall seconds, best and median of --repeat runs, of the whole process (`navlog replay` as a user
    runs it: interpreter start, imports, reading, nodes, writing the outputs, exit; target >= 100x)
    and of the replay itself (what `navlog replay` prints: reading, nodes, writing; the pipeline's
    modules imported before it);
(b) 3D mapping replay (the full mapping pipeline) of the mapping log: real-time factor of the whole
    process and of the replay itself (--repeat-3d runs of each); target >= 6x as a whole process;
(c) peak resident memory (the replaying process's ru_maxrss; its largest child process beside it) of
    the full mapping pipeline replaying the 10-minute log and the 1-minute log, and their ratio;
    target: within 20 %. The resident size after the imports (before the log is opened) is printed
    too, so the replay's own growth is visible.

Each replay also reports its CPU time over the same span (all threads: the reader decompresses
chunks ahead in a second thread, so CPU may exceed wall on an idle machine): on a shared machine,
wall >> CPU means the replay waited for a core. Nothing is asserted; the script prints measured
numbers and ratios.

Where the time goes: after (a) and (b), one more replay of each runs instrumented (unless
--no-stages) and prints the CPU seconds of its replay span by stage on the main thread
(deserialization, the 2D mapper's pose lookups and map updates, the 3D mapper's plans, sweep
preparation, ICP source covariances, ICP, map updates; the rest is the executor, TF buffers and
outgoing messages), by thread for the others (decompression, the replay.mcap writer, the input hash,
the 3D global map; small_gicp's OpenMP threads, which share the scan covariances with the main
thread, are not Python threads: their CPU time counts in the process CPU only), and the child
processes' CPU (the 2D grid's scan updates). The timed runs complete the 3D frames in a child
process (everything after the plan); the instrumented one completes them in its own process, so
that each stage is seen. CPU time, not wall time: on a shared machine the figures stay comparable.

    .venv/bin/python benchmarks/bench_replay.py [--repeat 3] [--repeat-3d 1] [--workdir DIR] [--skip-3d]
        [--skip-memory] [--no-stages]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]


# the per-stage CPU time of one replay (``--stages``): each stage's functions wrapped with a timer of
# the calling thread's CPU time (time.thread_time: what a busy machine does to wall time does not
# count); the other threads' CPU time read when each ends (or at the end of the replay)
STAGES_CODE = r"""
import functools, sys, threading, time

MAIN_STAGES = [  # (stage, module, attribute path); inclusive times, summed per stage
    ("deserialization: CDR -> messages", "navlog.replay.io.mcap_reader", "McapLogReader._decode"),
    ("2D: scans placed (pose lookups + map updates)", "navlog.replay.nodes.occupancy_mapper", "OccupancyMapperNode._insert"),
    ("2D: scans placed (pose lookups + map updates)", "navlog.replay.nodes.occupancy_mapper", "OccupancyMapperNode._poses"),
    ("2D:   of which map updates (ray casting)", "navlog.replay.mapping.occupancy", "OccupancyGrid2D.insert_scan"),
    ("2D: /map messages", "navlog.replay.nodes.occupancy_mapper", "OccupancyMapperNode._publish"),
    ("3D: IMU and odometry tracks", "navlog.replay.mapping.lidar_odometry.deskew", "GyroTrack.add"),
    ("3D: IMU and odometry tracks", "navlog.replay.mapping.lidar_odometry.deskew", "PoseTrack.add"),
    ("3D: sweeps (all of a sweep's work)", "navlog.replay.nodes.lidar_mapper", "LidarMapperNode._process"),
    ("3D:   plan: checks, motions from the IMU/odometry", "navlog.replay.mapping.lidar_odometry.odometry", "LidarOdometry.plan"),
    ("3D:   sweep preparation (deskew, voxel filters)", "navlog.replay.mapping.lidar_odometry.odometry", "prepare_sweep"),
    ("3D:   ICP source: k-d tree + covariances", "navlog.replay.mapping.lidar_odometry.voxel_map", "GaussianRegistrar.source_of_reduced"),
    ("3D:     of which covariances (covariance_threads)", "small_gicp", "estimate_covariances"),
    ("3D:   ICP: small_gicp VGICP", "navlog.replay.mapping.lidar_odometry.voxel_map", "GaussianRegistrar.register"),
    ("3D:   map updates (voxel map, global map)", "navlog.replay.mapping.lidar_odometry.voxel_map", "GaussianLocalMap.update"),
    ("3D:   map updates (voxel map, global map)", "navlog.replay.mapping.lidar_odometry.local_map", "GlobalMap.add"),
    ("manifest (output hashes)", "navlog.replay.session", "_manifest"),
]
ARTIFACTS = "outputs: map, trajectory, PCD files"  # the pipeline's write_artifacts
THREADS = [  # thread name prefix -> what it does
    ("navlog-read", "decompression (reader thread)"),
    ("navlog-mcap-writer", "replay.mcap: serialization, compression, writing (writer thread)"),
    ("navlog-hash", "input log sha256 (hash thread)"),
    ("navlog-global-map", "3D: global map batches (background thread)"),
]


class STAGES:
    def __init__(self, on):
        self.cpu, self.calls, self.threads = {}, {}, {}
        self.main = threading.get_ident()
        self.c0 = time.thread_time()
        if not on:
            return
        import navlog.replay.pipelines.mapping as mapping

        build = mapping.build

        def timed_build(*a, **k):  # the nodes' modules are imported now: wrap the stages of those loaded
            pipe = build(*a, **k)
            for stage, module, path in MAIN_STAGES:
                owner = sys.modules.get(module)
                *parents, name = path.split(".")
                for part in parents:
                    owner = getattr(owner, part, None)
                if hasattr(owner, name):  # a function the code no longer has is left out
                    setattr(owner, name, self._timed(stage, getattr(owner, name)))
            pipe.write_artifacts = self._timed(ARTIFACTS, pipe.write_artifacts)
            return pipe

        mapping.build = timed_build
        import navlog.replay.nodes.lidar_mapper as lidar_mapper

        lidar_mapper.usable_cpus = lambda: 1  # 3D frames completed in this process: each stage is seen here
        run, stages = threading.Thread.run, self

        def counted_run(thread):  # each other thread's CPU time when it ends
            try:
                run(thread)
            finally:
                stages.threads[thread.name] = stages.threads.get(thread.name, 0.0) + time.thread_time()

        threading.Thread.run = counted_run

    def _timed(self, stage, fn):
        stages = self

        @functools.wraps(fn)
        def timed(*a, **k):
            if threading.get_ident() != stages.main:
                return fn(*a, **k)
            t = time.thread_time()
            try:
                return fn(*a, **k)
            finally:
                stages.cpu[stage] = stages.cpu.get(stage, 0.0) + time.thread_time() - t
                stages.calls[stage] = stages.calls.get(stage, 0) + 1

        return timed

    def figures(self):
        import resource

        main_total = time.thread_time() - self.c0
        kids = resource.getrusage(resource.RUSAGE_CHILDREN)  # the grid and sweep processes, ended by now
        other = {}
        for name, cpu in self.threads.items():
            label = next((what for prefix, what in THREADS if name.startswith(prefix)), "other threads")
            other[label] = other.get(label, 0.0) + cpu
        order = [*dict.fromkeys(s for s, _, _ in MAIN_STAGES), ARTIFACTS]
        main = [[s, self.cpu[s], self.calls[s]] for s in order if s in self.cpu]
        other["child processes: 2D grid updates"] = kids.ru_utime + kids.ru_stime
        return {"main_thread_cpu_s": main_total, "main": main, "threads": sorted(other.items())}
"""

# run in a child process: one replay, then its timing and memory figures as JSON on stdout
CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, sys.argv[1])

def rss_kib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0

import navlog.replay.session as runner
import navlog.replay.pipelines.mapping, navlog.replay.nodes.lidar_mapper, navlog.replay.nodes.occupancy_mapper  # noqa: F401 (imports first)

span = {}
run = runner._run
stages = STAGES(sys.argv[4] == "1")

def timed_run(*args, **kwargs):  # CPU time (all threads) over the span that run_replay's wall_s covers
    c0 = time.process_time()
    out = run(*args, **kwargs)
    span["cpu_s"] = time.process_time() - c0
    return out

runner._run = timed_run
base = rss_kib()
result = runner.run_replay(sys.argv[2], "mapping", sys.argv[3], overrides=sys.argv[5:], progress=False, force=True)
print(json.dumps({
    "wall_s": result.wall_s,
    "log_s": result.log_s,
    "cpu_s": span["cpu_s"],
    "peak_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
    "child_peak_kib": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss,  # the largest helper process
    "base_kib": base,
    "messages": result.manifest["log"]["messages_read"],
    "stages": stages.figures(),
}))
"""


def record(out: Path, scenario: str, log: Path) -> None:
    if out.exists():
        print(f"  reusing {out}", flush=True)
        return
    cmd = [
        sys.executable,
        "-m",
        "navlog",
        "record",
        "--world",
        "indoor_room",
        "--robot",
        "go2",
        "--scenario",
        scenario,
        "--seed",
        "7",
        "-o",
        str(out),
    ]
    print(f"  {' '.join(['navlog', *cmd[3:]])}", flush=True)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    with open(log, "w") as f:
        subprocess.run(cmd, cwd=ROOT, env=env, stdout=f, stderr=subprocess.STDOUT, check=True)


def replay(log: Path, out: Path, overrides: list[str], stages: bool = False) -> dict:
    proc = subprocess.run(
        [sys.executable, "-c", STAGES_CODE + CHILD, str(ROOT), str(log), str(out), "1" if stages else "0", *overrides],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        raise SystemExit(f"replay of {log} failed:\n{proc.stderr}")
    shutil.rmtree(out, ignore_errors=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def whole_process(log: Path, out: Path, overrides: list[str]) -> tuple[float, float]:
    """(wall s, CPU s) of one `navlog replay` process, from its start to its exit."""
    cmd = [sys.executable, "-m", "navlog", "-q", "replay", str(log), "--pipeline", "mapping", "-o", str(out), "--force"]
    for o in overrides:
        cmd += ["--set", o]
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"navlog replay of {log} failed:\n{proc.stderr}")
    shutil.rmtree(out, ignore_errors=True)
    return wall, r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime


def speed(
    label: str,
    log: Path,
    work: Path,
    overrides: list[str],
    repeat: int,
    target: float,
    process: bool = False,
    stages: bool = True,
) -> None:
    """Real-time factors of `repeat` replays: of the replay span, and with ``process`` of whole processes;
    with ``stages``, where the time goes in one more (instrumented) replay."""
    runs = [replay(log, work / "out", overrides) for _ in range(repeat)]
    log_s = runs[0]["log_s"]
    print(f"{label}: {log_s:.1f} s of log, {runs[0]['messages']} messages read, {repeat} run(s)")
    figures = [("replay", [r["wall_s"] for r in runs], [r["cpu_s"] for r in runs])]
    if process:  # alternated with nothing else: each is a fresh `navlog replay`
        procs = [whole_process(log, work / "out", overrides) for _ in range(repeat)]
        figures.insert(0, ("process", [w for w, _ in procs], [c for _, c in procs]))
    for what, walls, cpus in figures:
        best, median = log_s / min(walls), log_s / statistics.median(walls)
        print(
            f"  {what:7s} wall {min(walls):.2f} s best, {statistics.median(walls):.2f} s median -> "
            f"{best:.1f}x real time best, {median:.1f}x median (target >= {target:g}x: median/target {median / target:.2f})"
        )
        print(f"  {what:7s} CPU  {min(cpus):.2f} s best -> {log_s / min(cpus):.1f}x real time per CPU second")
    if stages:
        print_stages(replay(log, work / "out", overrides, stages=True)["stages"])


def print_stages(st: dict) -> None:
    """The CPU seconds of one replay by stage (main thread) and by thread (the others)."""
    main = st["main_thread_cpu_s"]
    print("  where the time goes (one more replay, instrumented; CPU s of the replay span, imports excluded):")
    print(f"    {'main thread':48s} {main:6.2f} s")
    top = 0.0
    for stage, cpu, calls in st["main"]:
        print(f"      {stage:46s} {cpu:6.2f} s  {100 * cpu / main:4.1f} %  ({calls} calls)")
        top += 0.0 if stage.startswith(("2D:  ", "3D:  ")) else cpu  # indented rows are parts of the row above
    print(
        f"      {'the rest: executor, TF buffers, messages out':46s} {main - top:6.2f} s  {100 * (main - top) / main:4.1f} %"
    )
    for what, cpu in st["threads"]:
        print(f"    {what:48s} {cpu:6.2f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs of the 2D replay")
    ap.add_argument("--repeat-3d", type=int, default=1, help="runs of the 3D replay (each also as a whole process)")
    ap.add_argument("--workdir", type=Path, help="keep the logs here (and reuse them); default: a temporary folder")
    ap.add_argument("--skip-3d", action="store_true", help="skip (b)")
    ap.add_argument("--skip-memory", action="store_true", help="skip (c) and the patrol recordings")
    ap.add_argument("--no-stages", action="store_true", help="skip the instrumented replays (where the time goes)")
    args = ap.parse_args()

    work = args.workdir or Path(tempfile.mkdtemp(prefix="navlog-bench-replay-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        print(f"{os.cpu_count()} CPUs, load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}; logs in {work}")
        print("recording:", flush=True)
        mapping = work / "mapping.mcap"
        record(mapping, "mapping", work / "record_mapping.txt")
        if not args.skip_memory:
            short_yaml = work / "patrol_60s.yaml"
            spec = yaml.safe_load((ROOT / "config" / "scenarios" / "patrol.yaml").read_text())
            spec["max_duration"] = 60.0
            short_yaml.write_text(yaml.safe_dump(spec, sort_keys=False))
            short, long = work / "patrol_1min.mcap", work / "patrol_10min.mcap"
            record(short, str(short_yaml), work / "record_patrol_1min.txt")
            record(long, "patrol", work / "record_patrol_10min.txt")
        print()

        speed(
            "(a) 2D mapping replay (--set lidar_mapper=off)",
            mapping,
            work,
            ["lidar_mapper=off"],
            args.repeat,
            100.0,
            process=True,
            stages=not args.no_stages,
        )
        if not args.skip_3d:
            speed(
                "(b) 3D mapping replay (full pipeline)",
                mapping,
                work,
                [],
                args.repeat_3d,
                6.0,
                process=True,
                stages=not args.no_stages,
            )
        if not args.skip_memory:
            print("(c) peak resident memory, full mapping pipeline")
            figures = {}
            for name, log in (("1-minute", short), ("10-minute", long)):
                r = replay(log, work / "out", [])
                figures[name] = r
                print(
                    f"  {name:9s} log ({r['log_s']:.0f} s, {log.stat().st_size / 2**20:.0f} MiB): peak {r['peak_kib'] / 1024:.0f} MiB "
                    f"(after imports {r['base_kib'] / 1024:.0f} MiB, replay's own growth {(r['peak_kib'] - r['base_kib']) / 1024:.0f} MiB); "
                    f"{r['log_s'] / r['wall_s']:.1f}x real time; its largest child process (2D grid, 3D sweeps) "
                    f"{r['child_peak_kib'] / 1024:.0f} MiB",
                    flush=True,
                )
            ratio = figures["10-minute"]["peak_kib"] / figures["1-minute"]["peak_kib"]
            kids = figures["10-minute"]["child_peak_kib"] / max(figures["1-minute"]["child_peak_kib"], 1)
            print(f"  10-minute / 1-minute peak: {ratio:.3f} (target <= 1.20); largest child process: {kids:.3f}")
    finally:
        if args.workdir is None:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
