"""navlog diff A B: what moved between two replays (or two logs), judged against tolerances."""

from __future__ import annotations

from navlog.commands import add_force, refuse_existing


def register(sub) -> None:
    p = sub.add_parser(
        "diff",
        help="what moved between two replays or two logs: maps, plans, commands, trajectories, metrics",
        description="Compare B against A: two replay output folders (`navlog replay ... -o OUT/`, compared "
        "through their manifest.json), or two logs (.mcap, .db3, rosbag2 folder; compared topic by topic). "
        "Outputs and topics with the same bytes are EQUAL at once; the others go to a comparator by kind: "
        "occupancy grids (share of cells that changed class, IoU, Hausdorff), PCD maps (Chamfer, share "
        "beyond tau), plans (success, length, Hausdorff, endpoint, cost), velocity commands (RMS and max "
        "per axis), trajectories (ATE, RPE), metrics.json (by direction: IMPROVED or REGRESSED), any "
        "other message field by field. Names the first divergence. Exit 0 when everything is equal or "
        "within tolerance, 1 when not, 2 on bad input.",
        epilog="examples:\n  navlog diff out-a/ out-b/\n"
        "  navlog diff out-a/ out-b/ --tol grid.changed_share=0.01 --json diff.json --markdown diff.md\n"
        "  navlog diff run1.mcap run2.mcap --ignore /clock --ignore /tf.transforms\n\n"
        "tolerances (--tol KEY=VALUE): grid.changed_share, grid.hausdorff_m, points.tau_m, "
        "points.beyond_share, points.chamfer_m, path.hausdorff_m, path.length_m, path.endpoint_m, "
        "path.cost_rtol, twist.max_abs, trajectory.ate_m, trajectory.rpe_m, trajectory.max_diff_s, "
        "trajectory.rpe_delta_frames, metric.atol, metric.rtol, field.atol, field.rtol",
    )
    p.add_argument("a", help="the baseline: a replay output folder or a log")
    p.add_argument("b", help="the candidate: of the same kind as A")
    p.add_argument(
        "--tol", action="append", default=[], metavar="KEY=VALUE", help="a tolerance (repeatable; see below)"
    )
    p.add_argument(
        "--ignore",
        action="append",
        default=[],
        metavar="WHAT",
        help="skip a topic (/topic), a field of its messages (/topic.field.path) or an output file (repeatable)",
    )
    p.add_argument("--json", metavar="FILE", help="write the report as JSON (same report, same bytes)")
    p.add_argument("--markdown", metavar="FILE", help="write the report as Markdown (regressions first)")
    p.add_argument(
        "--rrd", metavar="FILE", help="write A and B overlaid (maps, changed cells, point maps, trajectories) for Rerun"
    )
    add_force(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.analysis.diff.core import diff
    from navlog.analysis.diff.report import format_report, to_json, to_markdown, write_text
    from navlog.analysis.diff.tolerances import parse_tolerances

    refuse_existing(args.force, args.json, args.markdown, args.rrd)
    report = diff(args.a, args.b, tolerances=parse_tolerances(args.tol), ignore=args.ignore)
    print(format_report(report))
    if args.json:
        print(f"Wrote {write_text(to_json(report), args.json)}")
    if args.markdown:
        print(f"Wrote {write_text(to_markdown(report), args.markdown)}")
    if args.rrd:
        from navlog.analysis.diff.overlay import save_overlay

        print(f"Wrote {save_overlay(report, args.rrd)}")
    return report.exit_code
