"""navlog check LOG: is this log fit to replay? Integrity, topics, rates, gaps, stamps, TF coverage."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "check",
        help="check that a log is fit to replay (topics, rates, gaps, stamps, TF, integrity)",
        description="Read a log once and check it: file integrity (a truncated MCAP is reported with its "
        "readable span), message types, required topics, rates (against --rate or the topic's median rate), "
        "gaps beyond k x the median period, log times and header stamps only going forward, NaN/inf in scans, "
        "and TF coverage of frame chains. Each check is PASS, WARN or FAIL with a message naming the topic "
        "and a fix. Exit status: 0 when nothing FAILs, 1 when a check FAILs, 2 when the log cannot be read.",
        epilog="examples:\n"
        "  navlog check run.mcap\n"
        "  navlog check run.mcap --pipeline mapping --frames map:base_link --json\n"
        "  navlog check bag/ --require /scan --require /odom --rate /scan=10 --frames odom:base_footprint",
    )
    p.add_argument("log", help="a .mcap file, a .db3 file or a rosbag2 folder")
    p.add_argument("--pipeline", metavar="NAME", help="require the topics this replay pipeline reads")
    p.add_argument(
        "--require", action="append", default=[], metavar="TOPIC", help="a topic that must be present (repeatable)"
    )
    p.add_argument(
        "--frames",
        action="append",
        default=[],
        metavar="TARGET:SOURCE",
        help="a TF chain that must be available, e.g. map:base_link (repeatable)",
    )
    p.add_argument(
        "--rate", action="append", default=[], metavar="TOPIC=HZ", help="a topic's expected rate (repeatable)"
    )
    p.add_argument("--rate-tolerance", type=float, default=0.10, metavar="SHARE", help="allowed rate deviation (0.10)")
    p.add_argument(
        "--gap-factor", type=float, default=5.0, metavar="K", help="a gap is longer than K median periods (5)"
    )
    p.add_argument("--max-gap", type=float, default=1.0, metavar="S", help="a gap this long fails the check (1.0 s)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.analysis.check import CheckOptions, check_log, format_check, parse_frames, parse_rates

    options = CheckOptions(rate_tolerance=args.rate_tolerance, gap_factor=args.gap_factor, max_gap_s=args.max_gap)
    result = check_log(
        args.log,
        require=args.require,
        rates=parse_rates(args.rate),
        frames=parse_frames(args.frames),
        pipeline=args.pipeline,
        options=options,
    )
    print(result.to_json(), end="") if args.json else print(format_check(result))
    return 1 if result.failed else 0
