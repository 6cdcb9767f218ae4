"""navlog plan: one global plan on a map_server map with a Nav2 parameter file."""

from __future__ import annotations

import math
from pathlib import Path

from navlog.commands import add_force, refuse_existing
from navlog.errors import ConfigError


def _pose(text: str, what: str) -> tuple[float, float, float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (2, 3) or not all(math.isfinite(v) for v in vals):
        raise ConfigError(f"--{what} {text!r}: expected x,y[,yaw] in metres and radians, e.g. 1.0,2.0,0.0")
    return (vals[0], vals[1], vals[2] if len(vals) == 3 else 0.0)


def register(sub) -> None:
    p = sub.add_parser(
        "plan",
        help="plan once on a map with NavFn or the Smac-2D-like planner",
        description="Build the global costmap from a map_server map and the Nav2 parameters, plan from start to "
        "goal, print length, cost and planning time; optionally write the plan as nav_msgs/Path MCAP or a PNG.",
        epilog="examples:\n  navlog plan --map tb3_sandbox.yaml --start=-2,-0.5,0 --goal 1.5,1,0 --png plan.png\n"
        "  navlog plan --map map.yaml --params nav2_params.yaml --planner smac2d --start 0,0,0 --goal 4,2,1.57 "
        "-o plan.mcap",
    )
    p.add_argument("--map", required=True, type=Path, help="map_server YAML")
    p.add_argument("--start", required=True, help="x,y,yaw (write --start=-1,0,0 when x is negative)")
    p.add_argument("--goal", required=True, help="x,y,yaw")
    p.add_argument("--params", type=Path, help="Nav2 parameter file (default: Nav2's defaults)")
    p.add_argument("--planner", choices=("navfn", "smac2d"), default="navfn")
    p.add_argument(
        "--potential", choices=("exact", "python"), default="exact", help="NavFn kernels: compiled, or plain Python"
    )
    p.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="Nav2 override (full or short key path)"
    )
    p.add_argument("-o", "--output", type=Path, help="write the plan (and the costmap) to this MCAP")
    p.add_argument("--png", type=Path, help="draw the costmap, the plan, the start and the goal to this PNG")
    add_force(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.replay.pipelines.planner import plan_on_map, write_plan_mcap, write_plan_png

    start, goal = _pose(args.start, "start"), _pose(args.goal, "goal")
    refuse_existing(args.force, args.output, args.png)
    result = plan_on_map(
        args.map,
        start,
        goal,
        nav2_params=args.params,
        planner=args.planner,
        potential=args.potential,
        overrides=args.set,
    )
    plan, cm = result.plan, result.costmap
    print(
        f"planner {plan.planner}: {len(plan.poses)} poses, length {plan.length:.3f} m, cost {plan.cost:.3f} "
        f"(cost-weighted m), time {plan.time_s * 1000:.1f} ms on {cm.size_x} x {cm.size_y} cells"
    )
    for note in plan.notes:
        print(f"note: {note}")
    if args.output:
        write_plan_mcap(args.output, result)
        print(f"wrote {args.output}")
    if args.png:
        write_plan_png(args.png, result)
        print(f"wrote {args.png}")
    return 0
