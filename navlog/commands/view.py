"""navlog view LOG: draw a log (and a replay output folder) in Rerun with a default blueprint."""

from __future__ import annotations

import logging
import sys
import time

from navlog.commands import skipped_note
from navlog.errors import NavlogError

log = logging.getLogger("navlog")


def register(sub) -> None:
    p = sub.add_parser(
        "view",
        help="draw a log in Rerun: 3D (map frame), top-down 2D, time series, events",
        description="Convert any log (navlog MCAP, rosbag2 folder, .mcap or .db3) into a Rerun recording: "
        "scans, clouds, TF, trajectories, plans, grids, goals, the velocity chain and events, on a "
        "sim_time duration timeline, with a default layout: the 3D view (camera on the robot) beside a "
        "top-down view, the plots below. --save writes an .rrd without a display; --spawn opens a viewer at the "
        "log's start; --connect streams to a running one.",
        epilog="examples:\n  navlog view run.mcap --save run.rrd\n  navlog view run.mcap --replay out/ --spawn\n"
        "  navlog view my_bag/ --connect rerun+http://127.0.0.1:9876/proxy",
    )
    p.add_argument("log", help="a .mcap file, a .db3 file or a rosbag2 folder")
    p.add_argument(
        "--replay", metavar="OUT", help="a replay output folder (replay.mcap, map.yaml, map.pcd, trajectory.tum)"
    )
    sink = p.add_mutually_exclusive_group(required=True)
    sink.add_argument("--save", metavar="FILE.rrd", help="write the recording to an .rrd file (headless)")
    sink.add_argument("--spawn", action="store_true", help="open a Rerun viewer and stream the recording to it")
    sink.add_argument("--connect", metavar="ADDR", help="stream to a viewer at ADDR (rerun+http://HOST:9876/proxy)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --save file")
    p.add_argument("--recover", action="store_true", help="draw the readable part of a truncated MCAP")
    p.add_argument("--fixed-frame", default="", help="frame of the 3D and 2D views (default: map, else the TF root)")
    p.add_argument("--frame-prefix", default="", help="prefix stripped from frame names, e.g. simple_robot/")
    p.add_argument("--cloud-stride", type=int, default=1, help="keep every n-th point of each cloud (default 1)")
    p.add_argument(
        "--cloud-period",
        type=float,
        default=0.5,
        metavar="S",
        help="draw at most one 3D LiDAR cloud per S seconds of each topic (default 0.5; 0: every cloud)",
    )
    p.add_argument("--follow", action="store_true", help="the 3D camera follows the robot as time plays")
    p.add_argument(
        "--paused",
        action="store_true",
        help="open paused at the log's start (default: a spawned viewer plays from the start)",
    )
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    import rerun as rr

    from navlog.analysis.view import ViewOptions, save_view, stream_view

    rr.set_strict_mode(True)
    opts = ViewOptions(
        fixed_frame=args.fixed_frame,
        frame_prefix=args.frame_prefix,
        cloud_stride=args.cloud_stride,
        cloud_period_s=args.cloud_period,
        follow=args.follow,
        play_state="paused" if args.paused else "",
    )
    t0 = time.perf_counter()
    if args.save:
        summary = save_view(
            args.log, args.save, replay_dir=args.replay, options=opts, force=args.force, recover=args.recover
        )
        where = args.save
    else:
        if args.connect and not args.connect.startswith(("rerun://", "rerun+http://", "rerun+https://")):
            raise NavlogError(f"--connect {args.connect}: expected a URL like rerun+http://127.0.0.1:9876/proxy")
        summary = stream_view(
            args.log, spawn=args.spawn, connect=args.connect, replay_dir=args.replay, options=opts, recover=args.recover
        )
        where = "the viewer" if args.spawn else args.connect
    dt = time.perf_counter() - t0
    if args.json:
        from navlog.replay.io import json_text

        print(json_text.dumps(summary.as_dict(), indent=2))
        return 0
    for w in summary.warnings:
        log.warning("%s", w)
    print(
        f"{where}: {summary.messages} messages, {summary.points} points, {len(summary.entities)} entities "
        f"in frame {summary.fixed_frame} ({dt:.1f} s)"
        + skipped_note(summary.skipped)
        + (
            f"; thinned: {', '.join(f'{k} ({v} left out)' for k, v in sorted(summary.thinned.items()))}"
            if summary.thinned
            else ""
        )
        + (f"; stored but not drawn: {', '.join(sorted(summary.not_drawn))}" if summary.not_drawn else "")
        + (
            f"; not read: {', '.join(f'{k} ({v})' for k, v in sorted(summary.unknown_types.items()))}"
            if summary.unknown_types
            else ""
        ),
        file=sys.stdout,
    )
    return 0
