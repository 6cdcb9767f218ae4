"""Nodes that run on the executor, live or in replay: the adapters between messages and algorithms.

- ``OccupancyMapperNode`` (``OccupancyMapperParams``): scans and poses into the 2D log-odds grid, ``/map``;
- ``LidarMapperNode`` (``LidarMapperParams``): LiDAR sweeps, IMU and odometry into the 3D mapper's
  ``/Odometry``, ``/cloud_registered`` and a PCD;
- ``CostmapNode`` and ``PlannerNode``: the global costmap and the planner server, ``/plan``;
- ``VelocitySmootherNode``: Nav2's velocity smoother, ``/cmd_vel_nav`` -> ``/cmd_vel_smoothed``;
- ``CollisionMonitorNode``: Nav2's collision monitor, ``/cmd_vel_smoothed`` -> ``/cmd_vel``, its state as events;
- ``AmclNode``: Nav2's AMCL on a map, /scan and odometry TF -> ``/amcl_pose``, ``/particle_cloud``, map -> odom;
- ``SlamNode`` (``SlamNodeParams``): 2D SLAM (slam_toolbox's role), /scan and odometry TF -> ``/map``, map -> odom,
  the pose graph and the trajectory;
- ``NavigationStack`` (``NavGoal``, ``GoalResult``): both costmaps and ``NavigationNode`` (navigator, planner,
  controller server, behaviours) -> ``/plan``, ``/cmd_vel_nav``, ``/local_plan``, goal results and events.

Names are imported on first use (the 3D mapper needs Open3D, the others do not).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.nodes.amcl import AmclNode
    from navlog.replay.nodes.collision_monitor import CollisionMonitorNode
    from navlog.replay.nodes.costmap import CostmapNode
    from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams
    from navlog.replay.nodes.navigation import GoalResult, NavGoal, NavigationNode, NavigationStack
    from navlog.replay.nodes.occupancy_mapper import OccupancyMapperNode, OccupancyMapperParams
    from navlog.replay.nodes.planner import PlannerNode
    from navlog.replay.nodes.slam import SlamNode, SlamNodeParams
    from navlog.replay.nodes.velocity_smoother import VelocitySmootherNode

__all__ = [
    "AmclNode",
    "CollisionMonitorNode",
    "CostmapNode",
    "GoalResult",
    "LidarMapperNode",
    "LidarMapperParams",
    "NavGoal",
    "NavigationNode",
    "NavigationStack",
    "OccupancyMapperNode",
    "OccupancyMapperParams",
    "PlannerNode",
    "SlamNode",
    "SlamNodeParams",
    "VelocitySmootherNode",
]

_MODULES = {
    "AmclNode": "amcl",
    "CollisionMonitorNode": "collision_monitor",
    "LidarMapperNode": "lidar_mapper",
    "LidarMapperParams": "lidar_mapper",
    "OccupancyMapperNode": "occupancy_mapper",
    "OccupancyMapperParams": "occupancy_mapper",
    "CostmapNode": "costmap",
    "GoalResult": "navigation",
    "NavGoal": "navigation",
    "NavigationNode": "navigation",
    "NavigationStack": "navigation",
    "PlannerNode": "planner",
    "SlamNode": "slam",
    "SlamNodeParams": "slam",
    "VelocitySmootherNode": "velocity_smoother",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
