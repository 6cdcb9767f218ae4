"""Fleet replay: many logs through one pipeline, in parallel, with one summary table at the end.

- ``replay_fleet`` (``navlog replay LOG LOG ... -o OUT``, ``--workers N``, ``--ray [ADDRESS]``): every
  log into ``OUT/NAME/`` as ``navlog replay`` writes it, and ``OUT/fleet-summary.{json,csv,md}``;
  returns a ``FleetResult`` (``format_fleet`` prints it);
- the logs: ``collect_logs`` (paths, folders, globs, list files, fsspec URLs) -> ``LogSource``;
- one log: ``replay_log(LogJob) -> LogResult`` (never raises for a bad log; reuses an up-to-date
  output);
- where jobs run: ``InProcess``, ``ProcessPool`` (spawned workers; a dead worker loses one job),
  ``RayPool`` (one Ray task per log, local or on a cluster), driven by ``run_jobs`` (with retries).

Names are imported on first use: importing the package loads neither Ray nor fsspec.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.analysis.fleet.executors import InProcess, Lost, ProcessPool, RayPool, run_jobs
    from navlog.analysis.fleet.inputs import LogSource, collect_logs
    from navlog.analysis.fleet.run import FleetResult, format_fleet, replay_fleet
    from navlog.analysis.fleet.worker import LogJob, LogResult, replay_log

__all__ = [
    "FleetResult",
    "InProcess",
    "LogJob",
    "LogResult",
    "LogSource",
    "Lost",
    "ProcessPool",
    "RayPool",
    "collect_logs",
    "format_fleet",
    "replay_fleet",
    "replay_log",
    "run_jobs",
]

# public name -> the module of this package that defines it
_MODULES = {
    "InProcess": "executors",
    "Lost": "executors",
    "ProcessPool": "executors",
    "RayPool": "executors",
    "run_jobs": "executors",
    "LogSource": "inputs",
    "collect_logs": "inputs",
    "FleetResult": "run",
    "format_fleet": "run",
    "replay_fleet": "run",
    "LogJob": "worker",
    "LogResult": "worker",
    "replay_log": "worker",
}

__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
