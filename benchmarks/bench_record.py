"""Recording speed of `navlog record` against the simulation floor, start-up, and MCAP writing throughput.

The run is `navlog record --world indoor_room --robot go2 --scenario mapping --seed 7` (about 138 s
of sim time with the default sensor set: scan 10 Hz x 720 beams, 3D LiDAR 10 Hz x 16 x 720 rays,
IMU 200 Hz, odometry / TF / ground truth 50 Hz, clock 100 Hz). `--duration S` cuts the mapping
tour after S seconds of sim time for a quicker look. The recorder writes from a second thread and
casts the laser and the LiDAR in a worker process, so the recording may use both cores (`--pin`
pins the process to the idlest one: `record()` then keeps the sensors in its own process, as it does
on one CPU; `--in-process` keeps them there anyway). Prints, all measured in the same run:

1. start-up: process start to the first simulated step of `navlog record` (a fresh process per
   sample, stopped at its first step), median of `--runs`, against the 1.0 s target, and which heavy
   libraries are loaded by then (SciPy must not be: nothing in a recording needs it);
2. the record real-time factor (sim s / wall s), median of `--runs` recordings (each into a new
   file, the previous run's removed first), against the 20x target, with the CPU time of each thread (the simulation's and the writer's) and of the sensor
   worker process (its start-up included: it imports Open3D and builds the world mesh), and the
   simulation floor, alternated with them: the same tour (the recording's own /cmd_vel commands
   at their times) with physics, drive control and ray casting only — no sensor models, no
   messages, no serialization, no writing. Record wall / floor wall against the 2.0 target; the
   floor's final pose must equal the recording's (it is the same tour);
3. a per-stage breakdown from one extra, instrumented recording, with the sensors in the
   simulation's process so that every stage is timed (physics and drive control, ray
   casting, sensor models, message building, executor, serialization in the simulation's thread;
   compression and MCAP records + file writing in the writer thread); the wrappers add a little time;
4. the writing throughput against its ceiling: the messages of that recording written by the raw
   `mcap.writer.Writer` from pre-serialized CDR bytes (same topics, schemas, QoS metadata, chunk
   size and zstd), and by navlog's `McapLogWriter` from the published messages (objects or CDR
   bytes; serialize + write, in the caller's thread), alternated `--repeat` times, each into a new
   file where its previous one was just removed; the percentage is ceiling time / navlog time
   (target >= 70 %). Both files must hold the same messages (navlog's writer puts the LiDAR clouds
   in chunks of their own, so the bytes differ).

    .venv/bin/python benchmarks/bench_record.py [--duration 30] [--runs 5] [--repeat 5] [--pin]

Nothing is asserted: the numbers are measurements on a shared machine, so the load average is
printed with them; compare the ratios, measured in one run, rather than absolute times.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # no BLAS threads: the sim is serial
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import gc  # noqa: E402
import hashlib  # noqa: E402
import inspect  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import types  # noqa: E402
from collections import defaultdict  # noqa: E402
from pathlib import Path  # noqa: E402

import mcap.writer  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import open3d  # noqa: E402, F401  (imported up front, so that no run's CPU time includes the import)
from mcap.writer import CompressionType, Writer  # noqa: E402

import navlog.recorder.range_sensors as range_mod  # noqa: E402
import navlog.recorder.record as record_mod  # noqa: E402
import navlog.recorder.sim as sim_mod  # noqa: E402
from navlog.recorder import sensors  # noqa: E402
from navlog.recorder.record import prepare, record  # noqa: E402
from navlog.recorder.sim import TICK_NS, SimNode, SimOptions, mat_to_quat  # noqa: E402
from navlog.replay import messages  # noqa: E402
from navlog.replay.io import logwriter  # noqa: E402
from navlog.replay.io.logwriter import McapLogWriter  # noqa: E402
from navlog.version import __version__  # noqa: E402

TARGET_RTF = 20.0
TARGET_FLOOR = 2.0
TARGET_STARTUP_S = 1.0
TARGET_WRITE = 0.70
COMMAND = "navlog record --world indoor_room --robot go2 --scenario mapping --seed 7"


def idlest_cpu(sample_s: float = 0.5) -> int:
    """The CPU (of those this process may use) with the most idle time over a short sample."""

    def idle() -> dict[int, int]:
        out = {}
        with open("/proc/stat") as f:
            for line in f:
                if line.startswith("cpu") and line[3].isdigit():
                    parts = line.split()
                    out[int(parts[0][3:])] = int(parts[4]) + int(parts[5])
        return out

    allowed = os.sched_getaffinity(0)
    a = idle()
    time.sleep(sample_s)
    b = idle()
    return max(sorted(allowed), key=lambda c: b.get(c, 0) - a.get(c, 0))


def load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def setup_for(seed: int, duration: float | None):
    setup = prepare("indoor_room", "go2", "mapping", seed=seed)
    if duration is not None:
        setup.scenario = dataclasses.replace(setup.scenario, max_duration=float(duration))
    return setup


# ---------------------------------------------------------------- 1. start-up

# run in a fresh process: `navlog record` as the command line runs it, stopped at the first executor
# run (whose first event is the simulator's first tick), printing the wall-clock time then
_STARTUP_CHILD = """
import os, sys, time
import navlog.replay.runtime.executor as executor_mod
def first_step(self, *a, **k):
    os.write(1, f"FIRST_STEP {time.time()!r}\\n".encode())
    heavy = [m for m in ("scipy", "open3d", "mujoco", "rosbags") if m in sys.modules]
    os.write(1, f"LOADED {','.join(heavy)}\\n".encode())
    os._exit(0)
