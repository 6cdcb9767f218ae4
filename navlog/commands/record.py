"""navlog record: run the MuJoCo simulation headless and record every topic to MCAP."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
from collections.abc import Iterator
from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "record",
        help="simulate a robot in a world and record every topic to MCAP",
        description="Run the MuJoCo simulation headless, faster than real time, and write a ROS 2 MCAP log "
        "(scan, 3D LiDAR, IMU, odometry, ground truth, TF, clock, cmd_vel). Worlds, robots and scenarios are "
        "YAML files in config/worlds, config/robots and config/scenarios (a name or a path).",
        epilog="example:\n  navlog record --world indoor_room --robot go2 --scenario mapping --seed 7 -o run.mcap",
    )
    p.add_argument("--world", default="indoor_room", help="world name or YAML path (default: indoor_room)")
    p.add_argument("--robot", default="go2", help="robot name or YAML path (default: go2)")
    p.add_argument("--scenario", default="mapping", help="scenario name or YAML path (default: mapping)")
    p.add_argument("--seed", type=int, default=0, help="seed of all sensor and odometry noise (default: 0)")
    p.add_argument("--no-noise", action="store_true", help="switch every sensor and odometry noise off")
    p.add_argument("-o", "--output", required=True, type=Path, help="output .mcap file")
    p.add_argument("--force", action="store_true", help="overwrite the output if it exists")
    p.add_argument(
        "--pipeline",
        help="also run a replay pipeline's nodes live (e.g. mapping) and record their outputs; the safety "
        "filters sit between the scenario and the robot (the scenario then publishes /cmd_vel_nav)",
    )
    p.add_argument(
        "--params",
        type=Path,
        help="the pipeline's parameter YAML, or the Nav2 file of a pipeline that takes one (planner, safety)",
    )
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a pipeline parameter")
    p.set_defaults(func=run)


@contextlib.contextmanager
def stop_on_ctrl_c() -> Iterator[threading.Event]:
    """An event that Ctrl-C (SIGINT) sets while the block runs, instead of raising KeyboardInterrupt.

    ``record(..., stop=event)`` then ends the run cleanly; a second Ctrl-C raises KeyboardInterrupt
    at once. The previous handler is restored after.
    """
    stop = threading.Event()

    def on_sigint(signum: int, frame: object) -> None:
        if stop.is_set():
            raise KeyboardInterrupt
        stop.set()
        os.write(2, b"\nnavlog: stopping cleanly (Ctrl-C again to stop at once)\n")

    previous = signal.signal(signal.SIGINT, on_sigint)
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, previous)


def run(args) -> int:
    from navlog.recorder.record import format_summary, prepare, record

    setup = prepare(args.world, args.robot, args.scenario, seed=args.seed, noise=not args.no_noise)
    pipe = None
    if args.pipeline:
        from navlog.replay.session import load_pipeline_module, pipeline_params

        params = pipeline_params(args.pipeline, args.params, overrides=args.set)
        pipe = load_pipeline_module(args.pipeline).build(params, setup.topics())
    elif args.params is not None:
        from navlog.errors import ConfigError

        raise ConfigError("--params needs --pipeline: the parameters of which pipeline?")
    with stop_on_ctrl_c() as stop:
        res = record(setup, args.output, force=args.force, progress=not args.quiet, pipeline=pipe, stop=stop)
    print(format_summary(res))
    return 130 if res.interrupted else 0
