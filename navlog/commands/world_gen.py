"""navlog world-gen: a generated world (BARN-style field, cluttered room, corridor, office) as a world YAML."""

from __future__ import annotations

from pathlib import Path


def register(sub) -> None:
    p = sub.add_parser(
        "world-gen",
        help="write a generated world (BARN-style obstacle field, cluttered room, corridor, office) as a world YAML",
        description="Generate a world from a seed, deterministically: barn (a cellular-automaton obstacle field, "
        "Perille et al. 2020), room (a walled room with random boxes and cylinders), corridor (cross walls "
        "with doorways) or office (rooms with doorways and furniture on both sides of a corridor). The YAML is a world every navlog command reads (--world w.yaml).",
        epilog="example:\n  navlog world-gen barn --seed 7 --param fill=0.3 --param smoothing=4 -o barn_7.yaml\n"
        "  navlog world-gen corridor --seed 1 --param doors=4 -o corridor.yaml",
    )
    p.add_argument("kind", help="generator: barn, room, corridor or office")
    p.add_argument("--seed", type=int, default=0, help="the seed (default 0)")
    p.add_argument(
        "--param", action="append", default=[], metavar="KEY=VALUE", help="a generator parameter (repeatable)"
    )
    p.add_argument("-o", "--output", type=Path, required=True, help="world YAML to write")
    p.add_argument("--force", action="store_true", help="overwrite an existing file")
    p.set_defaults(func=run)


def run(args) -> int:
    from navlog.recorder.generators import generate_world, write_world_yaml
    from navlog.replay.config import apply_overrides

    params = apply_overrides({}, args.param)
    gen = generate_world(args.kind, args.seed, params, "--param")
    path = write_world_yaml(gen, args.output, force=args.force)
    facts = ", ".join(f"{k} {v}" for k, v in gen.info.items() if k in ("difficulty", "optimal_path_m", "fill_actual"))
    print(f"wrote {path}: world '{gen.spec.name}', {len(gen.world.solids)} solids" + (f"; {facts}" if facts else ""))
    return 0
