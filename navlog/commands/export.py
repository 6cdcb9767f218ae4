"""navlog export LOG: a ROS 2 bag (rosbag2, sqlite3 or MCAP) or a TUM trajectory."""

from __future__ import annotations

from navlog.commands import skipped_note
from navlog.errors import NavlogError


def register(sub) -> None:
    p = sub.add_parser(
        "export",
        help="export a log as a ROS 2 bag (rosbag2) or a TUM trajectory",
        description="--to rosbag2 copies messages byte for byte into a rosbag2 folder that `ros2 bag play`, "
        "Foxglove and rosbags read (metadata version 8 for --distro humble, 9 for jazzy; /tf_static and /map "
        "transient-local). --to tum writes `t x y z qx qy qz qw` lines for evo and KISS-ICP from an Odometry, "
        "PoseStamped or Path topic (--topic) or a TF chain (--tf map:base_link).",
        epilog="examples:\n  navlog export run.mcap --to rosbag2 -o run_bag/ --distro jazzy\n"
        "  navlog export run.mcap --to rosbag2 --storage mcap --topics /scan /tf /tf_static /odom -o scan_bag/\n"
        "  navlog export run.mcap --to tum --topic /odom/ground_truth -o gt.tum\n"
        "  navlog export my_bag/ --to tum --tf map:base_link -o slam.tum",
    )
    p.add_argument("log", help="a .mcap file, a .db3 file or a rosbag2 folder")
    p.add_argument("--to", required=True, choices=("rosbag2", "tum"), help="output kind")
    p.add_argument("-o", "--output", required=True, help="rosbag2: a new folder; tum: a file")
    p.add_argument(
        "--storage", default="sqlite3", choices=("sqlite3", "mcap"), help="rosbag2 storage (default sqlite3)"
    )
    p.add_argument(
        "--distro",
        default="humble",
        choices=("humble", "jazzy"),
        help="ROS 2 distribution that reads the bag (default humble)",
    )
    p.add_argument(
        "--topics",
        nargs="+",
        default=[],
        metavar="TOPIC",
        help="rosbag2: topics (names or patterns like '/cmd_vel*') to export; default all",
    )
    p.add_argument("--topic", help="tum: the pose topic (Odometry, PoseStamped, PoseWithCovarianceStamped, Path)")
    p.add_argument(
        "--tf", metavar="TARGET:SOURCE", help="tum: the pose of SOURCE in TARGET from the TF tree, e.g. map:base_link"
    )
    p.add_argument(
        "--time",
        default="header",
        choices=("header", "log"),
        help="tum: timestamps from header stamps (default) or receive times",
    )
    p.add_argument("--frame-prefix", default="", help="tum --tf: prefix stripped from frame names, e.g. simple_robot/")
    p.add_argument("--start", type=float, help="seconds from the log's first message")
    p.add_argument("--end", type=float, help="seconds from the log's first message")
    p.add_argument("--force", action="store_true", help="replace an existing output")
    p.add_argument("--recover", action="store_true", help="export the readable part of a truncated MCAP")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.analysis.export import BagOptions, export_rosbag2, export_tum
    from navlog.replay.io import open_log

    if args.to == "rosbag2":
        if args.topic or args.tf:
            raise NavlogError("--topic and --tf are for --to tum; use --topics to choose bag topics")
        opts = BagOptions(
            storage=args.storage, distro=args.distro, topics=tuple(args.topics), start_s=args.start, end_s=args.end
        ).validate()
        with open_log(args.log, recover=args.recover) as reader:
            summary = export_rosbag2(reader, args.output, opts, force=args.force)
        print(
            f"{summary.path}: rosbag2 {args.storage} for {args.distro}, {summary.messages} messages on "
            f"{len(summary.topics)} topics, {(summary.end_ns - summary.start_ns) / 1e9:.3f} s"
            + skipped_note(summary.skipped)
        )
        return 0
    if args.topics:
        raise NavlogError("--topics is for --to rosbag2; use --topic TOPIC or --tf TARGET:SOURCE for --to tum")
    tf = None
    if args.tf:
        target, sep, source = args.tf.partition(":")
        if not sep or not target or not source:
            raise NavlogError(f"--tf {args.tf}: expected TARGET:SOURCE, e.g. map:base_link")
        tf = (target, source)
    with open_log(args.log, recover=args.recover) as reader:
        tum = export_tum(
            reader,
            args.output,
            topic=args.topic,
            tf=tf,
            time_source=args.time,
            start_s=args.start,
            end_s=args.end,
            frame_prefix=args.frame_prefix,
            force=args.force,
        )
    skipped = sum(tum.skipped.values())
    print(f"{tum.path}: {tum.poses} poses from {tum.source}" + (f"; skipped {skipped}" if skipped else ""))
    return 0
