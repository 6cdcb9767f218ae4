"""Running nodes over message streams: log readers and writers, the executor, TF, nodes, pipelines.

This package imports neither ``navlog.recorder`` nor ``navlog.analysis``; both of those build on it.

Its public API, imported on first use so that importing the package stays cheap:

- logs (``navlog.replay.io``): ``open_log``, ``LogReader``, ``McapLogWriter``, ``recover_mcap``;
- maps: ``OccupancyMap`` (``navlog.replay.occupancy_map``), ``load_map``, ``save_map`` (``navlog.replay.io``);
- running nodes (``navlog.replay.runtime``): ``Executor``, ``Node``, ``Envelope``, ``TFBuffer``,
  ``Pipeline``;
- replaying a log through a pipeline (``navlog.replay.runtime``): ``run_replay``, ``ReplayResult``,
  ``pipeline_names``, ``pipeline_params``.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from navlog.replay.io.formats import open_log
    from navlog.replay.io.logwriter import McapLogWriter
    from navlog.replay.io.map_server import load_map, save_map
    from navlog.replay.io.reader import LogReader
    from navlog.replay.io.recovery import recover_mcap
    from navlog.replay.occupancy_map import OccupancyMap
    from navlog.replay.pipelines import pipeline_names
    from navlog.replay.runtime.executor import Envelope, Executor, Node
    from navlog.replay.runtime.pipeline import Pipeline
    from navlog.replay.runtime.tf import TFBuffer
    from navlog.replay.session import ReplayResult, pipeline_params, run_replay


def lazy_exports(package: str, modules: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A package's module ``__getattr__`` and ``__dir__`` (PEP 562) that import each public name from
    ``package.<modules[name]>`` on its first use and keep it in the package."""
    namespace = sys.modules[package].__dict__

    def __getattr__(name: str) -> Any:
        module = modules.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted({*namespace, *modules})

    return __getattr__, __dir__


__all__ = [
    "Envelope",
    "Executor",
    "LogReader",
    "McapLogWriter",
    "Node",
    "OccupancyMap",
    "Pipeline",
    "ReplayResult",
    "TFBuffer",
    "load_map",
    "open_log",
    "pipeline_names",
    "pipeline_params",
    "recover_mcap",
    "run_replay",
    "save_map",
]

# the module, below this package, that defines each public name
_MODULES = {
    "open_log": "io.formats",
    "LogReader": "io.reader",
    "McapLogWriter": "io.logwriter",
    "recover_mcap": "io.recovery",
    "OccupancyMap": "occupancy_map",
    "load_map": "io.map_server",
    "save_map": "io.map_server",
    "Envelope": "runtime.executor",
    "Executor": "runtime.executor",
    "Node": "runtime.executor",
    "TFBuffer": "runtime.tf",
    "Pipeline": "runtime.pipeline",
    "ReplayResult": "session",
    "pipeline_names": "pipelines",
    "pipeline_params": "session",
    "run_replay": "session",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
