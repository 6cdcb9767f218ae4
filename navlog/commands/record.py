"""navlog record: run the MuJoCo simulation headless and record every topic to MCAP."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

from navlog.errors import Terminated


def register(sub) -> None:
    p = sub.add_parser(
        "record",
        help="simulate a robot in a world and record every topic to MCAP",
        description="Run the MuJoCo simulation headless, faster than real time, and write a ROS 2 MCAP log "
        "(scan, 3D LiDAR, IMU, odometry, ground truth, TF, clock, cmd_vel). Worlds, robots and scenarios are "
        "YAML files in config/worlds, config/robots and config/scenarios (a name or a path).",
        epilog="examples:\n  navlog record --world indoor_room --robot go2 --scenario mapping --seed 7 -o run.mcap\n"
        "  navlog record --scenario nav_tour -o nav.mcap          # Nav2 drives the Go2 through four waypoints\n"
        "  navlog record --scenario nav_tour --params config/nav2/nav_go2_mppi.yaml -o nav_mppi.mcap\n"
        "A run exits 1 when the robot touched something its scenario does not expect (expect_contact: true), "
        "or a navigate scenario's goal failed.",
    )
    p.add_argument(
        "--world",
        help="world name, world YAML, Gazebo SDF world (.sdf, .world, .sdf.xacro) or map_server map YAML "
        "(default: the scenario's world, else indoor_room)",
    )
    p.add_argument(
        "--robot",
        help="robot name, YAML path, or description file: .urdf, .sdf, .urdf.xacro, .sdf.xacro "
        "(default: the scenario's robot, else go2)",
    )
    p.add_argument(
        "--robot-arg",
        action="append",
        default=[],
        metavar="NAME:=VALUE",
        help="a xacro argument of the robot's description file, as ros2 launch takes it (repeatable)",
    )
    p.add_argument(
        "--package-path",
        action="append",
        default=[],
        type=Path,
        metavar="DIR",
        help="a folder holding ROS packages (folders with a package.xml), searched for package:// and $(find) "
        "before ROS_PACKAGE_PATH and AMENT_PREFIX_PATH (repeatable)",
    )
    p.add_argument(
        "--drive",
        choices=("diff_drive", "omni"),
        help="the drive of a description file that declares no drive plugin (diff_drive: its two wheel joints)",
    )
    p.add_argument("--scenario", default="mapping", help="scenario name or YAML path (default: mapping)")
    p.add_argument("--seed", type=int, default=0, help="seed of all sensor and odometry noise (default: 0)")
    p.add_argument("--no-noise", action="store_true", help="switch every sensor and odometry noise off")
    p.add_argument(
        "--localization",
        choices=("perfect", "none", "amcl"),
        default="perfect",
        help="perfect: map -> odom on /tf is the true correction (default); none: no map -> odom at all, "
        "odom -> base only, as a real robot's log for SLAM (/odom/ground_truth stays, for evaluation); "
        "amcl: Nav2's AMCL runs live on the world's map and publishes map -> odom (navigation runs on it)",
    )
    p.add_argument(
        "--sensors",
        choices=("auto", "worker", "in-process"),
        default="auto",
        help="where the laser and the LiDAR are cast: worker: a process beside the simulation (faster when a "
        "second CPU is free); in-process: in the simulation's process (faster when other jobs hold the other "
        "CPU); auto (default): the worker when the process may use more than one CPU. The log is the same bytes",
    )
    p.add_argument("-o", "--output", required=True, type=Path, help="output .mcap file")
    p.add_argument("--force", action="store_true", help="overwrite the output if it exists")
    add_world_options(p)
    p.add_argument(
        "--pipeline",
        help="also run a replay pipeline's nodes live (e.g. mapping) and record their outputs; the safety "
        "filters sit between the scenario and the robot (the scenario then publishes /cmd_vel_nav)",
    )
    p.add_argument(
        "--params",
        type=Path,
        help="the pipeline's parameter YAML, or the Nav2 file of a pipeline that takes one (planner, safety); "
        "for a navigate scenario without --pipeline: the Nav2 file that replaces the scenario's",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a pipeline parameter (a navigate scenario without --pipeline: a navigation parameter, "
        "e.g. --set velocity_smoother=off)",
    )
    p.set_defaults(func=run)


@contextlib.contextmanager
def stop_on_ctrl_c() -> Iterator[threading.Event]:
    """An event that Ctrl-C (SIGINT) or SIGTERM (a ``timeout``, a CI job cancelled) sets while the block runs,
    instead of raising KeyboardInterrupt; ``stop.signum`` is the signal's number.

    ``record(..., stop=event)`` then ends the run cleanly; a second signal raises KeyboardInterrupt at once.
    The previous handlers are restored after.
    """
    stop = threading.Event()
    stop.signum = 0  # type: ignore[attr-defined]

    def on_signal(signum: int, frame: object) -> None:
        if stop.is_set():
            raise Terminated if signum == signal.SIGTERM else KeyboardInterrupt
        stop.signum = signum  # type: ignore[attr-defined]
        stop.set()
        again = "Ctrl-C" if signum == signal.SIGINT else "the signal"
        os.write(2, f"\nnavlog: stopping cleanly ({again} again to stop at once)\n".encode())

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def robot_args(words: list[str]) -> dict[str, str]:
    """``NAME:=VALUE`` words as a mapping (ConfigError for another form)."""
    from navlog.errors import ConfigError

    out = {}
    for word in words:
        name, sep, value = word.partition(":=")
        if not sep or not name:
            raise ConfigError(f"--robot-arg '{word}': expected NAME:=VALUE")
        out[name] = value
    return out


def add_world_options(p) -> None:
    """The options of a world read from an SDF file or a map (``navlog record``, ``navlog world-map``)."""
    p.add_argument(
        "--resource-path",
        action="append",
        default=[],
        metavar="DIR",
        help="a folder of Gazebo models (model://NAME) or ROS packages (package://PKG) for an SDF world, searched "
        "before GZ_SIM_RESOURCE_PATH, GAZEBO_MODEL_PATH, ROS_PACKAGE_PATH and AMENT_PREFIX_PATH (repeatable)",
    )
    p.add_argument(
        "--wall-height",
        type=float,
        default=None,
        metavar="M",
        help="a map_server map as a world: the height of the walls its occupied cells become (default 2.0)",
    )


def run(args) -> int:
    from navlog.recorder.record import format_summary, prepare, record

    setup = prepare(
        args.world,
        args.robot,
        args.scenario,
        seed=args.seed,
        noise=not args.no_noise,
        localization=args.localization,
        robot_args=robot_args(args.robot_arg),
        package_paths=args.package_path,
        drive=args.drive,
        resource_paths=args.resource_path,
        wall_height=args.wall_height,
    )
    pipe = navigation = None
    if args.pipeline:
        from navlog.replay.pipelines import pipeline_spec
        from navlog.replay.session import pipeline_params

        params = pipeline_params(args.pipeline, args.params, overrides=args.set)
        pipe = pipeline_spec(args.pipeline).build(params, setup.topics())
    elif setup.scenario.kind == "navigate":
        from dataclasses import replace

        from navlog.recorder.navigation import navigation_pipeline

        if args.params is not None:  # the run's one Nav2 file: the navigation's and AMCL's (--localization amcl)
            setup.scenario = replace(setup.scenario, nav2_params=str(args.params))
        navigation = navigation_pipeline(
            setup.scenario,
            setup.seed,
            None,
            args.set,
            command_topic=setup.robot.cmd_topic,
            odometry=setup.robot.odometry,
        )
    elif args.params is not None or args.set:
        from navlog.errors import ConfigError

        raise ConfigError(
            "--params and --set need --pipeline (the parameters of which pipeline?), "
            "or a navigate scenario (its Nav2 file and navigation parameters)"
        )
    with stop_on_ctrl_c() as stop:
        res = record(
            setup,
            args.output,
            force=args.force,
            progress=not args.quiet,
            pipeline=pipe,
            navigation=navigation,
            stop=stop,
            sensor_worker={"auto": None, "worker": True, "in-process": False}[args.sensors],
        )
    print(format_summary(res))
    if res.interrupted:
        return 128 + stop.signum  # type: ignore[attr-defined]  # 130 after Ctrl-C, 143 after SIGTERM
    return 1 if res.failed else 0
