"""Metrics, Rerun views, export and log summaries: what navlog does with a log and its replay.

- ``navlog.analysis.metrics``: trajectory errors (ATE, RPE), 2D and 3D map quality, the metrics
  report (``compute_metrics``, ``MetricsOptions``);
- ``navlog.analysis.view``: Rerun recordings of a log and its replay outputs (``ViewOptions``,
  ``build_view``, ``save_view``, ``stream_view``);
- ``navlog.analysis.export``: ROS 2 bags and TUM trajectories (``export_rosbag2``, ``BagOptions``,
  ``export_tum``; a PCD map as a map_server map: ``pcd_to_map``);
- ``navlog.analysis.info``: a log's summary (``summarize``, ``format_info``);
- ``navlog.analysis.check``: is a log fit to replay (``check_log``, ``LogCheck``, ``format_check``);
- ``navlog.analysis.diff``: what moved between two replays or two logs (``DiffTolerances``,
  ``DiffReport``; the function is ``navlog.analysis.diff.diff``).
- ``navlog.analysis.fleet``: many logs replayed in parallel (a process pool or Ray) with one summary
  table (``replay_fleet``, ``FleetResult``).

Names are imported on first use, so importing the package loads neither Rerun, Open3D nor scipy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.analysis.check import LogCheck, check_log, format_check
    from navlog.analysis.diff import DiffReport, DiffTolerances
    from navlog.analysis.export import BagOptions, export_rosbag2, export_tum, pcd_to_map
    from navlog.analysis.info import format_info, summarize
    from navlog.analysis.metrics import MetricsOptions, Trajectory, compute_metrics
    from navlog.analysis.view import ViewOptions, build_view, save_view, stream_view

__all__ = [
    "BagOptions",
    "DiffReport",
    "DiffTolerances",
    "LogCheck",
    "MetricsOptions",
    "Trajectory",
    "ViewOptions",
    "build_view",
    "check_log",
    "compute_metrics",
    "export_rosbag2",
    "export_tum",
    "format_check",
    "format_info",
    "pcd_to_map",
    "save_view",
    "stream_view",
    "summarize",
]

# public name -> the subpackage or module of this package that defines it
_MODULES = {
    "MetricsOptions": "metrics",
    "Trajectory": "metrics",
    "compute_metrics": "metrics",
    "ViewOptions": "view",
    "build_view": "view",
    "save_view": "view",
    "stream_view": "view",
    "BagOptions": "export",
    "export_rosbag2": "export",
    "export_tum": "export",
    "pcd_to_map": "export",
    "format_info": "info",
    "summarize": "info",
    "LogCheck": "check",
    "check_log": "check",
    "format_check": "check",
    "DiffReport": "diff",
    "DiffTolerances": "diff",
}

__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
