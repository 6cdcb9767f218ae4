"""Nav2's behaviour server (``nav2_behaviors``): Spin, BackUp and Wait as pure step functions over sim time.

A behaviour is started with ``start(now_ns, pose)`` and then stepped every 1/``cycle_frequency``
(10 Hz) of sim time with ``step(now_ns, pose, costmap)``; each returns a ``BehaviorStep``: its
status (``running``, ``succeeded``, ``failed`` with the action's error code) and the command to
publish (None: publish nothing, as Wait). As Nav2's ``TimedBehavior``, the first step runs at the
start time. ``pose`` is the robot in the behaviour server's local frame (``odom``); None means no
transform (TF_ERROR).

- ``Spin`` (``spin.cpp``): integrates the yaw travelled; stops when ``|target| - |travelled| < 1e-6``;
  ``w = clamp(sqrt(2 * rotational_acc_lim * remaining), min_rotational_vel, max_rotational_vel)`` with
  the target's sign. Before each command it checks ``cycle_frequency * simulate_ahead_time`` poses
  ahead, 1/``cycle_frequency`` apart, against the local costmap -- with Nav2's quirk: the look-ahead
  stops once the simulated angle reaches the angle *already travelled*, so at the start of a spin it
  checks nothing. Codes: 701 TIMEOUT, 702 TF_ERROR, 703 COLLISION_AHEAD.
- ``BackUp`` (``DriveOnHeading`` with speed and distance forced negative): drives at ``speed`` until
  the straight-line distance from the start reaches ``|dist|``; the look-ahead is limited to the
  distance left. Codes: 711 TIMEOUT, 712 TF_ERROR, 713 INVALID_INPUT, 714 COLLISION_AHEAD.
- ``Wait``: running until ``wait_duration`` of sim time has passed; publishes nothing.

A time allowance > 0 fails the behaviour (TIMEOUT, zero command) once sim time passes start +
allowance. A pose collides when its cell is off the local costmap or its footprint's outline costs
LETHAL or more (Nav2's ``CostmapTopicCollisionChecker``: unknown space, 255, collides too).

``BehaviorServerParams`` / ``read_behavior_server`` read the ``behavior_server`` block.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar, Protocol

from navlog.replay.config import suggest
from navlog.replay.limits import MAX_RATE_HZ
from navlog.replay.nav2.costmap.cost_values import LETHAL
from navlog.replay.nav2.costmap.footprint import footprint_cost, transform_footprint
from navlog.replay.nav2.plugins import normalize_plugin
from navlog.replay.nav2.schema import ERROR, NOTE, SectionReader, param

Pose2D = tuple[float, float, float]
Twist2D = tuple[float, float, float]

RUNNING = "running"
SUCCEEDED = "succeeded"
FAILED = "failed"
ZERO: Twist2D = (0.0, 0.0, 0.0)

# nav2_msgs/action/Spin and BackUp result codes
SPIN_TIMEOUT, SPIN_TF_ERROR, SPIN_COLLISION_AHEAD = 701, 702, 703
BACKUP_TIMEOUT, BACKUP_TF_ERROR, BACKUP_INVALID_INPUT, BACKUP_COLLISION_AHEAD = 711, 712, 713, 714

# behaviour plugin types the behavior_server may list (Humble spells them nav2_behaviors/Spin)
BEHAVIOR_PLUGINS = (
    "nav2_behaviors::Spin",
    "nav2_behaviors::BackUp",
    "nav2_behaviors::DriveOnHeading",
    "nav2_behaviors::Wait",
    "nav2_behaviors::AssistedTeleop",
)
RUN_BY_NAVLOG = ("nav2_behaviors::Spin", "nav2_behaviors::BackUp", "nav2_behaviors::Wait")


@dataclass(frozen=True)
class BehaviorServerParams:
    """``behavior_server`` node parameters (Jazzy names; Humble's ``global_frame`` was the local frame)."""

    cycle_frequency: float = param(10.0, gt=0.0, le=MAX_RATE_HZ)
    local_frame: str = "odom"
    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    transform_tolerance: float = param(0.1, ge=0.0)
    simulate_ahead_time: float = param(2.0, ge=0.0)
    max_rotational_vel: float = param(1.0, ge=0.0)
    min_rotational_vel: float = param(0.4, ge=0.0)
    rotational_acc_lim: float = param(3.2, gt=0.0)
    behavior_plugins: tuple[str, ...] = ("spin", "backup", "drive_on_heading", "assisted_teleop", "wait")
    use_sim_time: bool = False
    behaviors: dict[str, str] = field(default_factory=dict)  # listed name -> plugin type
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "local_costmap_topic",
        "global_costmap_topic",
        "local_footprint_topic",
        "global_footprint_topic",
        "costmap_topic",
        "footprint_topic",
        "use_sim_time",
        "enable_stamped_cmd_vel",
        "introspection_mode",
    )


