"""Mapping algorithms as pure computation on numpy arrays (no logs, no executor, no files).

- the 2D occupancy grid (``navlog.replay.mapping.occupancy``): ``OccupancyGrid2D`` fused from laser
  scans at known poses (``OccupancyParams``, ``ScanStats``), and ``project_points``, a 3D point map
  projected to a 2D grid between two heights;
- the LiDAR odometry (``navlog.replay.mapping.lidar_odometry``, Open3D): ``LidarOdometry`` with its
  ``LidarOdometryParams``, motion priors (``MotionPrior``, ``GyroTrack``, ``PoseTrack``) and per-frame
  ``FrameResult``;
- the 2D SLAM (``navlog.replay.mapping.slam2d``, gtsam): ``Slam2D`` with its ``SlamParams`` (slam_toolbox's
  names), the correlative ``ScanMatcher`` and the ``PoseGraph``.

Names are imported on first use, so the occupancy grid's users do not load Open3D.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.mapping.lidar_odometry import (
        FrameResult,
        GyroTrack,
        LidarOdometry,
        LidarOdometryParams,
        MotionPrior,
        PoseTrack,
    )
    from navlog.replay.mapping.occupancy import OccupancyGrid2D, OccupancyParams, ScanStats, project_points
    from navlog.replay.mapping.slam2d import PoseGraph, ScanMatcher, Slam2D, SlamParams

__all__ = [
    "FrameResult",
    "GyroTrack",
    "LidarOdometry",
    "LidarOdometryParams",
    "MotionPrior",
    "OccupancyGrid2D",
    "OccupancyParams",
    "PoseGraph",
    "PoseTrack",
    "ScanMatcher",
    "ScanStats",
    "Slam2D",
    "SlamParams",
    "project_points",
]

# the module, below this package, that defines each public name
_MODULES = {
    "OccupancyGrid2D": "occupancy",
    "OccupancyParams": "occupancy",
    "ScanStats": "occupancy",
    "project_points": "occupancy",
    "FrameResult": "lidar_odometry",
    "GyroTrack": "lidar_odometry",
    "LidarOdometry": "lidar_odometry",
    "LidarOdometryParams": "lidar_odometry",
    "MotionPrior": "lidar_odometry",
    "PoseTrack": "lidar_odometry",
    "PoseGraph": "slam2d",
    "ScanMatcher": "slam2d",
    "Slam2D": "slam2d",
    "SlamParams": "slam2d",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
