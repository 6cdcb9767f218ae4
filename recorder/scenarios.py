"""Scenarios from YAML: what drives the robot during a recording.

- ``tour``: visit waypoints in order with a simple heading-then-drive controller on the true pose
  (like a person driving the robot around the room), then stand still for ``hold`` seconds.
- ``teleop``: play a list of timed velocity commands, then stand still for ``hold`` seconds.
- ``navigate``: Nav2 drives: the scenario names a Nav2 parameter file (``nav2_params``) and a goals
  YAML (``goals``); the recorder runs the navigation pipeline live (planner, controller, behaviours,
  navigator, then the velocity smoother and collision monitor when the file configures them) and the
  run ends ``hold`` seconds after the last goal ended. ``map: world`` publishes the world's obstacles
  grown by ``map_margin`` on /map at t = 0, as a map_server would (the Go2 setup's fixed map).

Both are checked before anything is simulated: the start pose and the whole intended path must stay
at least the robot's reach away from every obstacle (``check_scenario``): the larger of its Nav2 radius
and its body's half-diagonal, since a box body's corners reach beyond the radius (KiBot: radius
0.34 m, a 0.6 x 0.5 m body reaching 0.39 m). The check is of the intended path; the simulated robot
lags its commands and slips, so a path that passes close can still touch: the recorder reports every
contact and fails the run unless the scenario expects contact. A scenario made to test
what stops a robot before an obstacle (``teleop_wall``) opts in with ``expect_contact: true``: its
path must then reach an obstacle, and only its start pose must be clear.

The scenario publishes its commands on /cmd_vel, or, when a live pipeline filters them (the safety
pipeline reads /cmd_vel_nav), on the topic that pipeline takes (``ScenarioNode(command_topic=...)``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.robot import CMD_VEL_TOPIC, RobotSpec
from navlog.recorder.world import World, clearance, nearest_solid
from navlog.replay import messages
from navlog.replay.config import known_configs, load_config, named_config, param
from navlog.replay.geometry import rotate_planar, wrap_angle, yaw_from_quat
from navlog.replay.limits import MAX_PERIOD_S, MAX_RATE_HZ
from navlog.replay.runtime.executor import Node

MAX_SCENARIO_SPEED = 100.0  # m/s or rad/s a scenario may ask for: beyond any ground robot


@dataclass(frozen=True)
class TimedCommand:
    duration: float
    cmd: tuple[float, float, float]  # vx, vy, wz


@dataclass(frozen=True)
class ScenarioSpec:
    name: str
    kind: Literal["tour", "teleop", "navigate"]
    description: str = ""
    world: str = ""  # the world a tour was laid out for ("" = any world)
    robot: str = ""  # the robot it was made for ("" = any robot; also the default of --robot)
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    waypoints: list[tuple[float, float]] = field(default_factory=list)
    speed: float = param(0.3, gt=0.0, le=MAX_SCENARIO_SPEED)  # m/s a tour asks for (the robot's own limits cap it)
    turn_rate: float = param(0.5, gt=0.0, le=MAX_SCENARIO_SPEED)  # rad/s
    tolerance: float = param(0.15, gt=0.0, le=100.0)  # m from a waypoint that reaches it
    commands: list[TimedCommand] = field(default_factory=list)
    hold: float = param(1.0, ge=0.0, le=MAX_PERIOD_S)  # seconds stood still at the end
    max_duration: float = param(600.0, gt=0.0, le=MAX_PERIOD_S)  # seconds of sim time at most
    rate: float = param(20.0, le=MAX_RATE_HZ)  # Hz of the scenario's commands
    expect_contact: bool = False  # the path is meant to reach an obstacle (a test of the safety filters)
    # navigate: the Nav2 parameter file and goals YAML (names in config/nav2, config/goals, or paths)
    nav2_params: str = ""
    goals: str = ""
    navigation: Literal["waypoints", "through_poses"] = "waypoints"
    # world: the world's obstacles on /map, grown by map_margin; none; or a map_server YAML (a path relative
    # to the scenario file, or package://PKG/...) served on /map and given to AMCL, as Nav2's map_server does
    map: str = "world"
    map_margin: float = 0.15

    def __post_init__(self) -> None:
        if self.kind == "tour" and not self.waypoints:
            raise ValueError("a tour needs waypoints")
        if self.kind == "teleop" and not self.commands:
            raise ValueError("a teleop scenario needs commands")
        if self.kind == "navigate" and not (self.nav2_params and self.goals):
            raise ValueError("a navigate scenario needs nav2_params (a Nav2 file) and goals (a goals YAML)")
        if not self.map:
            raise ValueError("map must be 'world', 'none' or a map_server YAML")
        if not 0 <= self.map_margin <= 5:
            raise ValueError("map_margin must be between 0 and 5 m")
        if self.speed <= 0 or self.turn_rate <= 0 or self.rate <= 0 or self.max_duration <= 0:
            raise ValueError("speed, turn_rate, rate and max_duration must be positive")
        numbers = [*self.start, *(v for w in self.waypoints for v in w)]
        numbers += [v for c in self.commands for v in (c.duration, *c.cmd)]
        if not all(abs(v) <= 1e5 for v in numbers):  # also refuses NaN
            raise ValueError("start, waypoints and commands must be numbers within 100 km (no NaN or inf)")
        if not all(0 <= c.duration <= self.max_duration for c in self.commands):
            raise ValueError(f"command durations must be between 0 and max_duration ({self.max_duration} s)")


def load_scenario(name: str) -> ScenarioSpec:
    return load_config(ScenarioSpec, named_config("scenarios", name))


WORLD_FILE_SUFFIXES = (".yaml", ".yml", ".sdf", ".world", ".xacro", ".urdf")
MAP_KINDS = ("world", "none")  # a scenario's ``map`` that is no file


def _world_file(name: str) -> bool:
    """True when a scenario's ``world`` names a file (a path) rather than a world of config/worlds."""
    return "/" in name or name.endswith(WORLD_FILE_SUFFIXES)


