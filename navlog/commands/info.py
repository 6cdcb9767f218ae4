"""navlog info LOG: duration, topics, types, counts and rates of any log."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "info",
        help="summarise a log (navlog MCAP, rosbag2 folder, .mcap or .db3)",
        description="Print a summary like `ros2 bag info`: duration, start and end, size, compression, "
        "topics with type, count and rate, and navlog metadata. Topics of unknown types are listed as such.",
        epilog="examples:\n  navlog info run.mcap\n  navlog info my_bag/ --json\n"
        "  navlog info run.mcap.part --recover   # a recording killed mid-write",
    )
    p.add_argument("log", help="a .mcap file, a .db3 file or a rosbag2 folder")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--recover", action="store_true", help="summarise the readable part of a truncated file")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.analysis.info import format_info, summarize
    from navlog.replay.io import json_text, open_log

    with open_log(args.log, recover=args.recover) as reader:
        info = summarize(reader)
    print(json_text.dumps(info, indent=2) if args.json else format_info(info))
    return 0
