"""LiDAR odometry and mapping (the FAST-LIO role), as pure computation on numpy arrays.

Per frame (points in the sensor frame, per-point times in seconds after the frame stamp), in
``LidarOdometry.process`` (``odometry.py``), one module per stage:

1. preprocess (``preprocess.py``): range filter (``min_range``..``max_range`` in the sensor frame),
   sensor -> base_link;
2. deskew (``deskew.py``): every point is moved into base_link at the middle of the sweep, using the
   motion of the sweep sampled at ``deskew_slots`` times: rotation from the integrated gyro when it
   covers the sweep, translation from the odometry prior when it covers it, else the constant
   velocity of the last two registered frames;
3. register (``registration.py``): from the last pose composed with the prior's relative motion
   between the two times (gyro rotation / odometry / constant velocity, in that order of preference),
   scan-to-local-map ICP with Open3D's legacy ``o3d.pipelines.registration`` (point-to-plane by
   default, generalized ICP optional) on the scan voxel-filtered at ``scan_voxel``;
4. update the maps (``local_map.py``): keyframes (every ``keyframe_distance`` m or
   ``keyframe_angle_deg``) are merged into the local map (one point per ``map_voxel`` voxel, cropped
   to ``local_map_radius``); normals are estimated per keyframe only for its new points and their
   neighbours (covariances for GICP); every registered frame is accumulated into one running
   per-voxel mean (``save_voxel``, FAST-LIO's ``interval: -1``), and optionally into chunks of
   ``save_every_n_frames`` frames.

Parameters are ``LidarOdometryParams`` (``params.py``). Poses are base_link in the map frame (4x4);
the map frame is the first frame's base_link unless an initial pose is given. Open3D runs on
``threads`` threads (1 by default) during each call, so the same input gives the same bytes; the
previous limit is restored afterwards.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.mapping.lidar_odometry.deskew import ConstantVelocity, GyroTrack, MotionPrior, PoseTrack
    from navlog.replay.mapping.lidar_odometry.local_map import GlobalMap, LocalMap, VoxelStore
    from navlog.replay.mapping.lidar_odometry.odometry import FrameResult, LidarOdometry
    from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams, Method
    from navlog.replay.mapping.lidar_odometry.preprocess import sorted_points, voxel_keys, voxel_sums
    from navlog.replay.mapping.lidar_odometry.registration import Registrar, Registration

__all__ = [
    "ConstantVelocity",
    "FrameResult",
    "GlobalMap",
    "GyroTrack",
    "LidarOdometry",
    "LidarOdometryParams",
    "LocalMap",
    "Method",
    "MotionPrior",
    "PoseTrack",
    "Registrar",
    "Registration",
    "VoxelStore",
    "sorted_points",
    "voxel_keys",
    "voxel_sums",
]

# names load on first use: a pipeline that only reads the parameters does not import Open3D and SciPy
_MODULES = {
    "ConstantVelocity": "deskew",
    "GyroTrack": "deskew",
    "MotionPrior": "deskew",
    "PoseTrack": "deskew",
    "GlobalMap": "local_map",
    "LocalMap": "local_map",
    "VoxelStore": "local_map",
    "FrameResult": "odometry",
    "LidarOdometry": "odometry",
    "LidarOdometryParams": "params",
    "Method": "params",
    "sorted_points": "preprocess",
    "voxel_keys": "preprocess",
    "voxel_sums": "preprocess",
    "Registrar": "registration",
    "Registration": "registration",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
