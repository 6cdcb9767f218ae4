"""World generators: seeded, deterministic worlds for navigation campaigns (``navlog world-gen``).

Each generator is a pure function ``(params, seed) -> GeneratedWorld``: the same parameters and seed
give the same world, byte for byte once written (``write_world_yaml``: a world YAML ``load_world``
reads back into the same solids).

- ``barn``: a BARN-style obstacle field (Perille et al. 2020, "Benchmarking Metric Ground Navigation"):
  a ``rows`` x ``cols`` grid of ``cell``-metre cells filled at random with probability ``fill``, then
  ``smoothing`` iterations of the cellular automaton (a cell becomes an obstacle when at least
  ``fill_threshold`` of its 8 neighbours are, free when fewer than ``clear_threshold`` are, and stays
  as it was in between; cells outside the grid count as free: BARN's three parameters, fill
  percentage, smoothing iterations and fill threshold). Free strips of ``approach`` metres lie below and above the field, walls
  enclose it all. A field through which the robot cannot pass from the lower strip to the upper one is
  drawn again (the next sub-seed) up to ``tries`` times. Obstacle cells become boxes (merged runs).
  Its difficulty is that of the optimal path across (``navlog.recorder.routes.path_difficulty``).
- ``room``: a walled room with ``obstacles`` random boxes and cylinders (clutter);
- ``corridor``: a corridor of ``length`` x ``width`` with ``doors`` cross walls, each with a doorway
  of ``door_width`` at a random place;
- ``office``: a floor of ``rooms`` rooms on each side of a central corridor, each room opening onto the
  corridor through one doorway of ``door_width`` at a random place along its wall, with up to
  ``furniture`` random boxes (desks, cabinets) inside, clear of its doorway.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.world import ObjectSpec, WallsSpec, World, WorldSpec, resolve_world
from navlog.replay.config import dump_yaml, from_mapping, suggest, to_mapping
from navlog.replay.limits import check_seed

OBSTACLE_HEIGHT = 1.0  # m: generated obstacles (above a 2D laser's plane, below nothing a robot passes)


@dataclass(frozen=True)
class BarnParams:
    rows: int = 30  # cells along y (BARN: 30)
    cols: int = 30  # cells along x (BARN: 30)
    cell: float = 0.15  # cell size in m (BARN: 0.15)
    fill: float = 0.3  # initial probability of an obstacle cell (BARN: 0.15-0.35)
    smoothing: int = 4  # cellular-automaton iterations (BARN: 0-4)
    fill_threshold: int = 5  # a cell becomes an obstacle with at least this many obstacle neighbours (of 8)
    clear_threshold: int = 3  # a cell becomes free with fewer than this many obstacle neighbours
    approach: float = 1.5  # free strip below and above the field, in m
    robot_radius: float = 0.25  # the robot that must pass from the lower strip to the upper one, in m
    tries: int = 20  # fields drawn before giving up on a passable one

    def __post_init__(self) -> None:
        if not (2 <= self.rows <= 400 and 2 <= self.cols <= 400):
            raise ValueError("rows and cols must be between 2 and 400")
        if not 0.0 <= self.fill < 1.0:
            raise ValueError(f"fill must be at least 0 and below 1 (a field of fill {self.fill} has no free cell)")
        if not (0.01 <= self.cell <= 5 and 0 <= self.smoothing <= 50 and 0.5 <= self.approach <= 50):
            raise ValueError("cell must be 0.01..5 m, smoothing 0..50, approach 0.5..50 m")
        if not 0 <= self.clear_threshold <= self.fill_threshold <= 9:
            raise ValueError("thresholds must satisfy 0 <= clear_threshold <= fill_threshold <= 9")
        if not (0 < self.robot_radius < 5 and 1 <= self.tries <= 1000):
            raise ValueError("robot_radius must be 0..5 m and tries 1..1000")


@dataclass(frozen=True)
class RoomParams:
    size: tuple[float, float] = (8.0, 8.0)  # inner extent x, y in m
    obstacles: int = 12  # boxes and cylinders placed at random
    min_size: float = 0.2  # smallest obstacle side or diameter, m
    max_size: float = 1.0  # largest, m

    def __post_init__(self) -> None:
        if not (min(self.size) >= 1 and max(self.size) <= 200):
            raise ValueError("size must be 1..200 m on each side")
        if not (0 <= self.obstacles <= 2000 and 0.05 <= self.min_size <= self.max_size <= min(self.size) / 2):
            raise ValueError("obstacles must be 0..2000 and 0.05 <= min_size <= max_size <= half the room")


@dataclass(frozen=True)
class CorridorParams:
    length: float = 12.0  # m, along x
    width: float = 2.0  # m
    doors: int = 3  # cross walls, evenly spaced, each with one doorway
    door_width: float = 0.9  # m
    wall_thickness: float = 0.1  # m

    def __post_init__(self) -> None:
        if not (2 <= self.length <= 500 and 0.5 <= self.width <= 50 and 0 <= self.doors <= 100):
            raise ValueError("length must be 2..500 m, width 0.5..50 m, doors 0..100")
        if not (0.1 <= self.door_width <= self.width and 0.02 <= self.wall_thickness <= 1):
            raise ValueError("door_width must be 0.1 m..width, wall_thickness 0.02..1 m")


@dataclass(frozen=True)
class OfficeParams:
    rooms: int = 4  # rooms on each side of the corridor
    room_width: float = 3.0  # m, along the corridor (x)
    room_depth: float = 3.0  # m, away from the corridor (y)
    corridor_width: float = 1.6  # m
    door_width: float = 0.9  # m
    furniture: int = 2  # boxes placed at random in each room (0..furniture)
    wall_thickness: float = 0.1  # m

    def __post_init__(self) -> None:
        if not (1 <= self.rooms <= 50 and 1.5 <= self.room_width <= 50 and 1.5 <= self.room_depth <= 50):
            raise ValueError("rooms must be 1..50, room_width and room_depth 1.5..50 m")
        if not (0.5 <= self.corridor_width <= 20 and 0.3 <= self.door_width <= self.room_width - 0.4):
            raise ValueError("corridor_width must be 0.5..20 m and door_width 0.3 m..room_width - 0.4 m")
        if not (0 <= self.furniture <= 20 and 0.02 <= self.wall_thickness <= 1):
            raise ValueError("furniture must be 0..20 and wall_thickness 0.02..1 m")


@dataclass
class GeneratedWorld:
    """A generated world: its spec (what the YAML holds), the world resolved into solids, and facts
    about it (``info``: generator, seed, parameters, and e.g. the BARN field's difficulty)."""

    spec: WorldSpec
    world: World
    info: dict[str, Any] = field(default_factory=dict)


# ---------------------------------------------------------------- BARN obstacle fields


def cellular_automaton(
    grid: np.ndarray, iterations: int, fill_threshold: int = 5, clear_threshold: int = 4
) -> np.ndarray:
    """``iterations`` smoothing steps: a cell becomes an obstacle when at least ``fill_threshold`` of its 8
    neighbours are, free when fewer than ``clear_threshold`` are, else stays (cells outside count as free)."""
    g = grid.astype(np.int8)
    for _ in range(iterations):
        p = np.pad(g, 1)
        n = sum(
            p[1 + dy : 1 + dy + g.shape[0], 1 + dx : 1 + dx + g.shape[1]]
            for dy in (-1, 0, 1)
            for dx in (-1, 0, 1)
            if dy or dx
        )
        g = np.where(n >= fill_threshold, 1, np.where(n < clear_threshold, 0, g)).astype(np.int8)
    return g.astype(bool)


def barn_field(params: BarnParams, seed: int) -> GeneratedWorld:
    """A passable BARN-style obstacle field (module docstring)."""
    from navlog.recorder.map_world import merge_cells
    from navlog.recorder.routes import optimal_path, true_grid

    p = params
    width, field_h = p.cols * p.cell, p.rows * p.cell
    height = field_h + 2 * p.approach
    y0 = -field_h / 2  # the field's lower edge; the world is centred on the origin
    for attempt in range(p.tries):
        rng = np.random.default_rng(np.random.SeedSequence([seed, attempt, 0x6261726E]))  # "barn"
        cells = cellular_automaton(
            rng.random((p.rows, p.cols)) < p.fill, p.smoothing, p.fill_threshold, p.clear_threshold
        )
        objects = [
            ObjectSpec(
                f"block_{i}",
                (round(-width / 2 + (c0 + cols / 2) * p.cell, 6), round(y0 + (r0 + rows / 2) * p.cell, 6), 0.0),
                shape="box",
                size=(round(cols * p.cell, 6), round(rows * p.cell, 6), OBSTACLE_HEIGHT),
            )
            for i, (r0, c0, rows, cols) in enumerate(merge_cells(cells))
        ]
        spec = WorldSpec(
            f"barn_{seed}",
            description=f"BARN-style field {p.rows} x {p.cols} x {p.cell} m, fill {p.fill}, smoothing {p.smoothing}, "
            f"seed {seed}",
            walls=WallsSpec((round(width, 6), round(height, 6)), thickness=0.1, height=OBSTACLE_HEIGHT),
            objects=objects,
        )
        world = resolve_world(spec, Path(f"<barn seed {seed}>"))
        grid = true_grid(world)
        start = (0.0, -field_h / 2 - p.approach / 2, math.pi / 2)
        goal = (0.0, field_h / 2 + p.approach / 2, math.pi / 2)
        path = optimal_path(grid, start, goal, p.robot_radius)
        if path is None:
            continue
        info = {
            "generator": "barn",
            "seed": seed,
            "attempt": attempt,
            "params": to_mapping(p),
            "fill_actual": round(float(cells.mean()), 4),
            "difficulty": round(path.difficulty, 4),
            "optimal_path_m": round(path.length_m, 4),
            "path_min_clearance_m": round(path.min_clearance_m, 4),
            "start": list(start),
            "goal": list(goal),
        }
        return GeneratedWorld(spec, world, info)
    raise ConfigError(
        f"barn generator (seed {seed}): no passable field for a robot of radius {p.robot_radius} m in {p.tries} "
        f"tries at fill {p.fill}; lower fill or robot_radius, or raise smoothing"
    )


# ---------------------------------------------------------------- rooms and corridors


def _walled_world(
    kind: str, seed: int, params: Any, size: tuple[float, float], description: str, objects: list[ObjectSpec]
) -> GeneratedWorld:
    """A generated world of ``objects`` inside walls of ``size`` (0.2 m thick, ``OBSTACLE_HEIGHT`` high),
    named ``KIND_SEED``, with the generator's record of itself."""
    spec = WorldSpec(
        f"{kind}_{seed}",
        description=description,
        walls=WallsSpec(size, thickness=0.2, height=OBSTACLE_HEIGHT),
        objects=objects,
    )
    world = resolve_world(spec, Path(f"<{kind} seed {seed}>"))
    return GeneratedWorld(spec, world, {"generator": kind, "seed": seed, "params": to_mapping(params)})


def cluttered_room(params: RoomParams, seed: int) -> GeneratedWorld:
    """A walled room with random boxes and cylinders (module docstring)."""
    p = params
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x726F6F6D]))  # "room"
    hx, hy = p.size[0] / 2, p.size[1] / 2
    objects = []
    for i in range(p.obstacles):
        s = rng.uniform(p.min_size, p.max_size, 2)
        x = rng.uniform(-hx + s.max() / 2, hx - s.max() / 2)
        y = rng.uniform(-hy + s.max() / 2, hy - s.max() / 2)
        yaw = rng.uniform(-math.pi, math.pi)
        if rng.random() < 0.5:
            size = (round(float(s[0]), 4), round(float(s[1]), 4), OBSTACLE_HEIGHT)
            objects.append(ObjectSpec(f"box_{i}", (round(x, 4), round(y, 4), round(yaw, 4)), shape="box", size=size))
        else:
            r = round(float(s[0]) / 2, 4)
            objects.append(
                ObjectSpec(f"cylinder_{i}", (round(x, 4), round(y, 4), 0.0), shape="cylinder", radius=r, height=1.0)
            )
    return _walled_world(
        "room",
        seed,
        p,
        (float(p.size[0]), float(p.size[1])),
        f"cluttered room {p.size[0]:g} x {p.size[1]:g} m, {p.obstacles} obstacles, seed {seed}",
        objects,
    )


