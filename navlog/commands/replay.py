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
        "  navlog replay bag_dir --pipeline mapping --remap /scan=/stable_scan -o out/",
    )
    p.add_argument("log", type=Path, help="the log to replay")
    p.add_argument("--pipeline", required=True, help=f"pipeline name ({', '.join(pipeline_names())})")
    p.add_argument("-o", "--output", type=Path, required=True, help="output folder")
    p.add_argument("--params", type=Path, help="pipeline parameter YAML (default: config/pipelines/NAME.yaml)")
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
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.replay.session import format_summary, parse_remaps, pipeline_params, run_replay

    params = pipeline_params(args.pipeline, args.params, args.set)
    res = run_replay(
        args.log,
        args.pipeline,
        args.output,
        params=params,
        remap=parse_remaps(args.remap),
        recover=args.recover,
        force=args.force,
        progress=not args.quiet,
    )
    print(format_summary(args.log, res))
    return 0
