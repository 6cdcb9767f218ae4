"""DWB's parameters (``dwb_core::DWBLocalPlanner``): the planner's, its kinematics and trajectory generator's, its critics'.

All of DWB's parameters sit flat in the controller's section, as Nav2 declares them: the planner's
own (``critics``, ``prune_plan``, ...), the kinematics (``max_vel_x``, ``acc_lim_theta``, ...), the
trajectory generator's (``sim_time``, ``vx_samples``, ...), and each critic's under its name, written
either ``PathAlign.scale: 32.0`` or as a ``PathAlign:`` sub-section. A critic's class is its name
(or its ``<name>.class``) with ``Critic`` appended and ``dwb_critics::`` (or the first of
``default_critic_namespaces``) prefixed, as DWB resolves it.

Every velocity and acceleration limit defaults to 0.0 in Nav2; a file that leaves one the robot
needs at 0 makes DWB find no trajectory, so ``kinematics_problems`` names those keys and the reader
reports them as errors.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, ClassVar

from navlog.replay.config import suggest
from navlog.replay.limits import MAX_DWB_SAMPLES, MAX_SIM_TIME_S, MIN_GRANULARITY, budget
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import ERROR, WARNING, SectionReader, param

STANDARD_GENERATOR = "dwb_plugins::StandardTrajectoryGenerator"
LIMITED_ACCEL_GENERATOR = "dwb_plugins::LimitedAccelGenerator"


# ---------------------------------------------------------------- critics


@dataclass(frozen=True)
class CriticParams:
    """What every critic reads: its ``scale`` (the weight of its score in the total)."""

    scale: float = 1.0
    CLASS: ClassVar[str] = ""


@dataclass(frozen=True)
class BaseObstacleParams(CriticParams):
    """``BaseObstacleCritic``: the cost of the cell under each pose; the last pose's, or their sum."""

    sum_scores: bool = False
    CLASS: ClassVar[str] = "dwb_critics::BaseObstacleCritic"


@dataclass(frozen=True)
class ObstacleFootprintParams(BaseObstacleParams):
    """``ObstacleFootprintCritic``: the highest cost along the footprint's outline at each pose."""

    CLASS: ClassVar[str] = "dwb_critics::ObstacleFootprintCritic"


@dataclass(frozen=True)
class MapGridParams(CriticParams):
    """A map-grid critic: grid distances (cells) from the plan, aggregated over the poses."""

    aggregation_type: str = param("last", choices=("last", "sum", "product"))


@dataclass(frozen=True)
class PathDistParams(MapGridParams):
    CLASS: ClassVar[str] = "dwb_critics::PathDistCritic"


@dataclass(frozen=True)
class GoalDistParams(MapGridParams):
    CLASS: ClassVar[str] = "dwb_critics::GoalDistCritic"


@dataclass(frozen=True)
class PathAlignParams(MapGridParams):
    forward_point_distance: float = 0.325
    CLASS: ClassVar[str] = "dwb_critics::PathAlignCritic"


@dataclass(frozen=True)
class GoalAlignParams(MapGridParams):
    forward_point_distance: float = 0.325
    CLASS: ClassVar[str] = "dwb_critics::GoalAlignCritic"


@dataclass(frozen=True)
class RotateToGoalParams(CriticParams):
    slowing_factor: float = 5.0
    lookahead_time: float = -1.0
    CLASS: ClassVar[str] = "dwb_critics::RotateToGoalCritic"


@dataclass(frozen=True)
class OscillationParams(CriticParams):
    oscillation_reset_dist: float = 0.05
    oscillation_reset_angle: float = 0.2
    oscillation_reset_time: float = -1.0
    x_only_threshold: float = 0.05
    CLASS: ClassVar[str] = "dwb_critics::OscillationCritic"


@dataclass(frozen=True)
class PreferForwardParams(CriticParams):
    penalty: float = 1.0
    strafe_x: float = 0.1
    strafe_theta: float = 0.2
    theta_scale: float = 10.0
    CLASS: ClassVar[str] = "dwb_critics::PreferForwardCritic"


