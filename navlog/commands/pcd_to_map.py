"""navlog pcd-to-map: project a 3D point map (PCD) to a Nav2 map between two heights."""

from __future__ import annotations

from pathlib import Path

from navlog.errors import NavlogError


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
    from navlog.replay.io.logwriter import check_output
    from navlog.replay.io.map_server import save_map
    from navlog.replay.io.pcd import read_pcd
    from navlog.replay.mapping.occupancy import project_points

    if not args.pcd.is_file():
        raise NavlogError(f"{args.pcd}: no such file")
    check_output(args.output, args.force)
    check_output(args.output.with_suffix(".pgm"), args.force)
    pts = read_pcd(args.pcd)
    if len(pts) == 0:
        raise NavlogError(f"{args.pcd}: no points could be read (is it a PCD file?)")
    try:
        grid = project_points(
            pts, args.z_min, args.z_max, args.resolution, args.min_points, None if args.all_free else args.z_min
        )
    except ValueError as exc:
        raise NavlogError(f"{args.pcd}: {exc}") from None
    yaml_path, pgm_path = save_map(grid, args.output)
    print(
        f"wrote {yaml_path} and {pgm_path}: {grid.width} x {grid.height} cells, {int((grid.data == 100).sum())} occupied, "
        f"{int((grid.data == 0).sum())} free, from {len(pts)} points between {args.z_min} and {args.z_max} m"
    )
    return 0
