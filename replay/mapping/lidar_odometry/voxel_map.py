"""The ``vgicp`` method: small_gicp's voxelized GICP against an incremental Gaussian voxel map.

- ``GaussianLocalMap``: keyframes (every ``keyframe_distance`` m or ``keyframe_angle_deg``, as the
  Open3D local map) are inserted into one ``small_gicp.GaussianVoxelMap`` of ``gaussian_voxel``
  voxels (a mean and a covariance per voxel, updated in place: nothing is rebuilt per frame); voxels
  no keyframe has touched for ``lru_horizon`` keyframes (about twice ``local_map_radius`` of travel)
  are dropped.
- ``GaussianRegistrar``: the scan, voxel-filtered at ``scan_voxel`` with covariances from its
  ``covariance_nn`` nearest neighbours, is registered onto the map from an initial guess with
  correspondences within the threshold; a fitness (share of scan points with a correspondence)
  below ``min_fitness`` rejects the result and keeps the guess. Its ``rmse`` is the root mean
  Mahalanobis error of the inliers (VGICP's cost), not a distance.

The voxel filter runs on one thread (small_gicp's multi-threaded filter varies from run to run); the
covariances and their k-d tree on ``covariance_threads`` threads (each point's covariance is computed
on its own from its exact nearest neighbours: the same bits on any count); the registration on
``threads`` threads (its sums are reduced in an order that depends on the count).

GNU OpenMP's thread pool does not survive a fork: a process forked from one whose small_gicp calls
have started OpenMP threads would wait forever for threads it does not have. ``omp_threads`` gives
such a process one thread (the covariances are the same bits on any count; registration runs on one
thread by default).
"""

from __future__ import annotations

import math
import os

import numpy as np
import small_gicp

from navlog.replay.mapping.lidar_odometry.local_map import keyframe_due
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.preprocess import reduced
from navlog.replay.mapping.lidar_odometry.registration import Registration

_omp_process: int | None = None  # the process whose small_gicp calls have started OpenMP threads


def omp_threads(n: int) -> int:
    """``n`` threads for a small_gicp call, or 1 in a process forked from one whose OpenMP runtime has
    started threads (see the module docstring)."""
    global _omp_process
    if n <= 1:
        return 1
    pid = os.getpid()
    if _omp_process is None:
        _omp_process = pid
    return n if _omp_process == pid else 1


def lru_horizon(params: LidarOdometryParams) -> int:
    """Keyframes a voxel survives untouched: those of twice ``local_map_radius`` of travel."""
    step = max(params.keyframe_distance, params.scan_voxel)
    return max(int(math.ceil(2.0 * params.local_map_radius / step)), 10)


class GaussianLocalMap:
    """The map the ``vgicp`` method registers against (see the module docstring)."""

    def __init__(self, params: LidarOdometryParams) -> None:
        self.params = params
        self.target = small_gicp.GaussianVoxelMap(params.gaussian_voxel)
        self.target.set_lru(lru_horizon(params), 10)
        self._last_key: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.target.size())

    def is_keyframe(self, pose: np.ndarray) -> bool:
        return keyframe_due(self.params, self._last_key, pose)

    def update(self, pose: np.ndarray, scan: small_gicp.PointCloud) -> bool:
        """Insert ``scan`` (the registered source, in base_link, with covariances) at ``pose`` if the
        pose is a keyframe; returns whether it was."""
        if not self.is_keyframe(pose):
            return False
        self._last_key = pose
        self.target.insert(scan, pose)
        return True


class GaussianRegistrar:
    """small_gicp's VGICP with the voxel size, correspondence distance and iterations of the parameters."""

    def __init__(self, params: LidarOdometryParams) -> None:
        self.params = params
        self.count = 0  # registrations run

    def source(self, points: np.ndarray) -> small_gicp.PointCloud:
        """The scan (N, 3) in base_link, voxel-filtered at ``scan_voxel``, with covariances."""
        return self.source_of_reduced(reduced(points, self.params.scan_voxel))

    def source_of_reduced(self, points: np.ndarray) -> small_gicp.PointCloud:
        """``source`` of points already voxel-filtered at ``scan_voxel`` (``reduced``)."""
        p = self.params
        cloud = small_gicp.PointCloud(points)
        n = omp_threads(p.covariance_threads)
        small_gicp.estimate_covariances(cloud, small_gicp.KdTree(cloud, n), p.covariance_nn, n)
        return cloud

    def register(
        self,
        source: small_gicp.PointCloud,
        target: small_gicp.GaussianVoxelMap,
        guess: np.ndarray,
        max_correspondence: float | None = None,
    ) -> Registration:
        """Register ``source`` onto ``target`` from ``guess`` (4x4), with correspondences within
        ``max_correspondence`` (the parameter's when None)."""
        p = self.params
        distance = p.max_correspondence if max_correspondence is None else max_correspondence
        result = small_gicp.align(
            target,
            source,
            np.asarray(guess, dtype=np.float64),
            max_correspondence_distance=distance,
            num_threads=omp_threads(p.threads),
            max_iterations=p.max_iterations,
        )
        self.count += 1
        fitness = result.num_inliers / max(source.size(), 1)
        rmse = math.sqrt(max(float(result.error), 0.0) / max(result.num_inliers, 1))
        pose = np.asarray(result.T_target_source, dtype=np.float64)
        if fitness < p.min_fitness or not np.isfinite(pose).all():
            return Registration(np.asarray(guess, dtype=np.float64), fitness, rmse, False)
        return Registration(pose.copy(), fitness, rmse, True)