def corridor(params: CorridorParams, seed: int) -> GeneratedWorld:
    """A corridor with cross walls, each with a doorway (module docstring)."""
    p = params
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x636F7272]))  # "corr"
    hy, t = p.width / 2, p.wall_thickness
    objects = []
    for k in range(p.doors):
        x = round(-p.length / 2 + (k + 1) * p.length / (p.doors + 1), 4)
        lo = rng.uniform(-hy, hy - p.door_width)  # the doorway spans [lo, lo + door_width]
        pieces = [(-hy, lo), (lo + p.door_width, hy)]
        for j, (a, b) in enumerate(pieces):
            if b - a < 0.01:
                continue
            objects.append(
                ObjectSpec(
                    f"door_{k}_{'ab'[j]}",
                    (x, round((a + b) / 2, 4), 0.0),
                    shape="box",
                    size=(t, round(b - a, 4), OBSTACLE_HEIGHT),
                )
            )
    return _walled_world(
        "corridor",
        seed,
        p,
        (float(p.length), float(p.width)),
        f"corridor {p.length:g} x {p.width:g} m, {p.doors} doorways of {p.door_width:g} m, seed {seed}",
        objects,
    )


def office(params: OfficeParams, seed: int) -> GeneratedWorld:
    """Rooms on both sides of a corridor, each with a doorway and furniture (module docstring)."""
    p = params
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x6F666663]))  # "offc"
    length, t = p.rooms * p.room_width, p.wall_thickness
    hy = p.corridor_width / 2 + p.room_depth
    objects: list[ObjectSpec] = []

    def box(name: str, x0: float, x1: float, y0: float, y1: float) -> None:
        if x1 - x0 > 0.01 and y1 - y0 > 0.01:
            pose = (round((x0 + x1) / 2, 4), round((y0 + y1) / 2, 4), 0.0)
            objects.append(
                ObjectSpec(name, pose, shape="box", size=(round(x1 - x0, 4), round(y1 - y0, 4), OBSTACLE_HEIGHT))
            )

    for side, sign in (("s", -1.0), ("n", 1.0)):
        wall_y = sign * p.corridor_width / 2  # the corridor wall of this side's rooms
        far = sign * hy
        for k in range(p.rooms):
            x0 = -length / 2 + k * p.room_width
            x1 = x0 + p.room_width
            if k > 0:  # the wall between room k - 1 and room k
                ya, yb = sorted((wall_y, far))
                box(f"{side}{k}_side", x0 - t / 2, x0 + t / 2, ya, yb)
            door = float(rng.uniform(x0 + 0.2, x1 - 0.2 - p.door_width))
            ya, yb = sorted((wall_y, wall_y + sign * t))
            box(f"{side}{k}_wall_a", x0, door, ya, yb)
            box(f"{side}{k}_wall_b", door + p.door_width, x1, ya, yb)
            # furniture along the far half of the room, clear of the doorway's approach
            for j in range(int(rng.integers(0, p.furniture + 1))):
                w, d = rng.uniform(0.4, 1.2), rng.uniform(0.4, 0.8)
                cx = float(rng.uniform(x0 + t + w / 2, x1 - t - w / 2))
                depth = p.room_depth - t
                cy = sign * (p.corridor_width / 2 + t + depth / 2 + float(rng.uniform(0, depth / 2 - d / 2)))
                box(f"{side}{k}_desk_{j}", cx - w / 2, cx + w / 2, cy - d / 2, cy + d / 2)
    return _walled_world(
        "office",
        seed,
        p,
        (round(length, 6), round(2 * hy, 6)),
        f"office: {p.rooms} + {p.rooms} rooms of {p.room_width:g} x {p.room_depth:g} m on a "
        f"{p.corridor_width:g} m corridor, doorways {p.door_width:g} m, seed {seed}",
        objects,
    )


