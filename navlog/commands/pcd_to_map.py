"""navlog pcd-to-map: project a 3D point map (PCD) to a Nav2 map between two heights."""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "pcd-to-map",
        help="project a PCD map to a map_server map between two heights",
        description="Project a 3D point map (e.g. map.pcd from `navlog replay --pipeline mapping`, or FAST-LIO's "
        "scans.pcd) to a 2D occupancy grid: cells with points between --z-min and --z-max are occupied; cells "
        "where only floor points (below --z-min) were seen are free; the rest is unknown.",
        epilog="example:\n  navlog pcd-to-map out/map.pcd --z-min 0.1 --z-max 1.0 -o map2d.yaml",
    )
    p.add_argument("pcd", type=Path, help="the .pcd file")
    p.add_argument("--z-min", type=float, required=True, help="lowest height that counts as an obstacle (m)")
    p.add_argument("--z-max", type=float, required=True, help="highest height that counts as an obstacle (m)")
    p.add_argument("--resolution", type=float, default=0.05, help="cell size in m (default 0.05)")
    p.add_argument("--min-points", type=int, default=2, help="points a cell needs to be occupied (default 2)")
    p.add_argument("--all-free", action="store_true", help="mark every non-occupied cell free (no unknown)")
    p.add_argument("-o", "--output", type=Path, required=True, help="map YAML to write (the PGM goes beside it)")
    p.add_argument("--force", action="store_true", help="overwrite existing files")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.analysis.export import pcd_to_map

    res = pcd_to_map(
        args.pcd,
        args.output,
        z_min=args.z_min,
        z_max=args.z_max,
        resolution=args.resolution,
        min_points=args.min_points,
        all_free=args.all_free,
        force=args.force,
    )
    print(
        f"wrote {res.yaml_path} and {res.pgm_path}: {res.width} x {res.height} cells, {res.occupied} occupied, "
        f"{res.free} free, from {res.points} points between {args.z_min} and {args.z_max} m"
    )
    return 0
