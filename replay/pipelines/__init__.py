"""Replay pipelines: one module per pipeline, each registering one ``PipelineSpec`` of the module's name.

A pipeline is a class with a small explicit interface (``PipelineSpec``): its name, its ``Params``
dataclass (``params_class``; its YAML in ``config/pipelines/NAME.yaml``), the key a foreign parameter
file fills (``params_file_key``: the Nav2 file), ``settle`` (``auto`` parameters decided from the log),
``build`` (the run's ``Pipeline``: nodes and topics), and what the tools around a replay ask of it:
which CI facts its replays give, whether ``navlog metrics`` scores them, which parameter a CI world
map fills, the map and goals its parameters name.

``pipeline_names()`` lists the pipelines without importing any (the command line's help stays
instant); ``pipeline_spec(NAME)`` imports the one module and returns its registered class;
``PIPELINES`` holds the classes registered so far (``register`` adds one).
"""

from __future__ import annotations

import importlib
import pkgutil
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from navlog.errors import ConfigError

if TYPE_CHECKING:
    from navlog.replay.io.reader import LogReader
    from navlog.replay.runtime.pipeline import Pipeline

__all__ = [
    "PIPELINES",
    "PipelineSpec",
    "existing_file",
    "log_odometry",
    "pipeline_names",
    "pipeline_spec",
    "pipeline_specs",
    "register",
]

# the CI facts every replay gives (``navlog.analysis.ci.facts``): the navigation events of the log and
# the replay, and the flag that none is a collision
COMMON_FACTS = frozenset({"events", "no_collision"})


def log_odometry(reader: LogReader) -> tuple[str, str] | None:
    """(topic, frame) of the robot's odometry when a recording names them (its ``navlog`` metadata's
    ``odom_topic`` and ``odom_frame``: a robot whose drive plugin publishes elsewhere than /odom in the
    frame ``odom``), else None."""
    meta = reader.metadata.get("navlog", {})
    topic, frame = meta.get("odom_topic"), meta.get("odom_frame")
    if not topic and not frame:
        return None
    return topic or "/odom", frame or "odom"


class PipelineSpec:
    """A replay pipeline. Subclasses set the class attributes and define ``build``; they are never
    instantiated (every member is a class attribute or a class method).

    What a pipeline reads and publishes depends on its parameters and on the log (the mapper's LiDAR
    topic, the planner's /map when no static map is given), so the built ``Pipeline`` says it:
    ``inputs``, ``optional_inputs``, ``outputs``; what it reports, ``write_artifacts`` (its files)
    and ``report``.
    """

    name: ClassVar[str]
    params_class: ClassVar[type[Any]]  # its Params: a frozen dataclass, read from YAML by ``navlog.replay.config``
    # the parameter that ``--params FILE`` fills when the pipeline reads a foreign file (a Nav2
    # ``nav2_params.yaml``); None: ``--params`` is the pipeline's own YAML
    params_file_key: ClassVar[str | None] = None
    # the CI facts (first part of a fact's path, or a flag) its replays give
    facts: ClassVar[frozenset[str]] = COMMON_FACTS
    # the facts every CI case of it gathers for the reports, whether an invariant asks or not
    summary_facts: ClassVar[tuple[str, ...]] = ()
    # ``navlog metrics`` scores its replays (trajectory and maps against the log's ground truth)
    scored_by_metrics: ClassVar[bool] = False
    # the parameter a CI case's world map fills when the case does not set it (a static map), or None
    world_map_key: ClassVar[str | None] = None

    @classmethod
    def foreign_overrides(cls, params_file: Path) -> list[str] | None:
        """For a pipeline whose ``--params`` is its own YAML: when ``params_file`` is instead a file of the
        ROS tool it stands in for (the mapping pipeline's: slam_toolbox's parameter file), the ``KEY=VALUE``
        overrides of its own YAML that file's values amount to; None when it is the pipeline's own YAML."""
        return None

    @classmethod
    def settle(cls, params: Any, reader: LogReader, log_to: dict[str, str]) -> Any:
        """Before replaying: the parameters with their ``auto`` values decided from the log's content
        (``log_to``: the remaps, log topic -> pipeline topic). By default they are taken as they are."""
        return params

    @classmethod
    def build(cls, params: Any, log_topics: set[str]) -> Pipeline:
        """The run's nodes and topics for a log with ``log_topics`` (pipeline names, after remapping)."""
        raise NotImplementedError(f"pipeline '{cls.name}' has no build")

    @classmethod
    def static_map(cls, params: Any) -> Path | None:
        """The map_server YAML its parameters name (a static map, a map to localise on), when it exists."""
        return None

    @classmethod
    def goal_count(cls, params: Any) -> int | None:
        """How many goals its parameters give (a goals file), or None when it takes them from the log."""
        return None

    @classmethod
    def map_resolution(cls, params: Any) -> float | None:
        """The cell size (m) of the occupancy map it makes, or None when it makes none."""
        return None


PIPELINES: dict[str, type[PipelineSpec]] = {}


def existing_file(spec: str) -> Path | None:
    """A parameter naming a file, as a path when the file exists, else None (for ``static_map``)."""
    return Path(spec) if spec and Path(spec).is_file() else None


def register(spec: type[PipelineSpec]) -> type[PipelineSpec]:
    """Class decorator: add ``spec`` to ``PIPELINES`` under its name (one class per name)."""
    known = PIPELINES.get(spec.name)
    if known is not None and known is not spec:
        raise ValueError(f"pipeline '{spec.name}' is registered twice ({known.__qualname__}, {spec.__qualname__})")
    PIPELINES[spec.name] = spec
    return spec


def pipeline_names() -> list[str]:
    """The names of the pipeline modules in this package, sorted (nothing is imported)."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__))


def pipeline_spec(name: str) -> type[PipelineSpec]:
    """The registered pipeline ``name`` (its module imported); ConfigError with a suggestion when unknown."""
    from navlog.replay.config import suggest

    names = pipeline_names()
    if name not in names:
        raise ConfigError(f"unknown pipeline '{name}'{suggest(name, names)}; known: {', '.join(names)}")
    importlib.import_module(f"{__name__}.{name}")
    spec = PIPELINES.get(name)
    if spec is None:
        raise RuntimeError(f"module {__name__}.{name} registers no pipeline named '{name}'")
    return spec


def pipeline_specs() -> list[type[PipelineSpec]]:
    """Every pipeline (all their modules imported), by name."""
    return [pipeline_spec(n) for n in pipeline_names()]