def scenario_file(spec: str, folder: Path | None, search_paths: Sequence[Path | str] = ()) -> str:
    """A file a scenario names: ``package://PKG/...`` or ``model://NAME/...`` along the package and resource
    paths (``search_paths`` first, then the environment's: ``navlog.recorder.resources``), a path relative to
    the scenario file's ``folder``; a name (no ``/``, no file suffix) as it is."""
    if "://" in spec:
        from navlog.recorder.resources import resolve_uri

        return str(resolve_uri(spec, folder or Path("."), search_paths))
    if not _world_file(spec) or folder is None:
        return spec
    path = Path(spec)
    return str(path if path.is_absolute() else folder / path)


def scenario_world(scenario: ScenarioSpec, folder: Path | None, search_paths: Sequence[Path | str] = ()) -> str:
    """The world a scenario names: a name as it is, a file as ``scenario_file`` finds it."""
    return scenario_file(scenario.world, folder, search_paths) if scenario.world else ""


def resolve_files(scenario: ScenarioSpec, folder: Path | None, search_paths: Sequence[Path | str] = ()) -> ScenarioSpec:
    """``scenario`` with the files it names (world, robot, Nav2 file, goals, map) found (``scenario_file``)."""
    from dataclasses import replace

    def find(value: str) -> str:
        return scenario_file(value, folder, search_paths) if value and value not in MAP_KINDS else value

    search_paths = [Path(p).absolute() for p in search_paths]  # relative to the working folder, not the scenario
    s = scenario
    return replace(
        s,
        world=find(s.world),
        robot=find(s.robot),
        nav2_params=find(s.nav2_params),
        goals=find(s.goals),
        map=find(s.map),
    )


def scenario_map(scenario: ScenarioSpec) -> Path | None:
    """The map_server YAML a scenario serves on /map (its ``map`` when that is a file), else None."""
    return None if scenario.map in MAP_KINDS else Path(scenario.map)


PATH_STEP_S = 0.05  # a teleop path's time step (s) in the clearance check


def intended_path(scenario: ScenarioSpec, robot: RobotSpec, step: float = 0.05) -> np.ndarray:
    """Points (N, 2) along the path the scenario means to drive, for the clearance check."""
    if scenario.kind == "tour":
        pts = [np.array(scenario.start[:2])] + [np.array(w) for w in scenario.waypoints]
        out: list[Any] = [pts[0]]
        for a, b in zip(pts[:-1], pts[1:]):
            n = max(1, int(math.ceil(np.linalg.norm(b - a) / step)))
            out += [a + (b - a) * (i / n) for i in range(1, n + 1)]
        return np.array(out)
    x, y, th = scenario.start
    d = robot.drive
    out = [(x, y)]
    dt = PATH_STEP_S
    for c in scenario.commands:
        vx, vy, wz = np.clip(c.cmd, [-d.max_vx, -d.max_vy, -d.max_wz], [d.max_vx, d.max_vy, d.max_wz])
        for _ in range(int(round(c.duration / dt))):
            dx, dy = rotate_planar(vx, vy, th)
            x += dx * dt
            y += dy * dt
            th += wz * dt
            out.append((x, y))
    return np.array(out)


