"""navlog: record, replay, test and inspect mobile-robot navigation logs without ROS.

The code lives in three packages: ``navlog.recorder`` (producing logs), ``navlog.replay`` (running
nodes over message streams) and ``navlog.analysis`` (metrics, reports, views, export). This package
holds the version, the errors, the command line and the public API of the whole distribution — the
functions the commands call, with the same arguments:

- recording (``navlog record``): ``prepare`` a world, robot and scenario, then ``record`` it to MCAP
  (``RecordSetup``, ``RecordResult``);
- replay (``navlog replay``): ``run_replay`` (``ReplayResult``, ``pipeline_params``); many logs in
  parallel (``navlog replay LOG LOG ...``): ``replay_fleet`` (``FleetResult``); logs: ``open_log``,
  ``recover_mcap`` (``navlog recover``);
- metrics (``navlog metrics``): ``compute_metrics`` (``MetricsOptions``);
- Rerun (``navlog view``): ``save_view`` (``ViewOptions``, ``ViewSummary``);
- export (``navlog export``): ``export_rosbag2`` (``BagOptions``), ``export_tum``;
- maps: ``write_world_map`` (``navlog world-map``), ``pcd_to_map`` (``navlog pcd-to-map``);
- planning (``navlog plan``): ``plan_on_map`` (``MapPlan``);
- navigation campaigns (``navlog campaign run``): ``run_campaign`` (``CampaignResult``);
- the main job end to end (``navlog demo``): ``run_demo`` (``DemoResult``);
- errors meant for users: ``NavlogError`` and its kinds ``ConfigError``, ``LogError``,
  ``TruncatedLogError``; and ``__version__``.

Names are imported on first use, so ``import navlog`` stays light (no numpy, MuJoCo, Open3D or Rerun).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.errors import ConfigError, LogError, NavlogError, TruncatedLogError
from navlog.replay import lazy_exports
from navlog.version import __version__

if TYPE_CHECKING:
    from navlog.analysis import (
        BagOptions,
        MetricsOptions,
        ViewOptions,
        compute_metrics,
        export_rosbag2,
        export_tum,
        save_view,
    )
    from navlog.analysis.export import pcd_to_map
    from navlog.analysis.fleet import FleetResult, replay_fleet
    from navlog.analysis.view import ViewSummary
    from navlog.campaign import CampaignResult, run_campaign
    from navlog.demo import DemoResult, run_demo
    from navlog.recorder.record import RecordResult, RecordSetup, prepare, record
    from navlog.recorder.world import write_world_map
    from navlog.replay import ReplayResult, open_log, pipeline_params, recover_mcap, run_replay
    from navlog.replay.pipelines.planner import MapPlan, plan_on_map

# public name -> the package or module, below this package, that defines or re-exports it
_MODULES = {
    "prepare": "recorder.record",
    "record": "recorder.record",
    "RecordSetup": "recorder.record",
    "RecordResult": "recorder.record",
    "run_replay": "replay",
    "ReplayResult": "replay",
    "pipeline_params": "replay",
    "open_log": "replay",
    "recover_mcap": "replay",
    "compute_metrics": "analysis",
    "MetricsOptions": "analysis",
    "save_view": "analysis",
    "ViewOptions": "analysis",
    "ViewSummary": "analysis.view",
    "export_rosbag2": "analysis",
    "export_tum": "analysis",
    "BagOptions": "analysis",
    "write_world_map": "recorder.world",
    "pcd_to_map": "analysis.export",
    "replay_fleet": "analysis.fleet",
    "FleetResult": "analysis.fleet",
    "plan_on_map": "replay.pipelines.planner",
    "MapPlan": "replay.pipelines.planner",
    "run_campaign": "campaign",
    "CampaignResult": "campaign",
    "run_demo": "demo",
    "DemoResult": "demo",
}

__all__ = [
    "BagOptions",
    "CampaignResult",
    "ConfigError",
    "DemoResult",
    "FleetResult",
    "LogError",
    "MapPlan",
    "MetricsOptions",
    "NavlogError",
    "RecordResult",
    "RecordSetup",
    "ReplayResult",
    "TruncatedLogError",
    "ViewOptions",
    "ViewSummary",
    "__version__",
    "compute_metrics",
    "export_rosbag2",
    "export_tum",
    "open_log",
    "pcd_to_map",
    "pipeline_params",
    "plan_on_map",
    "prepare",
    "record",
    "recover_mcap",
    "replay_fleet",
    "run_campaign",
    "run_demo",
    "run_replay",
    "save_view",
    "write_world_map",
]

__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
