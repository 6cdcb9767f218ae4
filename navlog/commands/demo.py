"""navlog demo: the main job end to end — record a mapping run, replay it into a map and a PCD,
compute the metrics against the world's true geometry, and write a Rerun file."""

from __future__ import annotations

import shutil
import time
from pathlib import Path

from navlog.analysis.metrics.report import MetricsOptions, compute_metrics, format_table, write_json
from navlog.analysis.view.rerun_view import save_view
from navlog.errors import NavlogError
from navlog.recorder.record import format_summary, prepare, record
from navlog.recorder.world import occupancy, write_mesh
from navlog.replay.io.map_server import save_map
from navlog.replay.runtime.session import run_replay


def register(sub) -> None:
    p = sub.add_parser(
        "demo",
        help="record a mapping run, replay it into a map and a PCD, compute metrics, write a Rerun file",
        description="The main job in one command: (1) record the Go2 mapping tour of indoor_room to MCAP, "
        "(2) replay it through the mapping pipeline (2D occupancy map, 3D LiDAR map and trajectory), "
        "(3) write the reference map and mesh of the world and compute the metrics, (4) write a Rerun "
        "recording to open with `rerun OUT/demo.rrd`.",
    )
    p.add_argument("-o", "--output", type=Path, default=Path("demo-out"), help="output folder (default demo-out/)")
    p.add_argument("--seed", type=int, default=7, help="noise seed (default 7)")
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    p.set_defaults(func=run)


def run(args) -> int:
    out: Path = args.output
    if out.exists() and any(out.iterdir()):
        if not args.force:
            raise NavlogError(f"{out}: output folder exists and is not empty; pass --force to replace it")
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    progress = not args.quiet
    t0 = time.perf_counter()

    print("== 1/4 record: indoor_room + go2 + mapping", flush=True)
    setup = prepare("indoor_room", "go2", "mapping", seed=args.seed)
    rec = record(setup, out / "mapping.mcap", progress=progress)
    print(format_summary(rec), flush=True)

    print("\n== 2/4 replay through the mapping pipeline", flush=True)
    rep = run_replay(rec.path, "mapping", out / "replay", progress=progress)
    print(
        f"replayed {rep.log_s:.1f} s of log in {rep.wall_s:.1f} s into {rep.out_dir}/: "
        + ", ".join(o["file"] for o in rep.manifest["outputs"].values()),
        flush=True,
    )

    print("\n== 3/4 metrics against the world's true geometry", flush=True)
    ref = out / "reference"
    ref.mkdir()
    scan_height = setup.robot.body.height + setup.robot.scan.mount[2]
    map_yaml, _ = save_map(occupancy(setup.world, 0.05, 0.0, scan_height, scan_height), ref / "world_scan_plane.yaml")
    save_map(occupancy(setup.world, 0.05, 0.15), ref / "world_nav2.yaml")
    mesh = write_mesh(setup.world, ref / "world.ply")
    metrics = compute_metrics(
        rec.path, rep.out_dir, reference_map=map_yaml, reference_mesh=mesh, options=MetricsOptions()
    )
    write_json(metrics, out / "metrics.json")
    print(format_table(metrics), flush=True)

    print("\n== 4/4 Rerun recording", flush=True)
    summary = save_view(rec.path, out / "demo.rrd", replay_dir=rep.out_dir)
    print(f"wrote {out / 'demo.rrd'}: {len(summary.entities)} entities, {summary.messages} messages drawn")

    print(f"\ndone in {time.perf_counter() - t0:.0f} s. Outputs in {out}/:")
    print(f"  mapping.mcap          the recorded log (`navlog info {out}/mapping.mcap`)")
    print("  replay/               map.yaml + map.pgm, map.pcd, trajectory.tum, replay.mcap, manifest.json")
    print("  reference/            the world's map at the scan plane, its Nav2 map (0.15 m margin), its mesh")
    print("  metrics.json          ATE/RPE, 2D precision/recall/F1, 3D accuracy")
    print(f"  demo.rrd              open with `.venv/bin/rerun {out}/demo.rrd`")
    return 0