GENERATORS: dict[str, tuple[type, Callable[[Any, int], GeneratedWorld]]] = {
    "barn": (BarnParams, barn_field),
    "room": (RoomParams, cluttered_room),
    "corridor": (CorridorParams, corridor),
    "office": (OfficeParams, office),
}


def generate_world(kind: str, seed: int, params: dict[str, Any] | None = None, where: str = "") -> GeneratedWorld:
    """The world of generator ``kind`` with ``params`` (a mapping of its parameters; checked, did-you-mean)
    and ``seed``. ``where`` prefixes errors (the file and key that asked for it)."""
    prefix = f"{where}: " if where else ""
    if kind not in GENERATORS:
        raise ConfigError(
            f"{prefix}unknown world generator '{kind}'{suggest(kind, GENERATORS)}; known: {', '.join(GENERATORS)}"
        )
    check_seed(seed, f"{prefix}seed")
    cls, fn = GENERATORS[kind]
    typed: Any = from_mapping(cls, params or {}, f"{where or kind} params")
    return fn(typed, seed)


def world_yaml(gen: GeneratedWorld) -> str:
    """The world YAML of a generated world (what ``load_world`` reads back into the same solids)."""
    doc = _without_defaults(to_mapping(gen.spec))
    header = "".join(f"# {k}: {v}\n" for k, v in gen.info.items() if k not in ("params",))
    params = ", ".join(f"{k}={v}" for k, v in gen.info.get("params", {}).items())
    header = f"# generated by navlog world-gen {gen.info.get('generator')} ({params})\n" + header
    return header + dump_yaml(doc)


def _without_defaults(doc: Any) -> Any:
    """The mapping without the keys an object leaves at their defaults (short YAML)."""
    out = dict(doc)
    out["objects"] = [
        {k: v for k, v in o.items() if v not in ("", 0.0, [0.0, 0.0, 0.0]) or k == "pose"} for o in out["objects"]
    ]
    if out.get("walls") is None:
        out.pop("walls", None)
    return out


def write_world_yaml(gen: GeneratedWorld, path: Path | str, *, force: bool = False) -> Path:
    """Write ``world_yaml(gen)`` to ``path`` whole (a temporary file renamed into place)."""
    from navlog.replay.io.atomic import write_file
    from navlog.replay.io.logwriter import check_output

    path = Path(path)
    check_output(path, force)
    write_file(path, world_yaml(gen).encode())
    return path
