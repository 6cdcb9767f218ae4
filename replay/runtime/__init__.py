"""Running nodes over message streams: the executor, the TF buffer, pipelines, the replay session, progress.

- ``Executor`` delivers ``Envelope``\\ s to ``Node``\\ s in one deterministic order and fires their timers;
- ``TFBuffer`` looks transforms up by sim time;
- ``Pipeline`` is what a replay pipeline module builds; ``run_replay`` replays a log through one into
  a ``ReplayResult`` (``pipeline_names``, ``pipeline_params``, ``load_pipeline_module``, ``parse_remaps``);
- ``Progress`` shows progress on stderr; ``format_table`` renders summary tables.

Names are imported on first use, so importing the package stays cheap (and ``navlog.replay.io``,
which the session uses, can import the executor without a cycle).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.runtime.executor import Envelope, Executor, Node, Sink, Stats
    from navlog.replay.runtime.pipeline import Pipeline
    from navlog.replay.runtime.progress import Progress, format_table
    from navlog.replay.runtime.session import (
        ReplayResult,
        load_pipeline_module,
        parse_remaps,
        pipeline_names,
        pipeline_params,
        run_replay,
    )
    from navlog.replay.runtime.tf import TFBuffer, TransformError

__all__ = [
    "Envelope",
    "Executor",
    "Node",
    "Pipeline",
    "Progress",
    "ReplayResult",
    "Sink",
    "Stats",
    "TFBuffer",
    "TransformError",
    "format_table",
    "load_pipeline_module",
    "parse_remaps",
    "pipeline_names",
    "pipeline_params",
    "run_replay",
]

# the module, below this package, that defines each public name
_MODULES = {
    "Envelope": "executor",
    "Executor": "executor",
    "Node": "executor",
    "Sink": "executor",
    "Stats": "executor",
    "TFBuffer": "tf",
    "TransformError": "tf",
    "Pipeline": "pipeline",
    "ReplayResult": "session",
    "load_pipeline_module": "session",
    "parse_remaps": "session",
    "pipeline_names": "session",
    "pipeline_params": "session",
    "run_replay": "session",
    "Progress": "progress",
    "format_table": "progress",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
