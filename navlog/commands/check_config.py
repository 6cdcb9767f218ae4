"""navlog check-config FILE: every problem of a Nav2 parameter file at once, with its YAML path (a
slam_toolbox block, alone or beside Nav2's nodes, is checked as the mapping pipeline reads it)."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "check-config",
        help="check a Nav2 or slam_toolbox parameter file (typos, unknown plugins, types, ranges, renamed parameters)",
        description="Read a nav2_params.yaml as Nav2 would and report every problem at once with file, line and "
        "YAML path: misspelled keys and plugins (with did-you-mean), wrong types, out-of-range values, renamed "
        "parameters, sections Nav2 ignores. A slam_toolbox block (mapper_params_online_async.yaml) is checked as "
        "`navlog replay --pipeline mapping --params FILE` reads it. Lists what navlog reads but does not "
        "implement. Exits 1 on errors.",
        epilog="examples:\n  navlog check-config nav2_params.yaml\n"
        "  navlog check-config turtlebot4_nav2.yaml --distro humble --notes",
    )
    p.add_argument("file", help="a Nav2 parameter file (node: ros__parameters: ...)")
    p.add_argument(
        "--distro",
        choices=("jazzy", "humble"),
        default="jazzy",
        help="the Nav2 distribution the file is written for: its own names are not warned about as the "
        "other's (default: jazzy)",
    )
    p.add_argument("--notes", action="store_true", help="also list every parameter read but not implemented")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.replay.mapping.slam2d.toolbox import TOOLBOX_NODE, read_slam_toolbox
    from navlog.replay.nav2 import ERROR, IMPLEMENTED_NODES, NOTE, WARNING, load_nav2_params

    params = load_nav2_params(args.file, distro=args.distro, readers={TOOLBOX_NODE: read_slam_toolbox})
    order = {ERROR: 0, WARNING: 1, NOTE: 2}
    problems = sorted(params.problems, key=lambda q: (order[q.severity], q.line or 0, q.path))
    for q in problems:
        if q.severity != NOTE or args.notes:
            print(q.format(args.file))
    notes = [q for q in problems if q.severity == NOTE]
    implemented = [n for n in IMPLEMENTED_NODES if getattr(params, n) is not None] + list(params.others)
    print(f"checked: {', '.join(implemented) or 'no implemented node'}")
    if params.not_implemented:
        print(f"read, not implemented: {', '.join(params.not_implemented)}")
    print(
        f"{len(params.errors)} error(s), {len(params.warnings)} warning(s), {len(notes)} note(s)"
        + ("" if args.notes or not notes else " (--notes lists them)")
    )
    return 1 if params.errors else 0
