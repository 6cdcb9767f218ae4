"""A recording run: world + robot + scenario + seed -> one MCAP log, with a summary.

``record()`` is what ``navlog record`` calls. It validates everything before simulating, runs the
simulator and the scenario on the executor with the MCAP writer as a sink, shows progress, and
returns a ``RecordResult``. A replay pipeline (``pipeline=``, e.g. the mapper) or extra nodes
(``live_nodes=``) can run live in the same executor; their outputs are recorded too. A pipeline
that filters velocity commands (``Pipeline.commands``: the safety filters take /cmd_vel_nav and give
/cmd_vel) sits between the scenario and the robot: the scenario publishes on the topic it takes.
A run ends early, with a whole file of what was recorded, when its
``stop`` event is set (the command line sets it on Ctrl-C; the library installs no signal handler).

Both cores work: the simulation runs in the caller's thread, the MCAP writer's thread compresses
and writes beside it (``McapLogWriter(background=True)``: a bounded queue, the same bytes), and the
laser and the LiDAR (ray casting with Open3D, which holds the GIL, their sensor models and CDR) run
in a worker process (``navlog.recorder.range_sensors``) when this process may use more than one CPU:
the same file as in one process. The worker is started first and imports Open3D and builds the
world mesh while this process compiles the MuJoCo model; this process then never imports Open3D.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.description import load_robot
from navlog.recorder.range_sensors import start_range_sensors
from navlog.recorder.robot import CMD_VEL_TOPIC, RobotSpec
from navlog.recorder.scenarios import (
    ScenarioNode,
    ScenarioSpec,
    check_scenario,
    load_scenario,
    resolve_files,
    scenario_world,
)
from navlog.recorder.world import World, load_world
from navlog.replay.config import config_hash, named_config, to_mapping
from navlog.replay.io.atomic import hold_output
from navlog.replay.io.logwriter import McapLogWriter, check_output
from navlog.replay.limits import check_seed
from navlog.replay.runtime.cpus import usable_cpus
from navlog.replay.runtime.executor import Executor, Node
from navlog.replay.runtime.pipeline import Pipeline
from navlog.replay.runtime.progress import Progress, format_table
from navlog.version import __version__

DEFAULT_WORLD, DEFAULT_ROBOT = "indoor_room", "go2"  # when neither the command line nor the scenario names one
LOCALIZATIONS = ("perfect", "none", "amcl")  # what publishes map -> odom while recording (none: nothing)


@dataclass
class RecordResult:
    path: Path
    sim_s: float
    wall_s: float
    size_bytes: int
    topics: dict[str, tuple[str, int]]  # topic -> (type, count)
    interrupted: bool = False
    metadata: dict[str, str] = field(default_factory=dict)
    contacts: list[tuple[float, str]] = field(
        default_factory=list
    )  # robot-world contacts: (sim time s, the world geom touched), one per contact episode
    navigation: dict | None = None  # a navigate scenario's goal results (the navigation pipeline's report)
    notes: list[str] = field(
        default_factory=list
    )  # what the summary adds: the robot's drive and sensors, what the world ignored
    localization: dict | None = None  # AMCL's error against the ground truth (--localization amcl)
    expect_contact: bool = False  # the scenario is meant to reach an obstacle: contacts do not fail the run

    @property
    def collisions(self) -> int:
        """The number of robot-world contacts (the simulator's ``collision`` events)."""
        return len(self.contacts)

    @property
    def failed(self) -> str | None:
        """Why the run failed (a contact the scenario does not expect, a goal not reached), or None."""
        why = []
        if self.contacts and not self.expect_contact:
            why.append(f"{self.collisions} collision(s)")
        if self.navigation is None:
            return "; ".join(why) or None
        failed = [g["name"] for g in self.navigation.get("goals", []) if g["status"] != "succeeded"]
        if failed:
            why.append(f"goal(s) failed: {', '.join(failed)}")
        ended = len(self.navigation.get("goals", []))
        planned = self.navigation.get("planned_goals", ended)
        if ended < planned:
            why.append(f"{planned - ended} goal(s) never ended (max_duration reached)")
        return "; ".join(why) or None

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
    localization: str = "perfect"  # "none": no map -> odom on /tf (a real robot's log, for SLAM)

    def topics(self) -> set[str]:
        """The topics the simulator and the scenario publish."""
        r = self.robot
        out = {"/clock", "/tf", "/tf_static", r.cmd_topic, r.odom.topic, r.odom.ground_truth_topic}
        out.update(cfg.topic for cfg in (r.scan, r.lidar, r.imu) if cfg is not None)
        if r.model is not None and r.model.wheel_joints is not None:
            out.add(r.model.joint_states_topic)
        return out

    def notes(self) -> list[str]:
        """The summary's lines about the robot: the rates published at another rate than asked; for a robot from a
        description file, where its drive came from and the sensors it declares that navlog does not simulate."""
        from navlog.recorder.sim import TICK_NS, published_rates

        rates = published_rates(self.robot)
        said = ", ".join(f"{name} {asked:g} -> {got:.2f} Hz" for name, (asked, got) in rates.items())
        out = (
            [f"rates published at the nearest multiple of the {TICK_NS / 1e6:g} ms physics step: {said}"]
            if rates
            else []
        )
        m = self.robot.model
        if m is None:
            return out
        out.insert(
            0, f"robot from {m.source}: drive {self.robot.drive.type} from {m.drive_plugin or 'the --drive option'}"
        )
        if self.robot.scan is None:
            out.append("no 2D laser in the description: nothing on a scan topic (a SLAM or a costmap's scan has none)")
        if m.other_sensors:
            out.append(f"{len(m.other_sensors)} sensor(s) not simulated: {', '.join(m.other_sensors)}")
        unbalanced = [
            k.name for k in m.links if k.inertial is not None and k.inertial.mass > 0 and k.inertial.unbalanced
        ]
        if unbalanced:
            out.append(
                f"{len(unbalanced)} link(s) whose inertia no rigid body has (a principal moment above the sum of the "
                f"other two), evened out: {', '.join(unbalanced)}"
            )
        return out

    def metadata(self) -> dict[str, str]:
        full = {
            "world": to_mapping(self.world.spec),
            "robot": robot_mapping(self.robot),
            "scenario": to_mapping(self.scenario),
            "seed": self.seed,
            "noise": self.noise,
        }
        extra = {}
        if self.localization != "perfect":  # the default's metadata (and so its bytes) stay as they were
            full["localization"] = self.localization
            extra["localization"] = self.localization
        if self.robot.odometry is not None:  # where a replay's consumers read the odometry (log_odometry)
            extra.update(odom_topic=self.robot.odometry[0], odom_frame=self.robot.odometry[1])
        return {
            "navlog_version": __version__,
            "world": self.world.name,
            "robot": self.robot.name,
            "scenario": self.scenario.name,
            "seed": str(self.seed),
            "noise": "on" if self.noise else "off",
            "config_hash": config_hash(full),
            **extra,
        }


def robot_mapping(robot: RobotSpec) -> dict:
    """The robot's configuration for the metadata's hash (without ``model`` when it has none, and without
    ``imu.bandwidth`` when it is 0, as before they existed: the logs of robots that use neither keep
    their bytes)."""
    out = to_mapping(robot)
    if robot.model is None:
        del out["model"]
    if robot.imu is not None and robot.imu.bandwidth == 0:
        del out["imu"]["bandwidth"]
    return out


def prepare(
    world: str | None,
    robot: str | None,
    scenario: str,
    seed: int = 0,
    noise: bool = True,
    localization: str = "perfect",
    *,
    robot_args: Mapping[str, str] | None = None,
    package_paths: Sequence[Path | str] = (),
    drive: str | None = None,
    resource_paths: Sequence[Path | str] = (),
    wall_height: float | None = None,
) -> RecordSetup:
    """Load and check world, robot and scenario; raises ConfigError before anything runs.

    ``world``/``robot`` None: the scenario's own (its ``world``/``robot`` fields; a world given by path
    is relative to the scenario file), else indoor_room / go2. ``resource_paths`` and ``wall_height``:
    how an SDF world finds its models and a map world's wall height (``load_world``).

    ``localization``: ``amcl`` runs Nav2's AMCL live on the world's map (the scenario's Nav2 file's
    ``amcl`` block, started at the scenario's start pose): it publishes map -> odom from /scan and the
    drifting odometry, as on a real robot (a navigate scenario's navigation then runs on it);
    ``perfect`` publishes map -> odom as the true correction; ``none`` publishes no
    map -> odom (odom -> base only, drifting), as a real robot's log for a SLAM node to map.

    ``robot_args``, ``package_paths``, ``drive``: for a robot from a description file
    (``navlog.recorder.description.load_robot``)."""
    check_seed(seed)
    if localization not in LOCALIZATIONS:
        raise ConfigError(f"localization '{localization}' is not one of: {', '.join(LOCALIZATIONS)}")
    folder = named_config("scenarios", scenario).parent
    s = resolve_files(load_scenario(scenario), folder, [*package_paths, *resource_paths])
    w = load_world(
        world or scenario_world(s, folder) or DEFAULT_WORLD, resource_paths=resource_paths, wall_height=wall_height
    )
    r = load_robot(robot or s.robot or DEFAULT_ROBOT, robot_args, [*package_paths, *resource_paths], drive)
    check_scenario(s, r, w, folder)
    if localization == "amcl" and r.scan is None:
        where = f" ({r.model.source})" if r.model is not None else ""
        raise ConfigError(
            f"robot '{r.name}'{where} has no 2D laser, and AMCL localises on its scan: give the robot a laser (a "
            "ray or gpu_lidar sensor with one vertical sample, e.g. the gz_*.sdf.xacro of a TurtleBot), or record "
            "with --localization perfect"
        )
    return RecordSetup(w, r, s, seed, noise, localization)


class StopFlag(Protocol):
    """What ``record`` looks at to end a run early: a ``threading.Event`` set by another thread or a
    signal handler (the command line's, on Ctrl-C)."""

    def is_set(self) -> bool: ...


def record(
    setup: RecordSetup,
    out: Path | str,
    *,
    force: bool = False,
    progress: bool = True,
    live_nodes: Sequence[Node] = (),
    pipeline: Pipeline | None = None,
    navigation: Pipeline | None = None,
    stop: StopFlag | None = None,
    sensor_worker: bool | None = None,
) -> RecordResult:
    """Simulate ``setup`` and write every topic to ``out`` (MCAP); see the module docstring.

    ``pipeline``: a replay pipeline (``build(params, setup.topics())``) whose nodes run live after
    ``live_nodes``; when it filters commands, the scenario publishes on the topic it takes.

    ``navigation``: for a navigate scenario, its navigation pipeline (default: built from the scenario,
    ``navlog.recorder.navigation.navigation_pipeline``); it drives the robot, and the run ends the
    scenario's hold time after its last goal ended.

    ``stop``, when set (from another thread or a signal handler), ends the run within a second of sim
    time; the file is then closed cleanly with what was recorded and the result says ``interrupted``.

    ``sensor_worker``: cast the laser and the LiDAR in a worker process beside the simulation (the
    same file either way; ``navlog.recorder.range_sensors``); None: when this process may use more
    than one CPU (on one, the worker's start-up and messages would only add to the same core's work).
    """
    out = Path(out)
    check_output(out, force)
    with hold_output(out):  # one run writes ``out`` at a time
        return _record(setup, out, force, progress, live_nodes, pipeline, navigation, stop, sensor_worker)


def _record(
    setup: RecordSetup,
    out: Path,
    force: bool,
    progress: bool,
    live_nodes: Sequence[Node],
    pipeline: Pipeline | None,
    navigation: Pipeline | None,
    stop: StopFlag | None,
    sensor_worker: bool | None,
) -> RecordResult:
    """``record`` once ``out`` is checked and held."""
    command_topic = scenario_command_topic(pipeline, setup.robot.cmd_topic)
    # the sensor worker first, so that its start-up runs beside MuJoCo's import and model compilation
    if sensor_worker is None:
        sensor_worker = usable_cpus() > 1
    ranges = start_range_sensors(setup.world, setup.robot, setup.seed, setup.noise, worker=sensor_worker)
    try:
        from navlog.recorder.sim import SimNode, SimOptions

        options = SimOptions(
            seed=setup.seed,
            noise=setup.noise,
            start=setup.scenario.start,
            localization="perfect" if setup.localization == "perfect" else "none",
        )
        sim = SimNode(setup.world, setup.robot, options, ranges=ranges)
    except BaseException:
        if ranges is not None:
            ranges.close()
        raise
    try:
        nodes: list[Node] = []
        if setup.scenario.kind == "navigate":
            from navlog.recorder.navigation import navigation_pipeline, world_map_node

            if navigation is None:
                navigation = navigation_pipeline(
                    setup.scenario, setup.seed, command_topic=setup.robot.cmd_topic, odometry=setup.robot.odometry
                )
            map_server = world_map_node(setup.scenario, setup.world)
            nodes += [map_server] if map_server is not None else []
        amcl_error = None
        if setup.localization == "amcl":
            from navlog.recorder.navigation import AmclErrorNode, amcl_node

            amcl = amcl_node(setup.scenario, setup.world, setup.seed, odometry=setup.robot.odometry)
            amcl_error = AmclErrorNode(amcl, setup.robot.odom.ground_truth_topic)
            nodes += [amcl, amcl_error]
        done = navigation.done if navigation is not None else None
        driver = ScenarioNode(setup.scenario, setup.robot, command_topic=command_topic, navigation_done=done)
        ex = Executor()
        ex.add_node(sim, source=True)
        collisions = CollisionCounter(setup.world, setup.robot)
        nodes += [driver, collisions]
        nodes += navigation.nodes if navigation is not None else []
        for node in [*nodes, *live_nodes, *(pipeline.nodes if pipeline is not None else [])]:
            ex.add_node(node)
        meta = setup.metadata()
        max_ns = int(setup.scenario.max_duration * 1e9)
        start = time.perf_counter()
        with Progress(expected_duration(setup), "recording", "sim s", enabled=progress) as bar:
            with McapLogWriter(out, force=force, metadata={"navlog": meta}, background=True) as writer:
                ex.add_sink(writer)  # the worker's scans and sweeps in their places (``Node.defer``)
                t = 0
                while not (stop is not None and stop.is_set()):  # looked at after every second of sim time
                    t = min(t + 1_000_000_000, max_ns)
                    ex.run(until_ns=t)
                    bar.update(ex.now / 1e9)
                    end = driver.finished_ns
                    if end is not None and ex.now >= end:
                        break
                    if t >= max_ns:  # run up to max_duration (ex.now is the last event's time: it may stop short)
                        break
                ex.finish()
            interrupted = stop is not None and stop.is_set()
            if not interrupted:  # the run is complete: the estimated length becomes the real one
                bar.update(ex.now / 1e9, total=ex.now / 1e9)
        wall = time.perf_counter() - start
        counts = {}
        types = writer.topic_types
        for topic, n in sorted(ex.stats.published.items()):
            counts[topic] = (types.get(topic, ""), n)
        report = navigation.report() if navigation is not None and navigation.report is not None else None
        return RecordResult(
            out,
            ex.now / 1e9,
            wall,
            out.stat().st_size,
            counts,
            interrupted,
            meta,
            collisions.contacts,
            report,
            setup.notes() + list(setup.world.notes),
            amcl_error.report() if amcl_error is not None else None,
            setup.scenario.expect_contact,
        )
    finally:
        sim.close()  # the sensor worker ends with the run, however it ends


class CollisionCounter(Node):
    """Collects the robot's contacts with the world: (sim time s, what it touched), one per contact episode.

    A wheeled robot's are the simulator's ``collision`` events. A legged robot's trunk does not collide
    (its legs are not simulated: it passes through obstacles), so with ``world`` and ``robot`` given for
    one, a contact is where its footprint (a circle of the robot's radius around the true pose, from the
    ground truth) overlaps an obstacle, episodes apart by more than the simulator's contact gap."""

    name = "collision_counter"

    def __init__(self, world: World | None = None, robot: RobotSpec | None = None) -> None:
        super().__init__()
        self.contacts: list[tuple[float, str]] = []
        self._world = world
        self._robot = robot if robot is not None and robot.drive.type == "legged" else None
        self._poses: list[tuple[int, float, float]] = []  # a legged robot's true (t_ns, x, y)

    @property
    def count(self) -> int:
        return len(self.contacts)

    def setup(self) -> None:
        from navlog.recorder.sim import EVENTS_TOPIC

        self.subscribe(EVENTS_TOPIC, self._on_event)
        if self._robot is not None:
            self.subscribe(self._robot.odom.ground_truth_topic, self._on_pose)

    def _on_event(self, msg, t_ns: int) -> None:
        if getattr(msg, "kind", "") == "collision":
            self.contacts.append((t_ns / 1e9, str(msg.detail)))

    def _on_pose(self, msg, t_ns: int) -> None:
        p = msg.pose.pose.position
        self._poses.append((t_ns, p.x, p.y))

    def finish(self) -> None:
        """A legged robot's footprint contacts, from the poses of the whole run (one vectorised check)."""
        if self._robot is None or self._world is None or not self._poses:
            return
        from navlog.recorder.sim import CONTACT_GAP_NS
        from navlog.recorder.world import clearance, nearest_solid

        poses = np.array(self._poses)
        touching = np.flatnonzero(clearance(self._world, poses[:, 1:]) < self._robot.radius)
        last = None
        for i in touching.tolist():
            t_ns = int(poses[i, 0])
            if last is None or t_ns - last > CONTACT_GAP_NS:
                name, _ = nearest_solid(self._world, (float(poses[i, 1]), float(poses[i, 2])))
                self.contacts.append((t_ns / 1e9, name))
            last = t_ns
        self.contacts.sort()


def scenario_command_topic(pipeline: Pipeline | None, robot_topic: str = CMD_VEL_TOPIC) -> str:
    """Where the scenario publishes its commands: the robot's command topic (``robot_topic``), or the topic a
    live pipeline filters into it (ConfigError when that pipeline's commands would not reach the robot)."""
    if pipeline is None or pipeline.commands is None:
        return robot_topic
    takes, gives = pipeline.commands
    if gives != robot_topic:
        raise ConfigError(
            f"pipeline '{pipeline.name}' gives its commands on {gives}, but the robot drives on {robot_topic}; "
            f"run it live with its output on {robot_topic} (e.g. --set output_topic={robot_topic})"
        )
    return takes


def expected_duration(setup: RecordSetup) -> float:
    """An estimate of a run's sim length in seconds, for the progress bar (never more than ``max_duration``).

    A teleop scenario lasts its commands plus the hold. A tour lasts about its legs at the tour speed
    plus its turns at the turn rate, plus the hold.
    """
    s = setup.scenario
    if s.kind == "teleop":
        total = sum(c.duration for c in s.commands)
    else:
        d = setup.robot.drive
        speed, turn_rate = min(s.speed, d.max_vx), min(s.turn_rate, d.max_wz)
        x, y, heading = s.start
        total = 0.0
        for gx, gy in s.waypoints:
            dist = math.hypot(gx - x, gy - y)
            if dist > s.tolerance:
                bearing = math.atan2(gy - y, gx - x)
                turn = abs(math.atan2(math.sin(bearing - heading), math.cos(bearing - heading)))
                total += dist / speed + turn / turn_rate
                x, y, heading = gx, gy, bearing
    return min(total + s.hold, s.max_duration)


def format_summary(res: RecordResult) -> str:
    lines = [
        f"wrote {res.path} ({res.size_bytes / 1e6:.1f} MB){' — interrupted, file closed cleanly' if res.interrupted else ''}",
        f"sim time {res.sim_s:.2f} s, wall time {res.wall_s:.2f} s, real-time factor {res.real_time_factor:.1f}x",
        f"world {res.metadata.get('world')}, robot {res.metadata.get('robot')}, scenario {res.metadata.get('scenario')}, "
        f"seed {res.metadata.get('seed')}, noise {res.metadata.get('noise')}",
        *(f"world: {note}" for note in res.notes),
    ]
    rows = []
    for topic, (typ, n) in res.topics.items():
        rate = (n - 1) / res.sim_s if res.sim_s > 0 and n > 1 else 0.0
        rows.append((topic, typ, n, f"{rate:.2f} Hz"))
    if rows:
        lines.append(format_table(("topic", "type", "msgs", "rate"), rows, align=("left", "left", "right", "right")))
    lines += res.notes
    if res.localization is not None:
        lines.append(format_localization(res.localization))
    lines.append(format_contacts(res))
    if res.navigation is not None:
        goals = [
            (g["name"], g["status"], g["code"] or "", f"{g['time_s']:.1f} s", g["recoveries"], g["message"])
            for g in res.navigation.get("goals", [])
        ]
        lines.append(
            format_table(
                ("goal", "result", "code", "time", "recoveries", "message"),
                goals,
                align=("left", "left", "right", "right", "right", "left"),
            )
        )
        lines.append(
            f"navigation FAILED: {res.failed}" if res.failed else "navigation: every goal reached, no collision"
        )
    elif res.failed:
        lines.append(f"FAILED: {res.failed}")
    return "\n".join(lines)


def format_localization(report: dict) -> str:
    """One line of AMCL's error against the ground truth (``AmclErrorNode.report``)."""
    if not report.get("poses"):
        return "AMCL against ground truth: no pose estimated"
    return (
        f"AMCL against ground truth ({report['poses']} poses): position error mean {report['mean_m']:.3f} m, "
        f"RMS {report['rms_m']:.3f} m, max {report['max_m']:.3f} m, final {report['final_m']:.3f} m; "
        f"yaw error mean {report['yaw_mean_deg']:.2f} deg, max {report['yaw_max_deg']:.2f} deg"
    )


def format_contacts(res: RecordResult) -> str:
    """The summary's line about robot-world contacts: how many, the first (time and what), what was touched."""
    if not res.contacts:
        return "contacts: none" + (" (the scenario expected contact)" if res.expect_contact else "")
    t0, first = res.contacts[0]
    touched = sorted({name for _, name in res.contacts})
    expected = "expected: the scenario sets expect_contact" if res.expect_contact else "not expected by the scenario"
    return f"contacts: {res.collisions} ({expected}), first at {t0:.2f} s with {first}; touched: {', '.join(touched)}"
