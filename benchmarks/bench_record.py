"""Recording speed of `navlog record` and MCAP writing throughput, against their targets.

The run is `navlog record --world indoor_room --robot go2 --scenario mapping --seed 7` (about 138 s
of sim time with the default sensor set: scan 10 Hz x 720 beams, 3D LiDAR 10 Hz x 16 x 720 rays,
IMU 200 Hz, odometry / TF / ground truth 50 Hz, clock 100 Hz). `--duration S` cuts the mapping
tour after S seconds of sim time for a quicker look. The process is pinned to one CPU (the idlest
one) unless `--no-pin`, since the target is stated for one core. Prints:

1. the record real-time factor (sim s / wall s), median of `--runs` recordings, against the 20x
   target;
2. a per-stage breakdown from one extra, instrumented recording (physics and drive control, ray
   casting, sensor models, message building, executor, serialization, compression, MCAP records
   and file writing); the wrappers add a little time, so its total is a bit above the clean runs;
3. the writing throughput against its ceiling: the messages of that recording written by the raw
   `mcap.writer.Writer` from pre-serialized CDR bytes (same topics, schemas, QoS metadata, chunk
   size and zstd), and by navlog's `McapLogWriter` from message objects (serialize + write),
   alternated `--repeat` times; the percentage is ceiling time / navlog time (target >= 70 %).
   Both files must come out byte-identical; the script says whether they do.

    .venv/bin/python benchmarks/bench_record.py [--duration 30] [--runs 5] [--repeat 5] [--no-pin]

Nothing is asserted: the numbers are measurements on a shared machine, so the load average is
printed with them.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # one core: no BLAS threads
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import gc  # noqa: E402
import hashlib  # noqa: E402
import inspect  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import types  # noqa: E402
from collections import defaultdict  # noqa: E402
from pathlib import Path  # noqa: E402

import mcap.writer  # noqa: E402
import open3d  # noqa: E402, F401  (imported up front, so that no run's CPU time includes the import)
from mcap.writer import CompressionType, Writer  # noqa: E402

import navlog.recorder.record as record_mod  # noqa: E402
import navlog.recorder.sim as sim_mod  # noqa: E402
from navlog.recorder.record import prepare, record  # noqa: E402
from navlog.replay import messages  # noqa: E402
from navlog.replay.io.logwriter import McapLogWriter  # noqa: E402
from navlog.version import __version__  # noqa: E402

TARGET_RTF = 20.0
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


# ---------------------------------------------------------------- 1. real-time factor


def clean_runs(args, work: Path) -> tuple[list[float], list[float], list[float], str]:
    """Recordings as `navlog record` makes them; (real-time factors, wall s, CPU-time factors, identity)."""
    rtfs, walls, cpu_rtfs, digests = [], [], [], set()
    for i in range(args.runs):
        setup = setup_for(args.seed, args.duration)
        c0 = time.process_time()
        res = record(setup, work / "run.mcap", force=True, progress=False)
        cpu = time.process_time() - c0  # includes building the simulator (well under 0.5 s)
        rtfs.append(res.real_time_factor)
        walls.append(res.wall_s)
        cpu_rtfs.append(res.sim_s / cpu)
        digests.add(hashlib.sha256((work / "run.mcap").read_bytes()).hexdigest())
        print(
            f"  run {i + 1}: sim {res.sim_s:.2f} s, wall {res.wall_s:.2f} s, {res.real_time_factor:.1f}x real time "
            f"(CPU time {cpu:.2f} s: {res.sim_s / cpu:.1f}x), {res.size_bytes / 1e6:.1f} MB ({load()})",
            flush=True,
        )
    same = "byte-identical" if len(digests) == 1 else f"{len(digests)} DIFFERENT files"
    return rtfs, walls, cpu_rtfs, same


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
    # sensor models (their ray casting is timed separately and subtracted)
    real_sensors = sim_mod.sensors
    sproxy = types.SimpleNamespace(**{k: getattr(real_sensors, k) for k in dir(real_sensors) if not k.startswith("__")})
    sproxy.laser_ranges = tm.wrap("sensor models", real_sensors.laser_ranges)
    sproxy.lidar_sweep = tm.wrap("sensor models", real_sensors.lidar_sweep)

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
            t0 = time.perf_counter()
            super().write_raw(topic, typename, time_ns, data)
            tm.s["write_raw"] += time.perf_counter() - t0

        def close(self):  # the last chunk, the summary and the fsync count as writing
            t0 = time.perf_counter()
            try:
                return super().close()
            finally:
                dt = time.perf_counter() - t0
                tm.s["writer"] += dt
                tm.s["write_raw"] += dt

    real_zstd = mcap.writer.zstandard
    zproxy = types.SimpleNamespace(compress=tm.wrap("compression", real_zstd.compress))
    real_scenario_timer = record_mod.ScenarioNode._on_timer

    saved = (sim_mod.mujoco, sim_mod.sensors, record_mod.McapLogWriter, mcap.writer.zstandard)
    sim_mod.mujoco, sim_mod.sensors, record_mod.McapLogWriter, mcap.writer.zstandard = (
        proxy,
        sproxy,
        TimedWriter,
        zproxy,
    )
    sim_mod.SimNode.__init__ = sim_init
    record_mod.ScenarioNode._on_timer = tm.wrap("scenario node", real_scenario_timer)
    try:
        res = record(setup_for(args.seed, args.duration), work / "instrumented.mcap", force=True, progress=False)
    finally:
        sim_mod.mujoco, sim_mod.sensors, record_mod.McapLogWriter, mcap.writer.zstandard = saved
        sim_mod.SimNode.__init__ = real_sim_init
        record_mod.ScenarioNode._on_timer = real_scenario_timer
    return tm, res, captured, writer_args


def print_breakdown(tm: Timers, res) -> None:
    s = tm.s
    physics = s["physics"] + s["drive control"]
    cast = s["ray casting"]
    models = s["sensor models"] - cast
    building = s["sim tick"] - physics - s["sensor models"] + s["scenario node"]
    serialization = s["writer"] - s["write_raw"]
    compression = s["compression"]
    writing = s["write_raw"] - compression
    executor = res.wall_s - s["sim tick"] - s["scenario node"] - s["writer"]
    rows = [
        ("physics (mj_step, kinematics) + drive control", physics, f"{s['physics']:.2f} + {s['drive control']:.2f} s"),
        ("ray casting (Open3D, incl. array conversion)", cast, f"{tm.n['ray casting']} casts"),
        ("sensor models (patterns, poses, noise, points)", models, ""),
        ("message building (sim publishers, scenario)", building, ""),
        ("executor (queue, delivery) and the rest", executor, ""),
        ("serialization (CDR)", serialization, ""),
        ("compression (zstd)", compression, f"{tm.n['compression']} chunks"),
        ("MCAP records + file writing", writing, ""),
    ]
    print(
        f"per-stage breakdown, instrumented run: wall {res.wall_s:.2f} s for {res.sim_s:.2f} s of sim time "
        f"({res.real_time_factor:.1f}x; timers included)"
    )
    for name, sec, note in rows:
        print(f"  {name:<48} {sec:6.2f} s  {100 * sec / res.wall_s:5.1f} %  {note}")


# ---------------------------------------------------------------- 3. writing throughput


def chunk_size_default() -> int:
    return int(inspect.signature(McapLogWriter).parameters["chunk_size"].default)


def write_ceiling(path: Path, prepared, metadata) -> float:
    """The raw mcap Writer given pre-serialized messages, laid out as McapLogWriter lays them out."""
    t0 = time.perf_counter()
    with open(path, "wb") as f:
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
    prepared = [(env.topic, env.typename, env.time_ns, bytes(data)) for env, data in captured]
    raw_bytes = sum(len(d) for *_, d in prepared)
    ceiling, navlog, ser = [], [], []
    for i in range(args.repeat):  # alternate which writer goes first
        if i % 2 == 0:
            ceiling.append(write_ceiling(work / "ceiling.mcap", prepared, metadata))
        navlog.append(write_navlog(work / "navlog.mcap", envelopes, metadata))
        if i % 2 == 1:
            ceiling.append(write_ceiling(work / "ceiling.mcap", prepared, metadata))
        t0 = time.perf_counter()
        for env in envelopes:
            messages.serialize(env.msg, env.typename)
        ser.append(time.perf_counter() - t0)
    c, n = statistics.median(ceiling), statistics.median(navlog)
    same = (work / "ceiling.mcap").read_bytes() == (work / "navlog.mcap").read_bytes()
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
    print(f"  serialization alone (messages.serialize of every message): {statistics.median(ser):.2f} s")
    cb, nb = min(ceiling), min(navlog)
    print(
        f"  navlog / ceiling throughput: {100 * c / n:.1f} % (target >= {100 * TARGET_WRITE:.0f} %: "
        f"ratio {c / n / TARGET_WRITE:.2f}); best against best {100 * cb / nb:.1f} %; "
        f"files byte-identical: {'yes' if same else 'NO'}"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--duration", type=float, help="cut the mapping tour after this many sim seconds (default: the whole tour)"
    )
    ap.add_argument("--runs", type=int, default=5, help="clean recordings for the real-time factor (median)")
    ap.add_argument("--repeat", type=int, default=5, help="alternations of the two writers (median)")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--no-pin", action="store_true", help="do not pin the process to one CPU")
    ap.add_argument("--keep", type=Path, help="keep the outputs in this folder")
    args = ap.parse_args()
    if not args.no_pin:
        cpu = idlest_cpu()
        os.sched_setaffinity(0, {cpu})
        print(f"pinned to CPU {cpu} of {os.cpu_count()}")
    work = Path(tempfile.mkdtemp(prefix="navlog-bench-record-")) if args.keep is None else args.keep
    work.mkdir(parents=True, exist_ok=True)
    cmd = COMMAND if args.duration is None else f"{COMMAND} (tour cut at {args.duration:g} s)"
    try:
        print(f"recording: {cmd}, {args.runs} runs ({load()})", flush=True)
        rtfs, walls, cpu_rtfs, same = clean_runs(args, work)
        rtf = statistics.median(rtfs)
        print(
            f"real-time factor: median {rtf:.1f}x, best {max(rtfs):.1f}x (wall median {statistics.median(walls):.2f} s); "
            f"target {TARGET_RTF:.0f}x: ratio {rtf / TARGET_RTF:.2f} (best {max(rtfs) / TARGET_RTF:.2f}); "
            f"by CPU time median {statistics.median(cpu_rtfs):.1f}x; runs {same}"
        )
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
