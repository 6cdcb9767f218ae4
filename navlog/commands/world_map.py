"""navlog world-map: the Nav2-ready map of a world's obstacles, with a safety margin."""

from __future__ import annotations

from pathlib import Path

from navlog.commands.record import add_world_options


def register(sub) -> None:
    p = sub.add_parser(
        "world-map",
        help="write the map_server map (YAML + PGM) of a world's obstacles",
        description="Rasterise a world's obstacle geometry into a map_server map (trinary PGM + YAML), as the "
        "Go2 setup generates its fixed Nav2 map: cells within --margin of an obstacle are occupied, all others "
        "free. --z-min/--z-max choose the heights that count (default 0..2 m: everything a robot can hit); "
        "--height H keeps what crosses one horizontal plane, e.g. a 2D laser's scan plane.",
        epilog="example:\n  navlog world-map indoor_room --margin 0.15 --resolution 0.05 -o gt.yaml",
    )
    p.add_argument("world", help="world name, world YAML, Gazebo SDF world or map_server map YAML")
    p.add_argument("--margin", type=float, default=0.15, help="safety margin around obstacles in m (default 0.15)")
    p.add_argument("--resolution", type=float, default=0.05, help="cell size in m (default 0.05)")
    p.add_argument("--z-min", type=float, default=0.0, help="lowest height that counts (default 0)")
    p.add_argument("--z-max", type=float, default=2.0, help="highest height that counts (default 2.0)")
    p.add_argument("--height", type=float, help="keep only what crosses this height (sets z-min = z-max)")
    p.add_argument("-o", "--output", type=Path, required=True, help="map YAML to write (the PGM goes beside it)")
    p.add_argument(
        "--mesh",
        type=Path,
        help="also write the world's surfaces as a triangle mesh (.ply), "
        "the reference of `navlog metrics --reference-mesh`",
    )
    p.add_argument("--force", action="store_true", help="overwrite existing files")
    add_world_options(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.recorder.world import load_world, write_world_map
    from navlog.replay.io.atomic import check_not_input

    read = [args.world] if Path(args.world).exists() else []  # (a name of navlog's worlds is no file)
    if read and Path(args.world).suffix in (".yaml", ".yml"):  # a map_server map: its image is read too
        from navlog.replay.config import load_yaml

        doc = load_yaml(Path(args.world))
        if isinstance(doc, dict) and isinstance(doc.get("image"), str):
            read.append(str(Path(args.world).parent / doc["image"]))
    for out in (args.output, args.output.with_suffix(".pgm"), args.mesh):
        if out is not None:
            check_not_input(out, read)
    world = load_world(args.world, resource_paths=args.resource_path, wall_height=args.wall_height)
    for note in world.notes:
        print(f"world: {note}")
    z_min, z_max = (args.height, args.height) if args.height is not None else (args.z_min, args.z_max)
    res = write_world_map(
        world,
        args.output,
        margin=args.margin,
        resolution=args.resolution,
        z_min=z_min,
        z_max=z_max,
        mesh=args.mesh,
        force=args.force,
    )
    print(
        f"wrote {res.yaml_path} and {res.pgm_path}: {res.width} x {res.height} cells at {res.resolution} m, "
        f"{res.occupied} occupied ({args.margin} m margin, heights {z_min}..{z_max} m)"
    )
    if res.mesh_path is not None:
        print(f"wrote {res.mesh_path}: the surfaces of {res.world}")
    return 0