def _scenarios_for(world: World, refused: str) -> str:
    """What to name with --scenario for ``world``: navlog's scenarios laid out for a world of its name or file
    name, and those laid out for any world (not the ``refused`` one)."""
    fitting, anywhere = [], []
    for name in known_configs("scenarios"):
        if name == refused:
            continue
        try:
            laid_out = load_scenario(name).world
        except ConfigError:
            continue
        if not laid_out:
            anywhere.append(name)
        elif laid_out == world.name or (world.path is not None and Path(laid_out).name == Path(world.path).name):
            fitting.append(name)
    said = (
        f"a scenario laid out for it: --scenario {' or '.join(fitting)}"
        if fitting
        else "a scenario of your own (a tour's waypoints or a navigate scenario's goals in it: see the recording guide)"
    )
    return said + (f"; in any world, from its start pose: --scenario {' or '.join(anywhere)}" if anywhere else "")


def check_scenario(scenario: ScenarioSpec, robot: RobotSpec, world: World, folder: Path | None = None) -> None:
    """Refuse, before simulating, a start pose or path that comes closer than the robot's radius.

    ``folder``: the scenario file's folder, where a ``world`` given as a path starts."""
    if scenario.world and _world_file(scenario.world):
        wanted = Path(scenario_world(scenario, folder))
        if wanted.resolve() != Path(world.path).resolve():
            raise ConfigError(
                f"scenario '{scenario.name}' is laid out for world {wanted}, not {world.path}; "
                f"use --world {wanted} or {_scenarios_for(world, scenario.name)}"
            )
    elif scenario.world and scenario.world != world.name:
        raise ConfigError(
            f"scenario '{scenario.name}' is laid out for world '{scenario.world}', not '{world.name}'; "
            f"use --world {scenario.world} or {_scenarios_for(world, scenario.name)}"
        )
    if scenario.robot and not _world_file(scenario.robot) and scenario.robot != robot.name:
        raise ConfigError(
            f"scenario '{scenario.name}' is made for robot '{scenario.robot}', not '{robot.name}'; "
            f"use --robot {scenario.robot} or a scenario made for {robot.name}"
        )
    reach = robot_reach(robot)
    size = f"robot radius {robot.radius} m, body {robot.body.size[0]:.2f} x {robot.body.size[1]:.2f} m"
    start = (scenario.start[0], scenario.start[1])
    name0, c0 = nearest_solid(world, start)
    if c0 < reach:
        raise ConfigError(
            f"spawn pose ({scenario.start[0]:.2f}, {scenario.start[1]:.2f}) of scenario '{scenario.name}' is "
            f"{'inside an obstacle' if c0 < 0 else f'only {c0:.2f} m from an obstacle'} ({name0}) in world '{world.name}' "
            f"(the robot reaches {reach:.2f} m from its centre: {size}); move 'start'"
        )
    if scenario.kind == "navigate":
        check_goals(scenario, robot, world)
        return
    path = intended_path(scenario, robot)
    c = clearance(world, path)
    i = int(np.argmin(c))
    if scenario.expect_contact:
        if c[i] >= reach:
            raise ConfigError(
                f"scenario '{scenario.name}' sets expect_contact: true, but its path stays {c[i]:.2f} m from every "
                f"obstacle of world '{world.name}' (the robot reaches {reach:.2f} m from its centre: {size}); "
                "remove expect_contact"
            )
        return
    if c[i] < reach:
        j = int(np.argmax(c < reach))  # where the path first comes too close
        name, _ = nearest_solid(world, (float(path[j, 0]), float(path[j, 1])))
        when = f" after {j * PATH_STEP_S:.1f} s of commands" if scenario.kind == "teleop" else ""
        closest = "inside an obstacle" if c[i] < 0 else f"{c[i]:.2f} m from an obstacle"
        raise ConfigError(
            f"scenario '{scenario.name}' would collide with {name} in world '{world.name}': its path comes within "
            f"the robot's reach of it at ({path[j, 0]:.2f}, {path[j, 1]:.2f}){when} and passes "
            f"({path[i, 0]:.2f}, {path[i, 1]:.2f}), {closest} (the robot reaches {reach:.2f} m from its centre: "
            f"{size}); change the scenario's start or commands for this world (a scenario meant to reach an "
            "obstacle sets expect_contact: true)"
        )


def robot_reach(robot: RobotSpec) -> float:
    """How far the robot reaches from its centre, seen from above: the larger of its Nav2 radius and its
    body's half-diagonal (a box body's corners reach beyond an inscribed radius)."""
    return max(robot.radius, math.hypot(robot.body.size[0], robot.body.size[1]) / 2)


