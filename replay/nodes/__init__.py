"""Nodes that run on the executor, live or in replay: the adapters between messages and algorithms.

- ``OccupancyMapperNode`` (``OccupancyMapperParams``): scans and poses into the 2D log-odds grid, ``/map``;
- ``LidarMapperNode`` (``LidarMapperParams``): LiDAR sweeps, IMU and odometry into the 3D mapper's
  ``/Odometry``, ``/cloud_registered`` and a PCD;
- ``CostmapNode`` and ``PlannerNode``: the global costmap and the planner server, ``/plan``.

Names are imported on first use (the 3D mapper needs Open3D, the others do not).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams
    from navlog.replay.nodes.occupancy_mapper import OccupancyMapperNode, OccupancyMapperParams
    from navlog.replay.nodes.planner import CostmapNode, PlannerNode

__all__ = [
    "CostmapNode",
    "LidarMapperNode",
    "LidarMapperParams",
    "OccupancyMapperNode",
    "OccupancyMapperParams",
    "PlannerNode",
]

_MODULES = {
    "LidarMapperNode": "lidar_mapper",
    "LidarMapperParams": "lidar_mapper",
    "OccupancyMapperNode": "occupancy_mapper",
    "OccupancyMapperParams": "occupancy_mapper",
    "CostmapNode": "planner",
    "PlannerNode": "planner",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
