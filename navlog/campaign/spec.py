"""A campaign file: which worlds, robots, Nav2 variants, routes and seeds to run, typed and checked once.

```yaml
name: small
worlds:
  - {generate: barn, count: 3, seed: 0, params: {fill: 0.3}}   # generated (seeds 0, 1, 2)
  - {file: config/worlds/walled_room.yaml}                     # any world navlog reads
  - {glob: "worlds/*.sdf"}
robots: [go2]
variants:
  - {name: baseline, nav2_params: nav_go2}
  - {name: slow, nav2_params: nav_go2, set: ["FollowPath.desired_linear_vel=0.15"]}
routes: {kind: auto, count: 1, min_distance: 2.5}
seeds: [0, 1]
max_duration: 60
```

Every error names the file and the key, with a did-you-mean for a misspelt key (``from_mapping``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from navlog.errors import ConfigError
from navlog.replay.config import from_mapping, load_yaml, param
from navlog.replay.limits import MAX_SEED

MIN_MAX_DURATION_S = 1.0  # s: the shortest max_duration, a second of sim time (no goal is reached sooner)


@dataclass(frozen=True)
class WorldSource:
    file: str = ""  # a world: a name in config/worlds, a world YAML, an SDF world or a map_server map YAML
    glob: str = ""  # world files matching a glob pattern (relative to the campaign file)
    generate: str = ""  # a world generator: barn, room, corridor or office (`navlog world-gen`)
    count: int = 1  # generated worlds (seeds seed, seed + 1, ...)
    seed: int = 0  # the first generated world's seed
    params: dict[str, Any] = field(default_factory=dict)  # the generator's parameters

    def __post_init__(self) -> None:
        if sum(bool(v) for v in (self.file, self.glob, self.generate)) != 1:
            raise ValueError("give exactly one of file, glob or generate")
        if not 1 <= self.count <= 100_000 or self.seed < 0:
            raise ValueError("count must be 1..100000 and seed non-negative")


@dataclass(frozen=True)
class VariantSpec:
    name: str  # how reports call it (letters, digits, - and _)
    nav2_params: str  # a Nav2 parameter file: a name in config/nav2 or a path
    set: list[str] = field(default_factory=list)  # KEY=VALUE overrides of the file (full or short key paths)

    def __post_init__(self) -> None:
        if not self.name or not all(c.isalnum() or c in "-_" for c in self.name):
            raise ValueError(f"variant name {self.name!r}: use letters, digits, - and _")


@dataclass(frozen=True)
class RouteSpec:
    # auto: a generated field's own start and goal (BARN: across the field), else random
    kind: Literal["auto", "random", "fixed"] = "auto"
    count: int = 1  # routes per world, robot and seed (random)
    min_distance: float = 2.0  # m between a random start and goal
    margin: float = 0.1  # m of clearance at a random start or goal beyond the robot's radius and map_margin
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)  # fixed: x, y, yaw
    goal: tuple[float, float, float] = (0.0, 0.0, 0.0)  # fixed: x, y, yaw

    def __post_init__(self) -> None:
        if not 1 <= self.count <= 1000 or not 0 < self.min_distance < 1e4 or not 0 <= self.margin < 10:
            raise ValueError("count must be 1..1000, min_distance positive, margin 0..10 m")


@dataclass(frozen=True)
class CampaignSpec:
    name: str
    worlds: list[WorldSource]
    robots: list[str]  # robot names or description files
    variants: list[VariantSpec]
    routes: RouteSpec = field(default_factory=RouteSpec)
    seeds: list[int] = field(default_factory=lambda: [0])  # each run's seed (sensor noise, MPPI, AMCL)
    noise: bool = True  # sensor and odometry noise
    localization: Literal["perfect", "amcl"] = "perfect"  # what publishes map -> odom
    # s of sim time (1 s .. a day); a goal still open then is a timeout
    max_duration: float = param(120.0, ge=MIN_MAX_DURATION_S, le=86400.0)
    map_margin: float = 0.15  # m: the world's obstacles grown by it on /map (the static layer)
    wall_timeout: float = 900.0  # s of wall time after which a run counts as hung (a failed row)
    baseline: str = ""  # the variant the others are compared with (default: the first)
    alpha: float = 0.05  # significance level of the paired comparison
    description: str = ""

    def __post_init__(self) -> None:
        if not self.worlds or not self.robots or not self.variants or not self.seeds:
            raise ValueError("worlds, robots, variants and seeds must each list at least one entry")
        names = [v.name for v in self.variants]
        if len(set(names)) != len(names):
            raise ValueError(f"variant names must be unique, got {names}")
        if self.baseline and self.baseline not in names:
            from navlog.replay.config import suggest

            raise ValueError(f"baseline '{self.baseline}' is not a variant{suggest(self.baseline, names)}")
        for i, seed in enumerate(self.seeds):
            if not 0 <= seed <= MAX_SEED:
                raise ValueError(f"seeds[{i}]: {seed}: seeds must be unique integers from 0 to {MAX_SEED}")
            if seed in self.seeds[:i]:
                raise ValueError(
                    f"seeds[{i}]: {seed} is seeds[{self.seeds.index(seed)}] again: seeds must be unique integers "
                    f"from 0 to {MAX_SEED}"
                )
        if not (0 <= self.map_margin <= 5 and self.wall_timeout > 0):
            raise ValueError("map_margin must be 0..5 m, wall_timeout positive")
        if not 0 < self.alpha < 0.5:
            raise ValueError("alpha must be between 0 and 0.5")

    @property
    def baseline_variant(self) -> str:
        return self.baseline or self.variants[0].name


def load_campaign(path: Path | str) -> CampaignSpec:
    """The campaign file at ``path``, typed and checked (ConfigError naming the file and key)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such campaign file")
    doc = load_yaml(path)
    try:
        return from_mapping(CampaignSpec, doc)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
