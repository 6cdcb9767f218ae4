"""navlog demo: the main job end to end — record a mapping run, replay it into a map and a PCD,
compute the metrics against the world's true geometry, and write a Rerun file (``navlog.demo``)."""

from __future__ import annotations

import argparse
import functools
from pathlib import Path
from typing import Any


def register(sub: Any) -> None:
    p = sub.add_parser(
        "demo",
        help="record a mapping run, replay it into a map and a PCD, compute metrics, write a Rerun file",
        description="The main job in one command: (1) record the Go2 mapping tour of indoor_room to MCAP, "
        "(2) replay it through the mapping pipeline (2D occupancy map, 3D LiDAR map and trajectory), "
        "(3) write the reference map and mesh of the world and compute the metrics, (4) write a Rerun "
        "recording to open with `rerun OUT/demo.rrd`. From Python: navlog.run_demo(OUT).",
        epilog="example:\n  navlog demo -o demo-out/ --seed 7",
    )
    p.add_argument("-o", "--output", type=Path, default=Path("demo-out"), help="output folder (default demo-out/)")
    p.add_argument("--seed", type=int, default=7, help="noise seed (default 7)")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from navlog.commands.record import stop_on_ctrl_c
    from navlog.demo import run_demo

    out: Path = args.output
    with stop_on_ctrl_c() as stop:
        res = run_demo(
            out,
            seed=args.seed,
            force=args.force,
            progress=not args.quiet,
            echo=functools.partial(print, flush=True),
            stop=stop,
        )
    if res.interrupted:
        return 130
    print(f"\ndone in {res.wall_s:.0f} s. Outputs in {out}/:")
    print(f"  mapping.mcap          the recorded log (`navlog info {out}/mapping.mcap`)")
    print("  replay/               map.yaml + map.pgm, map.pcd, trajectory.tum, replay.mcap, manifest.json")
    print("  reference/            the world's map at the scan plane, its Nav2 map (0.15 m margin), its mesh")
    print("  metrics.json          ATE/RPE, 2D precision/recall/F1, 3D accuracy")
    print(f"  demo.rrd              open with `.venv/bin/rerun {out}/demo.rrd`")
    return 0
