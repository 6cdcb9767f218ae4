"""A CI suite: the YAML file ``navlog ci run`` reads, checked once, with did-you-mean on every key.

```yaml
name: navlog                      # default: the file's name without .yaml / .navlog-suite.yaml
baselines: ../../data/baselines   # relative to this file; default: data/baselines beside this file
cases:
  - name: planner_teleop
    recipe: {world: indoor_room, robot: go2, scenario: teleop, seed: 0, noise: true}   # or log: PATH
    pipeline: planner
    params: nav2_params.yaml      # optional: the pipeline's parameter file (relative to this file)
    overrides: [goals=indoor_room_waypoints]
    remap: {/cmd_vel_nav: /cmd_vel}
    world_map: {margin: 0.15}     # the world's map: the planner's static map, the mapper's reference
    checks:
      - diff: {tolerances: {path.cost_rtol: 0.02}, ignore: [replay.mcap]}
      - plans.failures == 0
      - min_clearance >= 0.3
```

A case of ``kind: campaign`` runs a campaign file instead and judges its summary
(``navlog.analysis.ci.campaign_case``): ``{name, kind: campaign, campaign: FILE, checks: [success_rate >= 0.9,
collisions == 0, not REGRESSED vs baseline]}``.

Every path is relative to the suite file (the baselines folder's default too). Errors name the suite file, the case and the key.
``checks`` omitted means one diff against the baseline with the default tolerances.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from navlog.analysis.ci.campaign_case import CampaignCheck, parse_campaign_check
from navlog.analysis.ci.invariants import Invariant, parse_invariant
from navlog.analysis.diff.tolerances import DEFAULT_TOLERANCES, DiffTolerances, parse_tolerances
from navlog.errors import ConfigError
from navlog.replay.config import load_yaml, suggest
from navlog.replay.limits import MAX_INFLATION_RADIUS_M

__all__ = ["Case", "DiffCheck", "Recipe", "Suite", "WorldMap", "load_suite", "suite_name"]

SUITE_KEYS = ("name", "baselines", "cases")
CASE_KEYS = (
    "name",
    "kind",
    "log",
    "recipe",
    "pipeline",
    "params",
    "overrides",
    "remap",
    "world_map",
    "checks",
    "campaign",
)
CASE_KINDS = ("replay", "campaign")
CAMPAIGN_KEYS = ("name", "kind", "campaign", "checks")
RECIPE_KEYS = ("world", "robot", "scenario", "seed", "noise")
WORLD_MAP_KEYS = ("world", "margin", "resolution")
DIFF_KEYS = ("tolerances", "ignore")
CASE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")
SUITE_SUFFIXES = (".navlog-suite.yaml", ".navlog-suite.yml", ".yaml", ".yml")


@dataclass(frozen=True)
class Recipe:
    """A golden log re-recorded deterministically: same recipe, same navlog, same bytes."""

    world: str
    robot: str
    scenario: str
    seed: int = 0
    noise: bool = True

    def to_dict(self) -> dict[str, Any]:
        return {
            "world": self.world,
            "robot": self.robot,
            "scenario": self.scenario,
            "seed": self.seed,
            "noise": self.noise,
        }


@dataclass(frozen=True)
class WorldMap:
    """A world's obstacles as a map_server map (``navlog world-map``). ``resolution`` None: the mapper's
    grid resolution in a mapping case (the reference must match the map), else 0.05 m."""

    world: str
    margin: float = 0.15
    resolution: float | None = None


@dataclass(frozen=True)
class DiffCheck:
    """The diff against the case's baseline: its tolerances and the outputs, topics or fields it ignores."""

    tolerances: DiffTolerances = DEFAULT_TOLERANCES
    ignore: tuple[str, ...] = ()
    tolerance_items: tuple[str, ...] = ()  # as written (SECTION.FIELD=VALUE), for reports


@dataclass(frozen=True)
class Case:
    name: str
    pipeline: str
    log: Path | None = None
    recipe: Recipe | None = None
    params: Path | None = None
    overrides: tuple[str, ...] = ()
    remap: tuple[tuple[str, str], ...] = ()
    world_map: WorldMap | None = None
    diff: DiffCheck | None = field(default_factory=DiffCheck)
    invariants: tuple[Invariant, ...] = ()
    kind: str = "replay"  # replay: a log through a pipeline; campaign: a campaign file run and judged
    campaign: Path | None = None  # the campaign file of a campaign case
    campaign_checks: tuple[CampaignCheck, ...] = ()  # its thresholds

    @property
    def source(self) -> str:
        """The log as people read it: the path, or the recipe."""
        if self.campaign is not None:
            return f"campaign {self.campaign.name}"
        if self.recipe is not None:
            r = self.recipe
            return f"recipe {r.world}/{r.robot}/{r.scenario} seed {r.seed}" + ("" if r.noise else " no noise")
        return str(self.log)


@dataclass(frozen=True)
class Suite:
    name: str
    path: Path
    cases: tuple[Case, ...]
    baselines: Path | None = None  # None: data/baselines in the suite file's folder

    def case(self, name: str) -> Case:
        for c in self.cases:
            if c.name == name:
                return c
        names = [c.name for c in self.cases]
        raise ConfigError(f"{self.path}: no case '{name}'{suggest(name, names)}; cases: {', '.join(names)}")