@dataclass(frozen=True)
class TwirlingParams(CriticParams):
    CLASS: ClassVar[str] = "dwb_critics::TwirlingCritic"


CRITIC_PARAMS: dict[str, type[CriticParams]] = {
    cls.CLASS: cls
    for cls in (
        BaseObstacleParams,
        ObstacleFootprintParams,
        GoalAlignParams,
        GoalDistParams,
        OscillationParams,
        PathAlignParams,
        PathDistParams,
        PreferForwardParams,
        RotateToGoalParams,
        TwirlingParams,
    )
}


def resolve_critic_class(name: str, namespaces: tuple[str, ...]) -> str:
    """DWB's ``resolveCriticClassName``: 'PathAlign' -> 'dwb_critics::PathAlignCritic'."""
    if "Critic" not in name:
        name += "Critic"
    if "::" not in name:
        for ns in namespaces or ("dwb_critics",):
            if f"{ns}::{name}" in CRITIC_PARAMS:
                return f"{ns}::{name}"
    return name


# ---------------------------------------------------------------- the planner


@dataclass(frozen=True)
class DWBParams(PluginParams):
    """``dwb_core::DWBLocalPlanner`` parameters, with Nav2's defaults (kinematic limits all 0.0)."""

    plugin: str = "dwb_core::DWBLocalPlanner"
    # the planner (dwb_local_planner.cpp)
    critics: tuple[str, ...] = ()
    default_critic_namespaces: tuple[str, ...] = ()
    prune_plan: bool = True
    prune_distance: float = param(2.0, ge=0.0)
    forward_prune_distance: float = param(2.0, ge=0.0)
    shorten_transformed_plan: bool = True
    short_circuit_trajectory_evaluation: bool = True
    transform_tolerance: float = param(0.1, ge=0.0)
    debug_trajectory_details: bool = False
    trajectory_generator_name: str = param(STANDARD_GENERATOR, choices=(STANDARD_GENERATOR, LIMITED_ACCEL_GENERATOR))
    # kinematics (kinematic_parameters.cpp): every limit defaults to 0.0
    min_vel_x: float = 0.0
    min_vel_y: float = 0.0
    max_vel_x: float = 0.0
    max_vel_y: float = 0.0
    max_vel_theta: float = param(0.0, ge=0.0)
    min_speed_xy: float = 0.0
    max_speed_xy: float = 0.0
    min_speed_theta: float = 0.0
    acc_lim_x: float = param(0.0, ge=0.0)
    acc_lim_y: float = param(0.0, ge=0.0)
    acc_lim_theta: float = param(0.0, ge=0.0)
    decel_lim_x: float = param(0.0, le=0.0)
    decel_lim_y: float = param(0.0, le=0.0)
    decel_lim_theta: float = param(0.0, le=0.0)
    # the velocity samples (xy_theta_iterator.cpp)
    vx_samples: int = 20  # below 2: 2 (OneDVelocityIterator)
    vy_samples: int = 5
    vtheta_samples: int = 20
    # the trajectory generator (standard_traj_generator.cpp, limited_accel_generator.cpp)
    sim_time: float = param(1.7, gt=0.0, le=MAX_SIM_TIME_S)
    discretize_by_time: bool = False
    time_granularity: float = param(0.5, ge=MIN_GRANULARITY)
    linear_granularity: float = param(0.5, ge=MIN_GRANULARITY)
    angular_granularity: float = param(0.025, ge=MIN_GRANULARITY)
    include_last_point: bool = True
    limit_vel_cmd_in_traj: bool = False
    sim_period: float = param(0.0, ge=0.0)  # LimitedAccelGenerator; 0: 1 / controller_frequency
    # read by RotateToGoal at the plugin's level
    xy_goal_tolerance: float = param(0.25, ge=0.0)
    trans_stopped_velocity: float = param(0.25, ge=0.0)
    # each critic's parameters by its name in ``critics``
    critic_params: dict[str, CriticParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "transform_tolerance",
        "debug_trajectory_details",
        "publish_evaluation",
        "publish_global_plan",
        "publish_transformed_plan",
        "publish_local_plan",
        "publish_trajectories",
        "publish_cost_grid_pc",
        "marker_lifetime",
    )

    def __post_init__(self) -> None:
        samples = max(2, self.vx_samples) * max(2, self.vy_samples) * max(2, self.vtheta_samples)
        what = (
            f"vx_samples x vy_samples x vtheta_samples ({self.vx_samples} x {self.vy_samples} x {self.vtheta_samples})"
        )
        budget("vx_samples", what, samples, MAX_DWB_SAMPLES, " trajectories")

    @classmethod
    def read_loaded(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> DWBParams:
        """The planner's parameters and, for each name in ``critics``, its critic's (flat or nested keys)."""
        own: dict[str, Any] = {}
        by_critic: dict[str, dict[str, Any]] = {}
        for key, value in (section or {}).items() if isinstance(section, dict) else ():
            key = str(key)
            if isinstance(value, dict):
                by_critic.setdefault(key, {}).update(value)
            elif "." in key:
                name, sub = key.split(".", 1)
                by_critic.setdefault(name, {})[sub] = value
            else:
                own[key] = value
        obj: DWBParams = r.read(cls, own, path, extra={"plugin": plugin})
        if not own and not by_critic:  # the controller server's default plugin, not configured by this file
            r.add(
                WARNING,
                path,
                "no DWB parameters: Nav2's default controller would fail to start (no critics, every limit 0.0)",
            )
            return obj
        if "critics" not in own:
            r.add(ERROR, path, "DWB needs 'critics' (e.g. [RotateToGoal, Oscillation, BaseObstacle, GoalAlign, ...])")
        for key, message in kinematics_problems(obj):
            r.add(ERROR, path + (key,), message)
        critic_params: dict[str, CriticParams] = {}
        for name in obj.critics:
            raw = dict(by_critic.get(name, {}))
            given = raw.pop("class", name)
            klass = resolve_critic_class(str(given), obj.default_critic_namespaces)
            pcls = CRITIC_PARAMS.get(klass)
            if pcls is None:
                known = [k.split("::")[-1].removesuffix("Critic") for k in CRITIC_PARAMS]
                r.add(
                    ERROR,
                    path + ("critics",),
                    f"unknown DWB critic '{given}' (class {klass}){suggest(str(given), known)}; Nav2 fails to load it",
                )
                continue
            if isinstance(raw.get("aggregation_type"), str):
                raw["aggregation_type"] = raw["aggregation_type"].lower()  # DWB lower-cases it
            critic_params[name] = r.read(pcls, raw, path + (name,))
        for name in by_critic:
            if name not in obj.critics:
                r.add(
                    WARNING,
                    path + (name,),
                    f"'{name}' is not in critics: DWB ignores its parameters{suggest(name, obj.critics)}",
                )
        return dataclasses.replace(obj, critic_params=critic_params)


# the limits without which DWB cannot drive a differential robot, with Nav2's Humble bringup values
_NEEDED = {
    "max_vel_x": 0.26,
    "max_speed_xy": 0.26,
    "max_vel_theta": 1.0,
    "acc_lim_x": 2.5,
    "acc_lim_theta": 3.2,
    "decel_lim_x": -2.5,
    "decel_lim_theta": -3.2,
}


def kinematics_problems(p: DWBParams) -> list[tuple[str, str]]:
    """(key, message) for each limit left at a value with which DWB cannot move the robot."""
    out = []
    for key, example in _NEEDED.items():
        value = getattr(p, key)
        if value * example > 0.0:  # the sign the limit needs
            continue
        if key == "max_vel_x" and p.min_vel_x < 0.0:  # a robot that only reverses
            continue
        if key == "max_speed_xy" and value < 0.0:  # negative: no speed limit
            continue
        out.append(
            (
                key,
                f"{key} is {value} (Nav2's default for every DWB limit is 0.0): DWB would find no trajectory "
                f"and the robot would not move; set it, e.g. {key}: {example} (Nav2's Humble bringup)",
            )
        )
    return out
