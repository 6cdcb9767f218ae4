"""A recording run: world + robot + scenario + seed -> one MCAP log, with a summary.

``record()`` is what ``navlog record`` calls. It validates everything before simulating, runs the
simulator and the scenario on the executor with the MCAP writer as a sink, shows progress, and
returns a ``RecordResult``. Extra nodes (e.g. mappers) can run live in the same executor; their
outputs are recorded too.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from navlog.recorder.robot import RobotSpec, load_robot
from navlog.recorder.scenarios import ScenarioNode, ScenarioSpec, check_scenario, load_scenario
from navlog.recorder.sim import SimNode, SimOptions
from navlog.recorder.world import World, load_world
from navlog.replay.config import config_hash, to_mapping
from navlog.replay.io.logwriter import McapLogWriter, check_output
from navlog.replay.runtime.executor import Executor, Node
from navlog.replay.runtime.progress import Progress
from navlog.version import __version__


@dataclass
class RecordResult:
    path: Path
    sim_s: float
    wall_s: float
    size_bytes: int
    topics: dict[str, tuple[str, int]]  # topic -> (type, count)
    interrupted: bool = False
    metadata: dict[str, str] = field(default_factory=dict)

    @property
    def real_time_factor(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else float("inf")


@dataclass
class RecordSetup:
    """Everything a recording is made of, loaded and checked."""

    world: World
    robot: RobotSpec
    scenario: ScenarioSpec
    seed: int
    noise: bool

    def topics(self) -> set[str]:
        """The topics the simulator and the scenario publish."""
        r = self.robot
        out = {"/clock", "/tf", "/tf_static", "/cmd_vel", r.odom.topic, r.odom.ground_truth_topic}
        out.update(cfg.topic for cfg in (r.scan, r.lidar, r.imu) if cfg is not None)
        return out

    def metadata(self) -> dict[str, str]:
        full = {
            "world": to_mapping(self.world.spec),
            "robot": to_mapping(self.robot),
            "scenario": to_mapping(self.scenario),
            "seed": self.seed,
            "noise": self.noise,
        }
        return {
            "navlog_version": __version__,
            "world": self.world.name,
            "robot": self.robot.name,
            "scenario": self.scenario.name,
            "seed": str(self.seed),
            "noise": "on" if self.noise else "off",
            "config_hash": config_hash(full),
        }


def prepare(world: str, robot: str, scenario: str, seed: int = 0, noise: bool = True) -> RecordSetup:
    """Load and check world, robot and scenario; raises ConfigError before anything runs."""
    w, r, s = load_world(world), load_robot(robot), load_scenario(scenario)
    check_scenario(s, r, w)
    return RecordSetup(w, r, s, seed, noise)


def record(
    setup: RecordSetup,
    out: Path | str,
    *,
    force: bool = False,
    progress: bool = True,
    live_nodes: Sequence[Node] = (),
) -> RecordResult:
    out = Path(out)
    check_output(out, force)
    sim = SimNode(setup.world, setup.robot, SimOptions(seed=setup.seed, noise=setup.noise, start=setup.scenario.start))
    driver = ScenarioNode(setup.scenario, setup.robot)
    ex = Executor()
    ex.add_node(sim, source=True)
    ex.add_node(driver)
    for node in live_nodes:
        ex.add_node(node)
    meta = setup.metadata()
    max_ns = int(setup.scenario.max_duration * 1e9)
    # the expected length, for the progress bar: path length at the tour speed, or the command list
    expected = setup.scenario.max_duration
    if setup.scenario.kind == "teleop":
        expected = sum(c.duration for c in setup.scenario.commands) + setup.scenario.hold
    bar = Progress(expected, "recording", "sim s", enabled=progress)
    interrupted = False

    def on_sigint(signum, frame):  # end cleanly with what was recorded
        nonlocal interrupted
        interrupted = True
        ex.stop()

    previous = signal.signal(signal.SIGINT, on_sigint)
    start = time.perf_counter()
    try:
        with McapLogWriter(out, force=force, metadata={"navlog": meta}) as writer:
            ex.add_sink(writer)
            t = 0
            while not interrupted:
                t += 1_000_000_000
                ex.run(until_ns=min(t, max_ns))
                bar.update(ex.now / 1e9)
                end = driver.finished_ns
                if end is not None and ex.now >= end:
                    break
                if ex.now >= max_ns:
                    break
            ex.finish()
    finally:
        signal.signal(signal.SIGINT, previous)
        bar.close()
    wall = time.perf_counter() - start
    counts = {}
    types = writer.topic_types
    for topic, n in sorted(ex.stats.published.items()):
        counts[topic] = (types.get(topic, ""), n)
    return RecordResult(out, ex.now / 1e9, wall, out.stat().st_size, counts, interrupted, meta)


def format_summary(res: RecordResult) -> str:
    lines = [
        f"wrote {res.path} ({res.size_bytes / 1e6:.1f} MB){' — interrupted, file closed cleanly' if res.interrupted else ''}",
        f"sim time {res.sim_s:.2f} s, wall time {res.wall_s:.2f} s, real-time factor {res.real_time_factor:.1f}x",
        f"world {res.metadata.get('world')}, robot {res.metadata.get('robot')}, scenario {res.metadata.get('scenario')}, "
        f"seed {res.metadata.get('seed')}, noise {res.metadata.get('noise')}",
    ]
    width = max(len(t) for t in res.topics) if res.topics else 5
    twidth = max(len(v[0]) for v in res.topics.values()) if res.topics else 4
    for topic, (typ, n) in res.topics.items():
        rate = (n - 1) / res.sim_s if res.sim_s > 0 and n > 1 else 0.0
        lines.append(f"  {topic:<{width}}  {typ:<{twidth}}  {n:>7} msgs  {rate:8.2f} Hz")
    return "\n".join(lines)