def suite_name(path: Path) -> str:
    """The suite's default name: its file name without the suite suffix."""
    for suffix in SUITE_SUFFIXES:
        if path.name.endswith(suffix):
            return path.name[: -len(suffix)]
    return path.stem


class _Where:
    """Error text naming the suite file, the case and the key."""

    def __init__(self, path: Path, case: str = "") -> None:
        self.path, self.case = path, case

    def error(self, key: str, message: str) -> ConfigError:
        where = f"case '{self.case}'" if self.case else "suite"
        return ConfigError(f"{self.path}: {where}: {key}: {message}")

    def keys(self, data: Any, allowed: Sequence[str], key: str) -> Mapping[str, Any]:
        if not isinstance(data, Mapping):
            raise self.error(key, f"expected a mapping with keys {', '.join(allowed)}, got {data!r}")
        for k in data:
            if k not in allowed:
                raise self.error(
                    f"{key}.{k}" if key else str(k),
                    f"unknown key{suggest(str(k), allowed)}; allowed: {', '.join(allowed)}",
                )
        return data

    def text(self, value: Any, key: str) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.error(key, f"expected a non-empty string, got {value!r}")
        return value.strip()

    def number(self, value: Any, key: str, *, minimum: float | None = None, maximum: float = float("inf")) -> float:
        """A number > 0 (or >= ``minimum`` when given), at most ``maximum``."""
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        if not ok or not (value >= minimum if minimum is not None else value > 0) or not value <= maximum:
            bound = f">= {minimum:g}" if minimum is not None else "> 0"
            bound += f" and <= {maximum:g}" if maximum < float("inf") else ""
            raise self.error(key, f"expected a number {bound}, got {value!r}")
        return float(value)

    def strings(self, value: Any, key: str) -> tuple[str, ...]:
        if value is None:
            return ()
        if not isinstance(value, list) or not all(isinstance(v, str | int | float) for v in value):
            raise self.error(key, f"expected a list of strings, got {value!r}")
        return tuple(str(v) for v in value)


def load_suite(path: Path | str) -> Suite:
    """Read and check a suite file; every problem raises ``ConfigError`` naming the file, case and key."""
    from navlog.replay.pipelines import pipeline_names

    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such suite file")
    root = _Where(path)
    data = root.keys(load_yaml(path), SUITE_KEYS, "")
    cases_data = data.get("cases")
    if not isinstance(cases_data, list) or not cases_data:
        raise root.error("cases", "expected a non-empty list of cases")
    name = root.text(data["name"], "name") if "name" in data else suite_name(path)
    if not CASE_NAME.match(name):
        raise root.error("name", f"'{name}' must be letters, digits, '_', '-' or '.' (it names the baselines folder)")
    baselines = path.parent / root.text(data["baselines"], "baselines") if "baselines" in data else None
    pipelines = pipeline_names()
    cases: list[Case] = []
    for i, item in enumerate(cases_data):
        named = item.get("name") if isinstance(item, Mapping) else None
        label = named if isinstance(named, str) else f"#{i + 1}"
        case = _case(item, _Where(path, label), path.parent, pipelines)
        if any(c.name == case.name for c in cases):
            raise root.error(f"cases[{i}].name", f"'{case.name}' is used by two cases; names must be unique")
        cases.append(case)
    return Suite(name, path, tuple(cases), baselines)


def _case(data: Any, at: _Where, base: Path, pipelines: Sequence[str]) -> Case:
    data = at.keys(data, CASE_KEYS, "")
    kind = data.get("kind", "replay")
    if kind not in CASE_KINDS:
        raise at.error(
            "kind", f"unknown case kind {kind!r}{suggest(str(kind), CASE_KINDS)}; known: {', '.join(CASE_KINDS)}"
        )
    if kind == "campaign":
        return _campaign_case(data, at, base)
    name = _case_name(data, at, "pipeline", "the baseline folder")
    pipeline = at.text(data["pipeline"], "pipeline")
    if pipeline not in pipelines:
        raise at.error(
            "pipeline", f"unknown pipeline '{pipeline}'{suggest(pipeline, pipelines)}; known: {', '.join(pipelines)}"
        )
    if ("log" in data) == ("recipe" in data):
        raise at.error("log", "give exactly one of log (a path) or recipe (world, robot, scenario, seed, noise)")
    log = base / at.text(data["log"], "log") if "log" in data else None
    recipe = _recipe(data["recipe"], at) if "recipe" in data else None
    params = base / at.text(data["params"], "params") if data.get("params") else None
    if params is not None and not params.is_file():
        raise at.error("params", f"{params}: no such parameter file")
    overrides = at.strings(data.get("overrides"), "overrides")
    for o in overrides:
        if "=" not in o:
            raise at.error("overrides", f"'{o}': expected KEY=VALUE, e.g. occupancy.grid.resolution=0.1")
    remap_data = data.get("remap") or {}
    if not isinstance(remap_data, Mapping) or not all(isinstance(v, str) for v in remap_data.values()):
        raise at.error("remap", f"expected a mapping PIPELINE_TOPIC: LOG_TOPIC, got {remap_data!r}")
    remap = tuple(sorted((str(k), str(v)) for k, v in remap_data.items()))
    world_map = _world_map(data["world_map"], at, recipe) if data.get("world_map") is not None else None
    diff, invariants = _checks(data.get("checks"), at, pipeline)
    return Case(name, pipeline, log, recipe, params, overrides, remap, world_map, diff, invariants)