executor_mod.Executor.run = first_step
from navlog.cli import main
sys.exit(main(sys.argv[1:]))
"""


def startup_runs(args, work: Path) -> tuple[list[float], list[float], str]:
    """(wall s, CPU s, heavy libraries loaded) from process start to the first simulated step of `navlog record`,
    a fresh process each."""
    argv = ["-q", *COMMAND.split()[1:], "-o", str(work / "startup.mcap"), "--force"]
    walls, cpus, loaded = [], [], ""
    for _ in range(args.runs):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.time()
        done = subprocess.run([sys.executable, "-c", _STARTUP_CHILD, *argv], capture_output=True, text=True)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        marks = [line for line in done.stdout.splitlines() if line.startswith("FIRST_STEP ")]
        if not marks:
            raise SystemExit(f"start-up probe failed: {done.stderr.strip()[-500:]}")
        walls.append(float(marks[-1].split()[1]) - t0)
        cpus.append(r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime)
        loaded = next((line.split(" ", 1)[1] for line in done.stdout.splitlines() if line.startswith("LOADED ")), "")
    return walls, cpus, loaded


# ---------------------------------------------------------------- 2. real-time factor and the floor


class _ThreadTimes:
    """CPU time of the writer thread of each recording (measured in the thread as it ends)."""

    def __init__(self) -> None:
        self.writer: list[float] = []
        self._real_drain = McapLogWriter._drain

    def __enter__(self) -> _ThreadTimes:
        times, real = self.writer, self._real_drain

        def drain(writer) -> None:
            try:
                real(writer)
            finally:
                times.append(time.thread_time())

        McapLogWriter._drain = drain  # type: ignore[method-assign]
        return self

    def __exit__(self, *exc) -> None:
        McapLogWriter._drain = self._real_drain  # type: ignore[method-assign]


def _removed(path: Path) -> Path:
    """``path``, with whatever was there removed."""
    path.unlink(missing_ok=True)
    return path


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def commands_of(path: Path) -> list[tuple[int, tuple[float, float, float]]]:
    """The /cmd_vel commands of a recording: (time ns, (vx, vy, wz))."""
    from navlog.replay.io import open_log

    with open_log(path) as reader:
        return [(env.time_ns, messages.twist_values(env.msg)) for env in reader.messages(["/cmd_vel"])]


def final_pose(path: Path) -> tuple[float, ...]:
    from navlog.replay.io import open_log

    with open_log(path) as reader:
        last = None
        for env in reader.messages(["/odom/ground_truth"]):
            last = env.msg
    assert last is not None
    p = last.pose.pose
    return (
        p.position.x,
        p.position.y,
        p.position.z,
        p.orientation.x,
        p.orientation.y,
        p.orientation.z,
        p.orientation.w,
    )


def floor_run(setup, commands, end_ns: int) -> tuple[float, tuple[float, ...]]:
    """The tour with physics, drive control and ray casting only; (wall s, final base pose).

    The recording's commands are applied at the ticks the simulator applied them (a command published
    at t reaches the simulator after its tick at t), so the trajectory is the recording's; the rays are
    the scan's and the LiDAR's, cast from the sensor poses of the tick (one pose per sweep).
    """
    robot = setup.robot
    sim = SimNode(setup.world, robot, SimOptions(seed=setup.seed, noise=setup.noise, start=setup.scenario.start))
    caster, model, data = sim.caster, sim.model, sim.data
    periods = sim._periods
    scan, lidar = robot.scan, robot.lidar
    scan_dirs = sensors.laser_directions(scan)[0] if scan else None
    lidar_dirs = sensors.lidar_pattern(lidar, 0)[0] if lidar else None
    rays = np.empty((len(lidar_dirs) if lidar_dirs is not None else 0, 6), dtype=np.float32)
    pending = list(reversed(commands))
    step, kinematics = mujoco.mj_step, mujoco.mj_kinematics
    t0 = time.perf_counter()
    for t in range(0, end_ns + 1, TICK_NS):
        if t > 0:
            sim._drive(t)
            for _ in range(sim.substeps):
                step(model, data)
            kinematics(model, data)
        base = sim.base_pose()
        if scan_dirs is not None and t % periods["scan"] == 0:
            pose = base @ sim._mounts[scan.frame]
            world = scan_dirs @ pose[:3, :3].T
            caster.cast_distances(np.broadcast_to(pose[:3, 3], world.shape), world)
        if lidar_dirs is not None and t > 0 and t % periods["lidar"] == 0:
            pose = base @ sim._mounts[lidar.frame]
            rays[:, :3] = pose[:3, 3]
            rays[:, 3:] = lidar_dirs @ pose[:3, :3].T
            caster.cast_rays(rays)
        while pending and pending[-1][0] <= t:
            t_cmd, sim._cmd = pending.pop()
            sim._cmd_ns = t_cmd
    wall = time.perf_counter() - t0
    return wall, (*sim.data.xpos[sim._bid].tolist(), *mat_to_quat(sim.data.xmat[sim._bid]))


def clean_runs(args, work: Path) -> dict:
    """Recordings as `navlog record` makes them, alternated with floor runs of the same tour."""
    out: dict = defaultdict(list)
    digests = set()
    floor_same = True
    for i in range(args.runs):
        setup = setup_for(args.seed, args.duration)
        # a new file, as `navlog record -o NEW.mcap` writes: renaming a recording over the previous run's
        # frees that file's 235 MB in the rename (~45 ms), which is not the recorder's work
        path = _removed(work / "run.mcap")
        with _ThreadTimes() as threads:
            c0, m0, w0 = time.process_time(), time.thread_time(), _children_cpu()
            res = record(setup, path, force=True, progress=False, sensor_worker=False if args.in_process else None)
            main_cpu, cpu = time.thread_time() - m0, time.process_time() - c0
            worker_cpu = _children_cpu() - w0  # the sensor worker process, waited for when the run ends
        writer_cpu = threads.writer[-1] if threads.writer else 0.0
        digests.add(hashlib.sha256(path.read_bytes()).hexdigest())
        floor_wall, pose = floor_run(
            setup_for(args.seed, args.duration), commands_of(path), int(round(res.sim_s * 1e9))
        )
        floor_same &= np.allclose(pose, final_pose(path), rtol=0, atol=1e-12)
        for key, v in (
            ("rtf", res.real_time_factor),
            ("wall", res.wall_s),
            ("cpu", cpu),
            ("main_cpu", main_cpu),
            ("writer_cpu", writer_cpu),
            ("worker_cpu", worker_cpu),
            ("floor", floor_wall),
            ("floor_ratio", res.wall_s / floor_wall),
        ):
            out[key].append(v)
        print(
            f"  run {i + 1}: sim {res.sim_s:.2f} s, wall {res.wall_s:.2f} s, {res.real_time_factor:.1f}x real time; "
            f"CPU {cpu + worker_cpu:.2f} s (simulation thread {main_cpu:.2f} s, writer thread {writer_cpu:.2f} s, "
            f"sensor worker process {worker_cpu:.2f} s); "
            f"floor {floor_wall:.2f} s ({res.sim_s / floor_wall:.1f}x), record / floor {res.wall_s / floor_wall:.2f}; "
            f"{res.size_bytes / 1e6:.1f} MB ({load()})",
            flush=True,
        )
    out["same"] = "byte-identical" if len(digests) == 1 else f"{len(digests)} DIFFERENT files"
    out["floor_same"] = floor_same
    out["digest"] = sorted(digests)
    return out


# ---------------------------------------------------------------- 2. instrumented run


class Timers:
    def __init__(self) -> None:
        self.s: dict[str, float] = defaultdict(float)
        self.n: dict[str, int] = defaultdict(int)

    def wrap(self, key: str, fn):
        s, n, clock = self.s, self.n, time.perf_counter

        def timed(*a, **k):
            t0 = clock()
            try:
                return fn(*a, **k)
            finally:
                s[key] += clock() - t0
                n[key] += 1

        return timed


def instrumented_run(args, work: Path):
    """One recording with timers around each stage; returns (timers, result, envelopes, raw bytes, writer setup)."""
    tm = Timers()
    captured: list = []  # (envelope, serialized bytes)
    writer_args: dict = {}

    # physics: MuJoCo steps seen through a module proxy in recorder.sim only
    real_mujoco = sim_mod.mujoco
    proxy = types.SimpleNamespace(**{k: getattr(real_mujoco, k) for k in dir(real_mujoco) if not k.startswith("__")})
    proxy.mj_step = tm.wrap("physics", real_mujoco.mj_step)
    proxy.mj_kinematics = tm.wrap("physics", real_mujoco.mj_kinematics)
    # sensor models (their ray casting is timed separately and subtracted), as the laser and LiDAR call them
    real_sensors = range_mod.sensors
    sproxy = types.SimpleNamespace(**{k: getattr(real_sensors, k) for k in dir(real_sensors) if not k.startswith("__")})
    sproxy.laser_ranges = tm.wrap("sensor models", real_sensors.laser_ranges)
    sproxy.lidar_returns = tm.wrap("sensor models", real_sensors.lidar_returns)

    real_sim_init = sim_mod.SimNode.__init__

    def sim_init(self, *a, **k):
        real_sim_init(self, *a, **k)
        self._drive = tm.wrap("drive control", self._drive)
        self._tick = tm.wrap("sim tick", self._tick)
        for name in ("cast", "cast_distances", "cast_rays"):
            if hasattr(self.caster, name):
                setattr(self.caster, name, tm.wrap("ray casting", getattr(self.caster, name)))

    class TimedWriter(McapLogWriter):
        def __init__(self, *a, **k):
            super().__init__(*a, **k)
            writer_args.update(metadata=k.get("metadata"))
            self._last = None

        def write(self, env):
            t0 = time.perf_counter()
            super().write(env)
            tm.s["writer"] += time.perf_counter() - t0
            captured.append((env, self._last))
            if len(captured) % 2000 == 0:
                # the kept messages leave the collector's view, so that full collections cost what
                # they cost in a clean run (which keeps nothing)
                gc.freeze()

        def write_raw(self, topic, typename, time_ns, data):
            self._last = data
            super().write_raw(topic, typename, time_ns, data)

        def _put(self, *a):  # in the writer thread: MCAP records, compression (timed inside) and writing
            t0 = time.perf_counter()
            super()._put(*a)
            tm.s["put"] += time.perf_counter() - t0

        def close(self):  # waiting for the writer thread, the last chunk, the summary and the fsync
            t0 = time.perf_counter()
            try:
                return super().close()
            finally:
                tm.s["close"] += time.perf_counter() - t0

    real_zstd = mcap.writer.zstandard
    zproxy = types.SimpleNamespace(compress=tm.wrap("compression", real_zstd.compress))
    real_scenario_timer = record_mod.ScenarioNode._on_timer

    saved = (sim_mod.mujoco, range_mod.sensors, record_mod.McapLogWriter, mcap.writer.zstandard)
    sim_mod.mujoco, range_mod.sensors, record_mod.McapLogWriter, mcap.writer.zstandard = (
        proxy,
        sproxy,
        TimedWriter,
        zproxy,
    )
    sim_mod.SimNode.__init__ = sim_init
    record_mod.ScenarioNode._on_timer = tm.wrap("scenario node", real_scenario_timer)
    try:
        # in one process, so that every stage is timed (a worker process would hide the sensors' stages)
        res = record(
            setup_for(args.seed, args.duration),
            work / "instrumented.mcap",
            force=True,
            progress=False,
            sensor_worker=False,
        )
    finally:
        sim_mod.mujoco, range_mod.sensors, record_mod.McapLogWriter, mcap.writer.zstandard = saved
        sim_mod.SimNode.__init__ = real_sim_init
        record_mod.ScenarioNode._on_timer = real_scenario_timer
    return tm, res, captured, writer_args


def print_breakdown(tm: Timers, res) -> None:
    s = tm.s
    physics = s["physics"] + s["drive control"]
    cast = s["ray casting"]
    models = s["sensor models"] - cast
    building = s["sim tick"] - physics - s["sensor models"] + s["scenario node"]
    executor = res.wall_s - s["sim tick"] - s["scenario node"] - s["writer"] - s["close"]
    rows = [
        ("physics (mj_step, kinematics) + drive control", physics, f"{s['physics']:.2f} + {s['drive control']:.2f} s"),
        ("ray casting (Open3D, incl. array conversion)", cast, f"{tm.n['ray casting']} casts"),
        ("sensor models (patterns, poses, noise, points)", models, ""),
        ("message building (publishers incl. direct CDR)", building, ""),
        ("executor (queue, delivery) and the rest", executor, ""),
        ("serialization of objects + hand-off to writer", s["writer"], ""),
        ("close: writer catch-up, last chunk, fsync", s["close"], ""),
    ]
    print(
        f"per-stage breakdown, instrumented run: wall {res.wall_s:.2f} s for {res.sim_s:.2f} s of sim time "
        f"({res.real_time_factor:.1f}x; timers included)"
    )
    print("  simulation thread:")
    for name, sec, note in rows:
        print(f"    {name:<48} {sec:6.2f} s  {100 * sec / res.wall_s:5.1f} %  {note}")
    print("  writer thread (beside it):")
    for name, sec, note in (
        ("compression (zstd)", s["compression"], f"{tm.n['compression']} chunks"),
        ("MCAP records + file writing", s["put"] - s["compression"], "compression of the last chunk included"),
    ):
        print(f"    {name:<48} {sec:6.2f} s  {100 * sec / res.wall_s:5.1f} %  {note}")


# ---------------------------------------------------------------- 3. writing throughput


def chunk_size_default() -> int:
    return int(inspect.signature(McapLogWriter).parameters["chunk_size"].default)


def write_ceiling(path: Path, prepared, metadata) -> float:
    """The raw mcap Writer given pre-serialized messages, laid out as McapLogWriter lays them out."""
    t0 = time.perf_counter()
    with open(path, "wb") as f, logwriter._compressing_at(logwriter.ZSTD_LEVEL):  # navlog's zstd level
        w = Writer(f, compression=CompressionType.ZSTD, chunk_size=chunk_size_default())
        w.start(profile="ros2", library=f"navlog {__version__}")
        schemas: dict[str, int] = {}
        channels: dict[str, int] = {}
        add = w.add_message
        for seq, (topic, typename, t, data) in enumerate(prepared):
            cid = channels.get(topic)
            if cid is None:
                sid = schemas.get(typename)
                if sid is None:
                    sid = schemas[typename] = w.register_schema(typename, "ros2msg", messages.msgdef(typename).encode())
                cid = channels[topic] = w.register_channel(
                    topic, "cdr", sid, metadata={"offered_qos_profiles": messages.qos_for(topic)}
                )
            add(cid, log_time=t, publish_time=t, data=data, sequence=seq)
        for name in sorted(metadata):
            w.add_metadata(name, {k: str(v) for k, v in metadata[name].items()})
        w.finish()
        f.flush()
        os.fsync(f.fileno())
    return time.perf_counter() - t0


def write_navlog(path: Path, envelopes, metadata) -> float:
    t0 = time.perf_counter()
    with McapLogWriter(path, force=True, metadata=metadata) as w:
        for env in envelopes:
            w.write(env)
    return time.perf_counter() - t0


def writing_throughput(args, work: Path, captured, metadata) -> None:
    envelopes = [env for env, _ in captured]
    objects = [env for env in envelopes if not isinstance(env.msg, (bytes, bytearray))]  # not sent as CDR
    prepared = [(env.topic, env.typename, env.time_ns, bytes(data)) for env, data in captured]
    raw_bytes = sum(len(d) for *_, d in prepared)
    ceiling, navlog, ser = [], [], []
    for i in range(args.repeat):  # alternate which writer goes first
        # each writes a new file where its last one was removed: McapLogWriter writes beside the file it
        # replaces and "wb" truncates it first, and a 235 MB file put in memory not freed just before costs
        # ~0.1 s more of system time (page cache pages a virtual machine has not touched lately)
        if i % 2 == 0:
            ceiling.append(write_ceiling(_removed(work / "ceiling.mcap"), prepared, metadata))
        navlog.append(write_navlog(_removed(work / "navlog.mcap"), envelopes, metadata))
        if i % 2 == 1:
            ceiling.append(write_ceiling(_removed(work / "ceiling.mcap"), prepared, metadata))
        t0 = time.perf_counter()
        for env in objects:
            messages.serialize(env.msg, env.typename)
        ser.append(time.perf_counter() - t0)
    c, n = statistics.median(ceiling), statistics.median(navlog)
    same = _messages(work / "ceiling.mcap") == _messages(work / "navlog.mcap")
    size = (work / "navlog.mcap").stat().st_size
    print(
        f"writing throughput, {len(prepared)} messages, {raw_bytes / 1e6:.1f} MB of CDR -> {size / 1e6:.1f} MB "
        f"(chunks {chunk_size_default() >> 20} MiB, zstd), median of {args.repeat}:"
    )
    print(
        f"  ceiling: raw mcap Writer, pre-serialized   {c:6.2f} s  {len(prepared) / c / 1e3:6.1f} k msg/s  {raw_bytes / c / 1e6:6.1f} MB/s"
    )
    print(
        f"  navlog: McapLogWriter, serialize + write   {n:6.2f} s  {len(prepared) / n / 1e3:6.1f} k msg/s  {raw_bytes / n / 1e6:6.1f} MB/s"
    )
    print(
        f"  serialization alone (messages.serialize of the {len(objects)} messages published as objects): "
        f"{statistics.median(ser):.2f} s"
    )
    cb, nb = min(ceiling), min(navlog)
    print(
        f"  navlog / ceiling throughput: {100 * c / n:.1f} % (target >= {100 * TARGET_WRITE:.0f} %: "
        f"ratio {c / n / TARGET_WRITE:.2f}); best against best {100 * cb / nb:.1f} %; "
        f"same messages in both files: {'yes' if same else 'NO'}"
    )


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, CDR bytes) of every message, in log-time order (ties by topic)."""
    from navlog.replay.io import open_log

    with open_log(path) as reader:
        return sorted((e.topic, e.time_ns, bytes(e.msg)) for e in reader.messages(decode=False))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--duration", type=float, help="cut the mapping tour after this many sim seconds (default: the whole tour)"
    )
    ap.add_argument("--runs", type=int, default=5, help="clean recordings for the real-time factor (median)")
    ap.add_argument("--repeat", type=int, default=5, help="alternations of the two writers (median)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--pin", action="store_true", help="pin the process to the idlest CPU (one core for both threads)")
    ap.add_argument("--keep", type=Path, help="keep the outputs in this folder")
    ap.add_argument(
        "--in-process", action="store_true", help="recordings with the laser and LiDAR in the simulation's process"
    )
    args = ap.parse_args()
    if args.pin:
        cpu = idlest_cpu()
        os.sched_setaffinity(0, {cpu})
        print(f"pinned to CPU {cpu} of {os.cpu_count()}")
    work = Path(tempfile.mkdtemp(prefix="navlog-bench-record-")) if args.keep is None else args.keep
    work.mkdir(parents=True, exist_ok=True)
    cmd = COMMAND if args.duration is None else f"{COMMAND} (tour cut at {args.duration:g} s)"
    try:
        print(f"start-up of `{COMMAND}` to its first simulated step, {args.runs} processes ({load()})", flush=True)
        starts, start_cpus, loaded = startup_runs(args, work)
        su = statistics.median(starts)
        print(
            f"start-up: median {su:.2f} s, best {min(starts):.2f} s (CPU time median {statistics.median(start_cpus):.2f} s); "
            f"target {TARGET_STARTUP_S:.1f} s: ratio {su / TARGET_STARTUP_S:.2f}; loaded at the first step: "
            f"{loaded.replace(',', ', ') or 'none of scipy, open3d, mujoco, rosbags'}"
        )
        where = "the laser and LiDAR in the simulation's process" if args.in_process else "as `navlog record` does"
        print(f"recording: {cmd} ({where}), {args.runs} runs, each followed by a floor run ({load()})", flush=True)
        r = clean_runs(args, work)
        rtf, ratio = statistics.median(r["rtf"]), statistics.median(r["floor_ratio"])
        med = statistics.median
        print(
            f"real-time factor: median {rtf:.1f}x, best {max(r['rtf']):.1f}x (wall median {med(r['wall']):.2f} s); "
            f"target {TARGET_RTF:.0f}x: ratio {rtf / TARGET_RTF:.2f} (best {max(r['rtf']) / TARGET_RTF:.2f}); runs {r['same']}"
        )
        print(
            f"floor (physics, drive control, ray casting): median {med(r['floor']):.2f} s; record wall / floor: "
            f"median {ratio:.2f}, best {min(r['floor_ratio']):.2f} (target <= {TARGET_FLOOR:.1f}); "
            f"floor follows the recorded trajectory: {'yes' if r['floor_same'] else 'NO'}"
        )
        print(
            f"CPU time per recording (median): simulation thread {med(r['main_cpu']):.2f} s, writer thread "
            f"{med(r['writer_cpu']):.2f} s, process {med(r['cpu']):.2f} s; sensor worker process "
            f"{med(r['worker_cpu']):.2f} s (its start-up included) (wall {med(r['wall']):.2f} s)"
        )
        print(f"sha256 {r['digest'][0]}")
        tm, res, captured, writer_args = instrumented_run(args, work)
        print_breakdown(tm, res)
        gc.freeze()
        writing_throughput(args, work, captured, writer_args.get("metadata") or {})
        del captured
        gc.unfreeze()
        print(f"done ({load()})")
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
