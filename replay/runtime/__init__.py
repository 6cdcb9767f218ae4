"""Running nodes over message streams: the executor, the TF buffer, the pipeline protocol, progress.

- ``Executor`` delivers ``Envelope``\\ s to ``Node``\\ s in one deterministic order and fires their timers;
- ``TFBuffer`` looks transforms up by sim time;
- ``Pipeline`` is what a replay pipeline module builds (``navlog.replay.session`` runs one over a log);
- ``Progress`` shows progress on stderr; ``format_table`` renders summary tables;
- ``usable_cpus`` counts the CPUs this process may run on (whether a helper process beside it pays).

Names are imported on first use, so importing the package stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.runtime.cpus import usable_cpus
    from navlog.replay.runtime.executor import Envelope, Executor, Node, Sink, Stats
    from navlog.replay.runtime.pipeline import Pipeline
    from navlog.replay.runtime.progress import Progress, format_table
    from navlog.replay.runtime.tf import TFBuffer, TransformError, WaitingForTransforms

__all__ = [
    "Envelope",
    "Executor",
    "Node",
    "Pipeline",
    "Progress",
    "Sink",
    "Stats",
    "TFBuffer",
    "TransformError",
    "WaitingForTransforms",
    "format_table",
    "usable_cpus",
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
    "WaitingForTransforms": "tf",
    "Pipeline": "pipeline",
    "Progress": "progress",
    "format_table": "progress",
    "usable_cpus": "cpus",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
