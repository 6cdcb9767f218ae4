"""LiDAR odometry and mapping (the FAST-LIO role), as pure computation on numpy arrays.

Per frame (points in the sensor frame, per-point times in seconds after the frame stamp), in
``LidarOdometry.process`` (``odometry.py``), one module per stage:

1. preprocess (``preprocess.py``): range filter (``min_range``..``max_range`` in the sensor frame),
   sensor -> base_link;
2. deskew (``deskew.py``): every point is moved into base_link at the middle of the sweep, using the
   motion of the sweep sampled at ``deskew_slots`` times: rotation from the integrated gyro when it
   covers the sweep, translation from the odometry prior when it covers it, else the constant
   velocity of the last two registered frames;
3. reduce (``preprocess.reduced``): one point per ``save_voxel`` voxel (small_gicp's voxel filter),
   what the registration and the maps use from here on;
4. register: from the last pose composed with the prior's relative motion between the two times
   (gyro rotation / odometry / constant velocity, in that order of preference), the scan
   voxel-filtered at ``scan_voxel`` is aligned to the local map, with correspondences within
   ``max_correspondence`` or, with ``adaptive_threshold``, KISS-ICP's adaptive threshold
   (``AdaptiveThreshold``: 3 sigma of the motion model's deviation). ``method``: ``vgicp`` (the
   default, ``voxel_map.py``): small_gicp's voxelized GICP against an incremental Gaussian voxel map
   (``gaussian_voxel``), nothing rebuilt per frame; ``point_to_plane`` / ``gicp``
   (``registration.py``): Open3D's legacy ICP against the local map of ``local_map.py``;
5. update the maps: keyframes (every ``keyframe_distance`` m or ``keyframe_angle_deg``) enter the
   local map (vgicp: the scan with its covariances is inserted into the voxel map, voxels untouched
   for about twice ``local_map_radius`` of travel expire; Open3D methods: one point per
   ``map_voxel`` voxel, cropped to ``local_map_radius``, normals estimated per keyframe only for its
   new points and their neighbours, covariances for GICP); every registered (reduced) frame is
   accumulated into one running per-voxel mean (``save_voxel``, FAST-LIO's ``interval: -1``), and optionally
   into chunks of ``save_every_n_frames`` frames.

Parameters are ``LidarOdometryParams`` (``params.py``), from a preset (``preset``: indoor, outdoor)
or sized from the first sweep (``for_sweep``: voxel = max range / 100, KISS-ICP's rule). Poses are base_link in the map frame (4x4);
the map frame is the first frame's base_link unless an initial pose is given. Open3D runs on
``threads`` threads (1 by default) during each call, so the same input gives the same bytes; the
previous limit is restored afterwards; small_gicp's registration runs on ``threads`` threads, its
voxel filter on one, the scan's covariances on ``covariance_threads`` (2 by default: each point's
covariance is its own, so the count changes no bit).

Importing the package sets ``OMP_WAIT_POLICY=PASSIVE`` unless it is set: small_gicp's OpenMP threads
then sleep between calls instead of spinning for milliseconds after each one on the core the log
reader and the writers need (OpenMP reads it once, when small_gicp is first loaded).
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before any module here loads small_gicp (see above)

if TYPE_CHECKING:
    from navlog.replay.mapping.lidar_odometry.deskew import ConstantVelocity, GyroTrack, MotionPrior, PoseTrack
    from navlog.replay.mapping.lidar_odometry.local_map import GlobalMap, LocalMap, VoxelStore
    from navlog.replay.mapping.lidar_odometry.odometry import AdaptiveThreshold, FrameResult, LidarOdometry
    from navlog.replay.mapping.lidar_odometry.params import (
        LidarOdometryParams,
        Method,
        Preset,
        for_sweep,
        observed_range,
        preset,
        scaled,
    )
    from navlog.replay.mapping.lidar_odometry.preprocess import sorted_points, voxel_keys, voxel_sums
    from navlog.replay.mapping.lidar_odometry.registration import Registrar, Registration
    from navlog.replay.mapping.lidar_odometry.voxel_map import GaussianLocalMap, GaussianRegistrar

__all__ = [
    "AdaptiveThreshold",
    "ConstantVelocity",
    "FrameResult",
    "GaussianLocalMap",
    "GaussianRegistrar",
    "GlobalMap",
    "GyroTrack",
    "LidarOdometry",
    "LidarOdometryParams",
    "LocalMap",
    "Method",
    "MotionPrior",
    "PoseTrack",
    "Preset",
    "Registrar",
    "Registration",
    "VoxelStore",
    "for_sweep",
    "observed_range",
    "preset",
    "scaled",
    "sorted_points",
    "voxel_keys",
    "voxel_sums",
]

# names load on first use: a pipeline that only reads the parameters does not import Open3D, small_gicp and SciPy
_MODULES = {
    "ConstantVelocity": "deskew",
    "GyroTrack": "deskew",
    "MotionPrior": "deskew",
    "PoseTrack": "deskew",
    "GlobalMap": "local_map",
    "LocalMap": "local_map",
    "VoxelStore": "local_map",
    "AdaptiveThreshold": "odometry",
    "FrameResult": "odometry",
    "LidarOdometry": "odometry",
    "LidarOdometryParams": "params",
    "Method": "params",
    "Preset": "params",
    "for_sweep": "params",
    "observed_range": "params",
    "preset": "params",
    "scaled": "params",
    "sorted_points": "preprocess",
    "voxel_keys": "preprocess",
    "voxel_sums": "preprocess",
    "Registrar": "registration",
    "Registration": "registration",
    "GaussianLocalMap": "voxel_map",
    "GaussianRegistrar": "voxel_map",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
