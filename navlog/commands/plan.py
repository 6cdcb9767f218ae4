"""navlog plan: one global plan on a map_server map with a Nav2 parameter file."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.io.map_server import load_map
from navlog.replay.nav2.params import load_nav2_params, parse_nav2_params
from navlog.replay.nav2.planners.navfn import PlanningError
from navlog.replay.nodes.planner import path_msg
from navlog.replay.pipelines.planner import default_costmap, make_planner


def _pose(text: str, what: str) -> tuple[float, float, float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (2, 3):
        raise ConfigError(f"--{what} {text!r}: expected x,y[,yaw] in metres and radians, e.g. 1.0,2.0,0.0")
    return (vals[0], vals[1], vals[2] if len(vals) == 3 else 0.0)


def register(sub) -> None:
    p = sub.add_parser(
        "plan",
        help="plan once on a map with NavFn or the Smac-2D-like planner",
        description="Build the global costmap from a map_server map and the Nav2 parameters, plan from start to "
        "goal, print length, cost and planning time; optionally write the plan as nav_msgs/Path MCAP or a PNG.",
    )
    p.add_argument("--map", required=True, type=Path, help="map_server YAML")
    p.add_argument("--start", required=True, help="x,y,yaw (write --start=-1,0,0 when x is negative)")
    p.add_argument("--goal", required=True, help="x,y,yaw")
    p.add_argument("--params", type=Path, help="Nav2 parameter file (default: Nav2's defaults)")
    p.add_argument("--planner", choices=("navfn", "smac2d"), default="navfn")
    p.add_argument("--potential", choices=("wavefront", "exact"), default="wavefront", help="NavFn potential")
    p.add_argument(
        "--set", action="append", default=[], metavar="KEY=VALUE", help="Nav2 override (full or short key path)"
    )
    p.add_argument("-o", "--output", type=Path, help="write the plan (and the costmap) to this MCAP")
    p.add_argument("--png", type=Path, help="draw costmap and plan to this PNG")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.replay.nav2.costmap import Costmap2D

    start, goal = _pose(args.start, "start"), _pose(args.goal, "goal")
    if args.params:
        nav2 = load_nav2_params(args.params, args.set)
    else:
        from navlog.replay.nav2.params import apply_nav2_overrides

        nav2 = parse_nav2_params(apply_nav2_overrides({}, args.set) if args.set else {}, source="<defaults>")
    nav2.require_valid(("global_costmap", "planner_server"))
    occ = load_map(args.map)
    cparams = nav2.global_costmap or default_costmap()
    cm = Costmap2D(cparams)
    if not cm.static_layers:
        raise ConfigError(f"{args.params}: the global costmap has no static layer, so the map cannot be used")
    cm.set_static_map(occ)
    cm.update(start[0], start[1], start[2])
    if (occ.data == -1).all():
        raise ConfigError(f"{args.map}: the map is unknown everywhere")
    planner = make_planner(nav2, args.planner, potential=args.potential)
    try:
        plan = planner.plan(cm, start, goal)
    except PlanningError as exc:
        raise PlanningError(f"{args.map}: {exc}") from None
    print(
        f"planner {plan.planner}: {len(plan.poses)} poses, length {plan.length:.3f} m, cost {plan.cost:.3f} "
        f"(cost-weighted m), time {plan.time_s * 1000:.1f} ms on {cm.size_x} x {cm.size_y} cells"
    )
    for note in plan.notes:
        print(f"note: {note}")
    if args.output:
        from navlog.replay import messages as m
        from navlog.replay.io.logwriter import McapLogWriter
        from navlog.replay.runtime.executor import Envelope

        with McapLogWriter(args.output, force=True) as w:
            w.write(Envelope("/global_costmap/costmap", m.OCCUPANCY_GRID, 0, cm.to_msg(0)))
            w.write(Envelope("/plan", m.PATH, 0, path_msg(plan, 0, cparams.global_frame)))
        print(f"wrote {args.output}")
    if args.png:
        from PIL import Image

        img = np.stack([255 - (cm.costs.astype(np.int32) * 255 // 255)] * 3, axis=-1).astype(np.uint8)
        img[cm.costs == 255] = (120, 120, 160)
        mx, my = cm.world_to_cell(plan.poses[:, 0], plan.poses[:, 1])
        ok = (mx >= 0) & (mx < cm.size_x) & (my >= 0) & (my < cm.size_y)
        img[my[ok], mx[ok]] = (220, 30, 30)
        Image.fromarray(img[::-1]).save(args.png)
        print(f"wrote {args.png}")
    return 0