def read_behavior_server(r: SectionReader, params: dict, path: tuple) -> BehaviorServerParams:
    """The node's parameters and its listed behaviours' plugin types (unknown types: did-you-mean)."""
    names = params.get("behavior_plugins", list(BehaviorServerParams.behavior_plugins))
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    behaviors: dict[str, str] = {}
    # a list holding anything but names is reported by the read of behavior_plugins below
    for name in names if isinstance(names, list) and all(isinstance(n, str) for n in names) else []:
        sec = params.get(name)
        if not isinstance(sec, dict) or not isinstance(sec.get("plugin"), str):
            r.add(ERROR, path + ("behavior_plugins",), f"behaviour '{name}' is listed but has no '{name}: plugin:'")
            continue
        ptype = normalize_plugin(sec["plugin"])
        if ptype not in BEHAVIOR_PLUGINS:
            r.add(
                ERROR,
                path + (name, "plugin"),
                f"unknown behaviour plugin '{sec['plugin']}'{suggest(ptype, BEHAVIOR_PLUGINS)}",
            )
            continue
        if ptype not in RUN_BY_NAVLOG:
            r.add(NOTE, path + (name, "plugin"), f"behaviour plugin '{ptype}' is read, not run by navlog")
        behaviors[name] = ptype
    humble_local = "global_frame" in params and "local_frame" not in params
    obj = r.read(BehaviorServerParams, params, path, sections=sections, extra={"behaviors": behaviors})
    if humble_local:  # Humble's behaviour server calls its local frame global_frame (default odom)
        r.add(NOTE, path + ("global_frame",), "read as the local frame, as Humble's behaviour server does")
        obj = BehaviorServerParams(**{**obj.__dict__, "local_frame": obj.global_frame})
    return obj


@dataclass
class BehaviorStep:
    """One behaviour cycle: its status, the command to publish (None: nothing) and the error code."""

    status: str
    cmd: Twist2D | None
    code: int = 0
    message: str = ""


class LocalCostmap(Protocol):
    """What the collision check reads of the local costmap (a ``CostmapGrid``)."""

    costs: object
    footprint: list[tuple[float, float]]
    resolution: float
    origin_x: float
    origin_y: float

    def world_to_cell(self, x: float, y: float) -> tuple[int, int]: ...

    def contains(self, mx: int, my: int) -> bool: ...


def collision_free(cm: LocalCostmap, x: float, y: float, yaw: float) -> bool:
    """Nav2's ``CostmapTopicCollisionChecker::isCollisionFree``: on the grid and footprint cost < LETHAL."""
    if not cm.contains(*cm.world_to_cell(x, y)):
        return False
    poly = transform_footprint(cm.footprint, x, y, yaw)
    return footprint_cost(cm.costs, poly, cm.origin_x, cm.origin_y, cm.resolution) < LETHAL  # type: ignore[arg-type]


class Behavior:
    """A timed behaviour: ``start`` then ``step`` every cycle (see the module docstring)."""

    name = "behavior"
    timeout_code = 0
    tf_code = 0

    def __init__(self, params: BehaviorServerParams, time_allowance: float) -> None:
        self.params = params
        self.allowance_ns = int(round(time_allowance * 1e9))
        self.end_ns = 0

    def start(self, now_ns: int, pose: Pose2D | None) -> BehaviorStep | None:
        """None when started, else the failed step (no pose, bad input)."""
        self.end_ns = now_ns + self.allowance_ns
        if pose is None:
            return BehaviorStep(FAILED, None, self.tf_code, "Initial robot pose is not available.")
        return self._start(pose)

    def _start(self, pose: Pose2D) -> BehaviorStep | None:
        return None

    def step(self, now_ns: int, pose: Pose2D | None, costmap: LocalCostmap | None) -> BehaviorStep:
        if now_ns > self.end_ns and self.allowance_ns > 0:
            return BehaviorStep(
                FAILED, ZERO, self.timeout_code, f"Exceeded time allowance before reaching the {self.name} goal"
            )
        if pose is None:
            return BehaviorStep(FAILED, None, self.tf_code, "Current robot pose is not available.")
        return self._step(now_ns, pose, costmap)

    def _step(self, now_ns: int, pose: Pose2D, costmap: LocalCostmap | None) -> BehaviorStep:
        raise NotImplementedError

    def _look_ahead(self, costmap: LocalCostmap | None, poses: list[Pose2D]) -> bool:
        return costmap is None or all(collision_free(costmap, *p) for p in poses)

    @property
    def _steps(self) -> int:
        return int(self.params.cycle_frequency * self.params.simulate_ahead_time)