def _case_name(data: Mapping[str, Any], at: _Where, required: str, names: str) -> str:
    """A case's name, after checking that it and ``required`` are given (the name ``names`` a folder)."""
    for key in ("name", required):
        if key not in data:
            raise at.error(key, "required key is missing")
    name = at.text(data["name"], "name")
    if not CASE_NAME.match(name):
        raise at.error("name", f"'{name}' must be letters, digits, '_', '-' or '.' (it names {names})")
    return name


def _campaign_case(data: Mapping[str, Any], at: _Where, base: Path) -> Case:
    """A case of kind campaign: its campaign file and thresholds (``navlog.analysis.ci.campaign_case``)."""
    data = at.keys(data, CAMPAIGN_KEYS, "")
    name = _case_name(data, at, "campaign", "the output folder")
    campaign = base / at.text(data["campaign"], "campaign")
    if not campaign.is_file():
        raise at.error("campaign", f"{campaign}: no such campaign file")
    items = data.get("checks")
    if not isinstance(items, list) or not items or not all(isinstance(i, str) for i in items):
        raise at.error("checks", f"expected a non-empty list of thresholds (e.g. 'success_rate >= 0.9'), got {items!r}")
    checks = []
    for i, text in enumerate(items):
        try:
            checks.append(parse_campaign_check(text))
        except ConfigError as exc:
            raise at.error(f"checks[{i}]", str(exc)) from None
    return Case(name, "campaign", diff=None, kind="campaign", campaign=campaign, campaign_checks=tuple(checks))


def _recipe(data: Any, at: _Where) -> Recipe:
    data = at.keys(data, RECIPE_KEYS, "recipe")
    for key in ("world", "robot", "scenario"):
        if key not in data:
            raise at.error(f"recipe.{key}", "required key is missing")
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise at.error("recipe.seed", f"expected an integer >= 0, got {seed!r}")
    noise = data.get("noise", True)
    if not isinstance(noise, bool):
        raise at.error("recipe.noise", f"expected true or false, got {noise!r}")
    return Recipe(
        at.text(data["world"], "recipe.world"),
        at.text(data["robot"], "recipe.robot"),
        at.text(data["scenario"], "recipe.scenario"),
        seed,
        noise,
    )


def _world_map(data: Any, at: _Where, recipe: Recipe | None) -> WorldMap:
    data = at.keys(data, WORLD_MAP_KEYS, "world_map")
    world = data.get("world") or (recipe.world if recipe is not None else None)
    if world is None:
        raise at.error("world_map.world", "required when the case reads a log file (a recipe names its world)")
    return WorldMap(
        at.text(world, "world_map.world"),
        at.number(data.get("margin", 0.15), "world_map.margin", minimum=0.0, maximum=MAX_INFLATION_RADIUS_M),
        at.number(data["resolution"], "world_map.resolution") if "resolution" in data else None,
    )


def _checks(data: Any, at: _Where, pipeline: str) -> tuple[DiffCheck | None, tuple[Invariant, ...]]:
    if data is None:
        return DiffCheck(), ()
    if not isinstance(data, list):
        raise at.error("checks", f"expected a list of checks (a diff mapping or invariant strings), got {data!r}")
    diff: DiffCheck | None = None
    invariants: list[Invariant] = []
    for i, item in enumerate(data):
        key = f"checks[{i}]"
        if isinstance(item, str):
            try:
                invariants.append(parse_invariant(item, pipeline))
            except ConfigError as exc:
                raise at.error(key, str(exc)) from None
            continue
        body = at.keys(item, ("diff",), key).get("diff")
        if diff is not None:
            raise at.error(key, "a case has one diff check")
        diff = _diff(body, at, f"{key}.diff")
    return diff, tuple(invariants)


def _diff(data: Any, at: _Where, key: str) -> DiffCheck:
    if data is None:
        return DiffCheck()
    data = at.keys(data, DIFF_KEYS, key)
    tol_data = data.get("tolerances") or {}
    if not isinstance(tol_data, Mapping):
        raise at.error(f"{key}.tolerances", f"expected a mapping SECTION.FIELD: value, got {tol_data!r}")
    items = tuple(f"{k}={v}" for k, v in sorted(tol_data.items(), key=lambda kv: str(kv[0])))  # keys may be numbers
    try:
        tolerances = parse_tolerances(items)
    except ConfigError as exc:
        raise at.error(f"{key}.tolerances", str(exc).replace("--tol ", "")) from None
    return DiffCheck(tolerances, at.strings(data.get("ignore"), f"{key}.ignore"), items)
