"""Nav2's controller server: its parameters with its controllers', goal checkers' and progress checkers'.

``read_controller_server`` reads the ``controller_server`` block with each plugin listed in
``controller_plugins``, ``goal_checker_plugins`` and ``progress_checker_plugins`` as its registered
type (Humble's ``progress_checker_plugin`` is read and warned about).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from navlog.replay.limits import MAX_RATE_HZ
from navlog.replay.nav2.controllers.checkers import GoalCheckerParams, ProgressCheckerParams
from navlog.replay.nav2.controllers.registry import CONTROLLERS, GOAL_CHECKERS, PROGRESS_CHECKERS, ControllerParams
from navlog.replay.nav2.plugins import read_plugin_list
from navlog.replay.nav2.schema import NOTE, WARNING, SectionReader, param


@dataclass(frozen=True)
class ControllerServerParams:
    """``controller_server`` node parameters with its controllers' and checkers', by name."""

    controller_frequency: float = param(20.0, gt=0.0, le=MAX_RATE_HZ)
    costmap_update_timeout: float = param(0.3, ge=0.0)
    min_x_velocity_threshold: float = param(0.0001, ge=0.0)
    min_y_velocity_threshold: float = param(0.0001, ge=0.0)
    min_theta_velocity_threshold: float = param(0.0001, ge=0.0)
    failure_tolerance: float = 0.0
    progress_checker_plugins: tuple[str, ...] = ("progress_checker",)
    goal_checker_plugins: tuple[str, ...] = ("goal_checker",)
    controller_plugins: tuple[str, ...] = ("FollowPath",)
    use_realtime_priority: bool = False
    odom_topic: str = "odom"
    speed_limit_topic: str = "speed_limit"
    enable_stamped_cmd_vel: bool = False
    use_sim_time: bool = False
    controllers: dict[str, ControllerParams] = field(default_factory=dict)
    goal_checkers: dict[str, GoalCheckerParams] = field(default_factory=dict)
    progress_checkers: dict[str, ProgressCheckerParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "costmap_update_timeout",
        "use_realtime_priority",
        "speed_limit_topic",
        "enable_stamped_cmd_vel",
        "use_sim_time",
        "failure_tolerance",
        "publish_zero_velocity",
        "introspection_mode",
        "path_handler_plugins",  # Nav2 after Jazzy: its plugins' sections are read and noted
    )


def read_controller_server(r: SectionReader, params: dict, path: tuple) -> ControllerServerParams:
    """The node's parameters, its controllers and checkers; sections listed nowhere are warned about."""
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    controllers = read_plugin_list(
        r, params, path, "controller_plugins", CONTROLLERS, ["FollowPath"], "dwb_core::DWBLocalPlanner"
    )
    pc_key = "progress_checker_plugins" if "progress_checker_plugins" in params else "progress_checker_plugin"
    pc_names = params.get(pc_key, ["progress_checker"])
    if isinstance(pc_names, str):
        pc_names = [pc_names]
    # as for controllers, a default-named checker without a section (or without ``plugin``) is Nav2's default type
    goal_checkers: dict[str, GoalCheckerParams] = read_plugin_list(
        r, params, path, "goal_checker_plugins", GOAL_CHECKERS, ["goal_checker"], "nav2_controller::SimpleGoalChecker"
    )
    progress_checkers: dict[str, ProgressCheckerParams] = read_plugin_list(
        r, params, path, pc_key, PROGRESS_CHECKERS, ["progress_checker"], "nav2_controller::SimpleProgressChecker"
    )
    known = set(controllers) | set(goal_checkers) | set(progress_checkers)
    listed = set()
    handlers = params.get("path_handler_plugins", [])
    for name in handlers if isinstance(handlers, list) else []:
        if isinstance(name, str) and isinstance(params.get(name), dict):
            plugin = params[name].get("plugin", "?")
            r.add(
                NOTE,
                path + (name,),
                f"path handler '{plugin}' is read, not implemented by navlog (its controller prunes the path)",
            )
    for key in (
        "controller_plugins",
        "goal_checker_plugins",
        "progress_checker_plugins",
        "progress_checker_plugin",
        "path_handler_plugins",
    ):
        v = params.get(key)
        listed |= {v} if isinstance(v, str) else {x for x in v if isinstance(x, str)} if isinstance(v, list) else set()
    for s in sections:
        if s not in known and s not in listed:
            r.add(WARNING, path + (s,), f"section '{s}' is not listed in any *_plugins: Nav2 ignores it")
    skip = ("progress_checker_plugin",) if pc_key == "progress_checker_plugin" else ()
    if skip and r.distro != "humble":
        r.add(
            WARNING,
            path + ("progress_checker_plugin",),
            "'progress_checker_plugin' is the Humble name; Jazzy reads 'progress_checker_plugins' (a list); "
            "for a Humble file, check it with --distro humble",
        )
    if r.distro == "humble" and pc_key == "progress_checker_plugins":
        r.add(
            WARNING,
            path + ("progress_checker_plugins",),
            "'progress_checker_plugins' is the Jazzy name; Humble reads 'progress_checker_plugin' (one name) "
            "and ignores it",
        )
    return r.read(
        ControllerServerParams,
        params,
        path,
        sections=sections,
        skip=skip,
        extra={
            "controllers": controllers,
            "goal_checkers": goal_checkers,
            "progress_checkers": progress_checkers,
            "progress_checker_plugins": tuple(pc_names) if isinstance(pc_names, list) else ("progress_checker",),
        },
    )