def navigation_goals(scenario: ScenarioSpec) -> list[tuple[str, tuple[float, float, float]]]:
    """A navigate scenario's goals, (name, (x, y, yaw)) in the map frame, from its goals YAML."""
    from navlog.replay.pipelines.planner import load_named_goals

    goals, _ = load_named_goals(scenario.goals)
    if not goals:
        raise ConfigError(f"scenario '{scenario.name}': goals '{scenario.goals}' lists no goal")
    return goals


def check_goals(scenario: ScenarioSpec, robot: RobotSpec, world: World) -> None:
    """Refuse, before simulating, a goal outside the world or closer than the robot's radius to an obstacle."""
    goals = navigation_goals(scenario)
    x0, y0, x1, y1 = world.bounds()
    c = clearance(world, np.array([pose[:2] for _, pose in goals]))
    for (name, (x, y, _)), ci in zip(goals, c):
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            raise ConfigError(
                f"scenario '{scenario.name}': goal '{name}' ({x:.2f}, {y:.2f}) is outside world '{world.name}' "
                f"(x {x0:.2f}..{x1:.2f}, y {y0:.2f}..{y1:.2f}); fix it in {scenario.goals}"
            )
        if ci < robot.radius:
            where = "inside an obstacle" if ci < 0 else f"only {ci:.2f} m from an obstacle"
            raise ConfigError(
                f"scenario '{scenario.name}': goal '{name}' ({x:.2f}, {y:.2f}) is {where} of world '{world.name}' "
                f"(robot radius {robot.radius} m); move it in {scenario.goals}"
            )


class ScenarioNode(Node):
    """Publishes commands on ``command_topic`` at ``rate`` from the true pose, until the scenario is done."""

    name = "scenario"

    def __init__(
        self,
        scenario: ScenarioSpec,
        robot: RobotSpec,
        *,
        command_topic: str = CMD_VEL_TOPIC,
        navigation_done: Callable[[], bool] | None = None,
    ) -> None:
        """``navigation_done``: for a navigate scenario, says when every goal has ended (the node then
        publishes no command: the navigation stack drives)."""
        super().__init__()
        if scenario.kind == "navigate" and navigation_done is None:
            raise ValueError("a navigate scenario needs navigation_done (the navigation stack's done)")
        self.navigation_done = navigation_done
        self.scenario = scenario
        self.robot = robot
        self.command_topic = command_topic
        self.pose: tuple[float, float, float] | None = None
        self.index = 0
        self.done_ns: int | None = None
        self.reached: list[int] = []

    def setup(self) -> None:
        self.subscribe(self.robot.odom.ground_truth_topic, self._on_pose)
        self.create_timer(int(round(1e9 / self.scenario.rate)), self._on_timer, start_ns=0)

    @property
    def finished_ns(self) -> int | None:
        """Sim time at which the recording can end (done plus the hold time)."""
        return None if self.done_ns is None else self.done_ns + int(self.scenario.hold * 1e9)

    def _on_pose(self, msg, t_ns: int) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        self.pose = (p.x, p.y, yaw_from_quat((q.x, q.y, q.z, q.w)))

    def _on_timer(self, t_ns: int) -> None:
        if self.navigation_done is not None:
            if self.done_ns is None and self.navigation_done():
                self.done_ns = t_ns
            return
        cmd = (0.0, 0.0, 0.0)
        if self.done_ns is None:
            cmd = self._tour(t_ns) if self.scenario.kind == "tour" else self._teleop(t_ns)
        self.publish(self.command_topic, messages.TWIST, messages.twist(*cmd))

    def _teleop(self, t_ns: int) -> tuple[float, float, float]:
        t = t_ns / 1e9
        for c in self.scenario.commands:
            if t < c.duration - 1e-9:
                return c.cmd
            t -= c.duration
        self.done_ns = t_ns
        return (0.0, 0.0, 0.0)

    def _tour(self, t_ns: int) -> tuple[float, float, float]:
        if self.pose is None:
            return (0.0, 0.0, 0.0)
        s, d = self.scenario, self.robot.drive
        x, y, th = self.pose
        while self.index < len(s.waypoints):
            gx, gy = s.waypoints[self.index]
            dist = math.hypot(gx - x, gy - y)
            if dist > s.tolerance:
                break
            self.reached.append(t_ns)
            self.index += 1
        if self.index >= len(s.waypoints):
            self.done_ns = t_ns
            return (0.0, 0.0, 0.0)
        err = math.atan2(gy - y, gx - x) - th
        err = wrap_angle(err)
        wmax = min(s.turn_rate, d.max_wz)
        w = max(-wmax, min(wmax, 1.5 * err))
        if abs(err) > 0.35:
            return (0.0, 0.0, w)
        v = min(s.speed, d.max_vx, 0.8 * dist + 0.05) * math.cos(err)
        return (v, 0.0, w)