class Spin(Behavior):
    """``nav2_behaviors::Spin`` by ``target_yaw`` radians (sign: direction)."""

    name = "Spin"
    timeout_code, tf_code = SPIN_TIMEOUT, SPIN_TF_ERROR

    def __init__(self, params: BehaviorServerParams, target_yaw: float = 1.57, time_allowance: float = 10.0) -> None:
        super().__init__(params, time_allowance)
        self.target_yaw = target_yaw
        self.prev_yaw = 0.0
        self.travelled = 0.0

    def _start(self, pose: Pose2D) -> BehaviorStep | None:
        self.prev_yaw, self.travelled = pose[2], 0.0
        return None

    def _step(self, now_ns: int, pose: Pose2D, costmap: LocalCostmap | None) -> BehaviorStep:
        p = self.params
        delta = pose[2] - self.prev_yaw
        if abs(delta) > math.pi:
            delta = math.copysign(2 * math.pi - abs(delta), self.prev_yaw)
        self.travelled += delta
        self.prev_yaw = pose[2]
        remaining = abs(self.target_yaw) - abs(self.travelled)
        if remaining < 1e-6:
            return BehaviorStep(SUCCEEDED, ZERO)
        vel = min(max(math.sqrt(2 * p.rotational_acc_lim * remaining), p.min_rotational_vel), p.max_rotational_vel)
        wz = math.copysign(vel, self.target_yaw)
        ahead = []
        for k in range(self._steps):
            change = wz * (k / p.cycle_frequency)
            if abs(self.travelled) - abs(change) <= 0.0:  # Nav2's quirk: compares with the angle travelled
                break
            ahead.append((pose[0], pose[1], pose[2] + change))
        if not self._look_ahead(costmap, ahead):
            return BehaviorStep(FAILED, ZERO, SPIN_COLLISION_AHEAD, "Collision Ahead - Exiting Spin")
        return BehaviorStep(RUNNING, (0.0, 0.0, wz))


class BackUp(Behavior):
    """``nav2_behaviors::BackUp``: ``dist`` metres backwards at ``speed`` m/s (both taken as negative)."""

    name = "BackUp"
    timeout_code, tf_code = BACKUP_TIMEOUT, BACKUP_TF_ERROR

    def __init__(
        self, params: BehaviorServerParams, dist: float = 0.30, speed: float = 0.15, time_allowance: float = 10.0
    ) -> None:
        super().__init__(params, time_allowance)
        self.command_x = -abs(dist)
        self.speed = -abs(speed)
        self.start_pose: Pose2D = (0.0, 0.0, 0.0)

    def _start(self, pose: Pose2D) -> BehaviorStep | None:
        self.start_pose = pose
        return None

    def _step(self, now_ns: int, pose: Pose2D, costmap: LocalCostmap | None) -> BehaviorStep:
        p = self.params
        distance = math.hypot(self.start_pose[0] - pose[0], self.start_pose[1] - pose[1])
        if distance >= abs(self.command_x):
            return BehaviorStep(SUCCEEDED, ZERO)
        left = abs(self.command_x) - distance
        c, s = math.cos(pose[2]), math.sin(pose[2])
        ahead = []
        for k in range(self._steps):
            change = self.speed * (k / p.cycle_frequency)
            if left - abs(change) <= 0.0:
                break
            ahead.append((pose[0] + change * c, pose[1] + change * s, pose[2]))
        if not self._look_ahead(costmap, ahead):
            return BehaviorStep(FAILED, ZERO, BACKUP_COLLISION_AHEAD, "Collision Ahead - Exiting DriveOnHeading")
        return BehaviorStep(RUNNING, (self.speed, 0.0, 0.0))


class Wait(Behavior):
    """``nav2_behaviors::Wait`` for ``duration`` seconds of sim time; publishes no command."""

    name = "Wait"

    def __init__(self, params: BehaviorServerParams, duration: float = 5.0) -> None:
        super().__init__(params, 0.0)
        self.wait_ns = int(round(duration * 1e9))
        self.until_ns = 0

    def start(self, now_ns: int, pose: Pose2D | None) -> BehaviorStep | None:
        self.until_ns = now_ns + self.wait_ns
        return None

    def step(self, now_ns: int, pose: Pose2D | None, costmap: LocalCostmap | None) -> BehaviorStep:
        return BehaviorStep(RUNNING if self.until_ns - now_ns > 0 else SUCCEEDED, None)
