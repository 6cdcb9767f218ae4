"""navlog metrics LOG --replay OUT/: trajectory, 2D map and 3D map metrics of a replay."""

from __future__ import annotations

import math

from navlog.commands import add_force, refuse_existing

# The values navlog.analysis.metrics accepts (report.PCD_FRAMES, trajectory.ALIGN_MODES and DELTA_UNITS),
# written here so that the help needs no numpy; tests/navlog/test_cli.py checks they agree.
PCD_FRAMES = ("first-pose", "as-is", "aligned")
ALIGN_MODES = ("se3", "sim3", "none")
DELTA_UNITS = ("frames", "m", "s")


def register(sub) -> None:
    p = sub.add_parser(
        "metrics",
        help="measure a replay or a navigation log: ATE/RPE, 2D/3D map accuracy, goals and clearance",
        description="Compare the outputs of `navlog replay LOG -o OUT/` with ground truth: OUT/trajectory.tum "
        "against the log's /odom/ground_truth (ATE after Umeyama alignment, RPE), OUT/map.yaml against a "
        "reference grid (occupied precision, recall and F1 at a tolerance, IoU, mean distances, free-space "
        "coverage), OUT/map.pcd against a reference mesh (accuracy@tau, and completeness@tau of the surfaces "
        "visible from the ground-truth path). Prints a table; -o writes JSON. "
        "Metrics whose inputs are missing are skipped with a note.",
        epilog="examples:\n  navlog metrics run.mcap --replay out/\n"
        "  navlog metrics run.mcap --replay out/ --reference-map gt.yaml --tau 0.05 -o metrics.json\n"
        "  navlog metrics nav.mcap   # a navigation log: goals, clearance, collisions",
    )
    p.add_argument("log", help="the log that was replayed (.mcap, .db3 or rosbag2 folder)")
    p.add_argument(
        "--replay",
        metavar="OUT",
        help="the replay output folder (trajectory and map metrics); without it, only the log's own "
        "metrics (navigation: goals, clearance, collisions, recoveries, speed, jerk)",
    )
    p.add_argument(
        "--reference-map",
        metavar="MAP.yaml",
        help="reference grid, without a safety margin (e.g. `navlog world-map WORLD --margin 0`; one with a margin "
        "is warned about)",
    )
    p.add_argument("--reference-mesh", metavar="MESH.ply", help="triangle mesh of the true surfaces")
    p.add_argument("--tau", type=float, default=0.05, help="2D tolerance in metres (default 0.05)")
    p.add_argument(
        "--map-frame",
        type=float,
        nargs=3,
        metavar=("X", "Y", "YAW"),
        help="where the replayed map's frame lies in the reference map's (m, m, rad), e.g. a SLAM map "
        "started elsewhere; the map is resampled onto the reference grid (default: the same frame)",
    )
    p.add_argument(
        "--tau-3d",
        type=float,
        nargs="+",
        default=[0.02, 0.05],
        metavar="TAU",
        help="3D accuracy tolerances in metres (default 0.02 0.05)",
    )
    p.add_argument(
        "--max-diff", type=float, default=0.01, help="timestamp association window in seconds (default 0.01)"
    )
    p.add_argument(
        "--interpolate",
        action="store_true",
        help="interpolate the ground truth at the estimate's stamps (instead of the nearest stamp within --max-diff)",
    )
    p.add_argument(
        "--max-gap", type=float, default=0.1, help="--interpolate: largest ground-truth gap bridged, s (default 0.1)"
    )
    p.add_argument("--align", choices=ALIGN_MODES, default="se3", help="ATE alignment (default se3)")
    p.add_argument("--rpe-delta", type=float, default=1.0, help="RPE delta (default 1)")
    p.add_argument("--rpe-unit", choices=DELTA_UNITS, default="m", help="RPE delta unit (default m)")
    p.add_argument(
        "--rpe-pairs-from",
        choices=("reference", "estimate"),
        default="reference",
        help="path along which RPE pairs are chosen (default reference; evo's default is estimate)",
    )
    p.add_argument("--gt-topic", default="/odom/ground_truth", help="ground-truth nav_msgs/Odometry topic")
    p.add_argument(
        "--cmd-topic", default="/cmd_vel", help="the commands the robot drove on (navigation jerk; default /cmd_vel)"
    )
    p.add_argument(
        "--pcd-frame",
        choices=PCD_FRAMES,
        default="first-pose",
        help="how map.pcd is put in the world frame (default first-pose: anchored at the first matched pose)",
    )
    p.add_argument(
        "--view-fov",
        type=float,
        nargs=2,
        default=[-15.0, 15.0],
        metavar=("LOW", "HIGH"),
        help="elevation band (deg) of the rays that find the visible surfaces for 3D completeness (default -15 15)",
    )
    p.add_argument("--view-range", type=float, default=30.0, help="range (m) of those rays (default 30)")
    p.add_argument(
        "--view-spacing", type=float, default=0.5, help="one viewpoint per this many metres of path (default 0.5)"
    )
    p.add_argument("--recover", action="store_true", help="read the complete chunks of a truncated MCAP log")
    p.add_argument("-o", "--output", metavar="metrics.json", help="write the metrics as JSON")
    p.add_argument("--json", action="store_true", help="print JSON instead of the table")
    add_force(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.analysis.metrics.report import MetricsOptions, compute_metrics, format_table, to_json, write_json
    from navlog.errors import NavlogError
    from navlog.replay.limits import MAX_PERIOD_S

    refuse_existing(args.force, args.output)
    for flag, value in (("--max-diff", args.max_diff), ("--max-gap", args.max_gap)):
        if not (math.isfinite(value) and 0 <= value <= MAX_PERIOD_S):
            raise NavlogError(f"{flag} {value!r}: must be a time in seconds from 0 to {MAX_PERIOD_S:g}")
    options = MetricsOptions(
        tau=args.tau,
        taus_3d=tuple(args.tau_3d),
        max_diff_ns=int(round(args.max_diff * 1e9)),
        interpolate=args.interpolate,
        max_gap_ns=int(round(args.max_gap * 1e9)),
        align=args.align,
        rpe_delta=args.rpe_delta,
        rpe_unit=args.rpe_unit,
        rpe_pairs_from=args.rpe_pairs_from,
        gt_topic=args.gt_topic,
        cmd_topic=args.cmd_topic,
        map_frame=tuple(args.map_frame) if args.map_frame else None,
        pcd_frame=args.pcd_frame,
        view_fov_deg=(args.view_fov[0], args.view_fov[1]),
        view_range_m=args.view_range,
        view_spacing_m=args.view_spacing,
    )
    metrics = compute_metrics(
        args.log,
        args.replay,
        reference_map=args.reference_map,
        reference_mesh=args.reference_mesh,
        options=options,
        recover=args.recover,
    )
    print(to_json(metrics), end="") if args.json else print(format_table(metrics))
    if args.output:
        path = write_json(metrics, args.output)
        if not args.json:
            print(f"Wrote {path}")
    return 0
