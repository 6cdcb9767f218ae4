"""navlog replay: run a log through a pipeline, deterministically, into maps, PCDs and a manifest."""

from __future__ import annotations

from pathlib import Path

from navlog.replay.pipelines import pipeline_names


def register(sub) -> None:
    p = sub.add_parser(
        "replay",
        help="replay a log through a pipeline (mapping, planner) into maps, PCDs, plans and a manifest",
        description="Stream a log (navlog MCAP, rosbag2 folder, .mcap or .db3) through a pipeline's nodes in "
        "one deterministic order. Writes OUT/replay.mcap (the new outputs), the pipeline's files (mapping: "
        "map.yaml + map.pgm, map.pcd, trajectory.tum) and OUT/manifest.json (input hashes, every parameter, "
        "output hashes, skipped inputs and why). Same inputs and parameters give the same bytes.",
        epilog="examples:\n  navlog replay run.mcap --pipeline mapping -o out/\n"
        "  navlog replay run.mcap --pipeline mapping --set pose_source=odom -o out-odom/\n"
        "  navlog replay bag_dir --pipeline mapping --remap /scan=/stable_scan -o out/\n"
        "  navlog replay bag_dir --pipeline mapping --params mapper_params_online_async.yaml -o slam/\n"
        "  navlog replay nav.mcap --pipeline navigation --set goals=indoor_room_waypoints -o out-nav/\n"
        "  navlog replay logs/ --pipeline mapping -o fleet/ --workers 4\n"
        "  navlog replay 'logs/2026-*.mcap' --list more.txt --pipeline mapping -o fleet/ --retries 1\n"
        "  navlog replay s3://bucket/logs/ --pipeline mapping -o s3://bucket/replays/ --ray auto\n"
        "Several logs (paths, a folder of logs, a quoted glob, --list FILE, fsspec URLs) make a fleet: "
        "OUT/NAME/ per log as above, plus OUT/fleet-summary.{json,csv,md} (one row per log and the totals); "
        "the exit code is 1 when any log failed. A rerun skips logs whose OUT/NAME/manifest.json matches the "
        "inputs and parameters (--force redoes them).",
    )
    p.add_argument(
        "logs",
        nargs="*",
        metavar="LOG",
        help="the log to replay; several logs, a folder of logs, a glob or a URL replay a fleet",
    )
    p.add_argument("--pipeline", required=True, help=f"pipeline name ({', '.join(pipeline_names())})")
    p.add_argument("-o", "--output", type=Path, required=True, help="output folder")
    p.add_argument(
        "--params",
        type=Path,
        help="pipeline parameter YAML (default: config/pipelines/NAME.yaml); a Nav2 file for the pipelines that "
        "run Nav2 nodes; for mapping, slam_toolbox's own file (mapper_params_online_async.yaml) too",
    )
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a parameter (repeatable)")
    p.add_argument(
        "--remap",
        action="append",
        default=[],
        metavar="PIPELINE_TOPIC=LOG_TOPIC",
        help="read another topic (repeatable)",
    )
    p.add_argument("--recover", action="store_true", help="replay the readable part of a truncated log")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    fleet = p.add_argument_group("fleet (several logs)")
    fleet.add_argument("--list", action="append", default=[], metavar="FILE", help="a file naming logs, one a line")
    fleet.add_argument("--workers", type=int, metavar="N", help="worker processes (default: the CPU count)")
    fleet.add_argument(
        "--ray",
        nargs="?",
        const=True,
        default=False,
        metavar="ADDRESS",
        help="run each log as a Ray task: on a local Ray instance, or on the cluster at ADDRESS "
        "(auto, HOST:6379, ray://HOST:10001); needs pip install navlog[fleet]",
    )
    fleet.add_argument("--retries", type=int, default=0, metavar="N", help="rerun a log whose worker died (default: 0)")
    fleet.add_argument("--cpus-per-log", type=float, default=1.0, metavar="N", help="CPUs a Ray task requests")
    fleet.add_argument("--memory-per-log", metavar="SIZE", help="memory a Ray task requests (e.g. 2G, 512M)")
    fleet.add_argument("--no-metrics", action="store_true", help="leave the mapping metrics out of the summary")
    p.set_defaults(func=run)


def _is_fleet(args) -> bool:
    if len(args.logs) != 1 or args.list or args.workers is not None or args.ray:
        return True
    text = args.logs[0]
    if "://" in text or any(c in text for c in "*?["):
        return True
    path = Path(text)
    return path.is_dir() and not (path / "metadata.yaml").is_file()


def _size(text: str | None) -> int | None:
    if text is None:
        return None
    from navlog.errors import ConfigError

    units = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
    number, unit = (text[:-1], text[-1].upper()) if text[-1:].upper() in units else (text, "")
    try:
        return int(float(number) * units.get(unit, 1))
    except ValueError:
        raise ConfigError(f"--memory-per-log {text}: expected a size such as 2G, 512M or 1000000") from None


def _run_fleet(args) -> int:
    from navlog.analysis.fleet.run import format_fleet, replay_fleet
    from navlog.replay.session import parse_remaps, pipeline_params

    logs, ray = list(args.logs), args.ray
    if isinstance(ray, str) and Path(ray).exists():  # `--ray LOG ...`: the log, not a cluster's address
        logs, ray = [ray, *logs], True
    params = pipeline_params(args.pipeline, args.params, args.set)
    res = replay_fleet(
        logs,
        args.pipeline,
        args.output,
        lists=args.list,
        params=params,
        remap=parse_remaps(args.remap),
        recover=args.recover,
        force=args.force,
        workers=args.workers,
        ray=ray,
        retries=args.retries,
        metrics=not args.no_metrics,
        cpus_per_log=args.cpus_per_log,
        memory_per_log=_size(args.memory_per_log),
        progress=not args.quiet,
    )
    print(format_fleet(res))
    return 1 if res.failed else 0


def run(args) -> int:
    if _is_fleet(args):
        return _run_fleet(args)
    from navlog.replay.io.atomic import check_not_input
    from navlog.replay.session import format_summary, parse_remaps, pipeline_params, run_replay

    log = Path(args.logs[0])
    check_not_input(args.output, [args.params], folder=True)  # (the log: run_replay's own check)
    params = pipeline_params(args.pipeline, args.params, args.set)
    res = run_replay(
        log,
        args.pipeline,
        args.output,
        params=params,
        remap=parse_remaps(args.remap),
        recover=args.recover,
        force=args.force,
        progress=not args.quiet,
    )
    print(format_summary(log, res))
    return 0
