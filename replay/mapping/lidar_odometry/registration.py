"""Scan-to-local-map registration with Open3D's legacy ICP (point-to-plane, or generalized ICP): the
``point_to_plane`` and ``gicp`` methods (``vgicp`` is in ``voxel_map.py``).

The scan, voxel-filtered at ``scan_voxel``, is registered against the local map from an initial
guess, with correspondences within ``max_correspondence`` and at most ``max_iterations`` iterations;
a result whose fitness (share of scan points with a correspondence) is below ``min_fitness`` is
rejected and the guess kept.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.preprocess import downsample

if TYPE_CHECKING:
    import open3d as o3d


@dataclass(frozen=True)
class Registration:
    """The outcome of one registration: the pose (the guess when rejected), ICP's fitness and inlier RMSE."""

    pose: np.ndarray
    fitness: float
    rmse: float
    accepted: bool


class Registrar:
    """Runs ICP with the method, correspondence distance and stopping rule of the parameters."""

    def __init__(self, params: LidarOdometryParams) -> None:
        import open3d as o3d  # loaded by these methods only (``Registration`` is the vgicp method's too)

        _reg = o3d.pipelines.registration
        self.params = params
        self.estimation = (
            _reg.TransformationEstimationForGeneralizedICP()
            if params.method == "gicp"
            else _reg.TransformationEstimationPointToPlane()
        )
        self.criteria = _reg.ICPConvergenceCriteria(params.convergence, params.convergence, params.max_iterations)
        self.count = 0  # registrations run

    def source(self, points: np.ndarray) -> o3d.geometry.PointCloud:
        """The scan (N, 3) in base_link, voxel-filtered at ``scan_voxel``."""
        return downsample(points, self.params.scan_voxel)

    def register(
        self,
        source: o3d.geometry.PointCloud,
        target: o3d.geometry.PointCloud,
        guess: np.ndarray,
        max_correspondence: float | None = None,
    ) -> Registration:
        """Register ``source`` (the downsampled scan) onto ``target`` (the local map) from ``guess`` (4x4),
        with correspondences within ``max_correspondence`` (the parameter's when None)."""
        import open3d as o3d

        p = self.params
        distance = p.max_correspondence if max_correspondence is None else max_correspondence
        if p.method == "gicp":
            source.estimate_covariances(o3d.geometry.KDTreeSearchParamKNN(p.normal_max_nn))
        result = o3d.pipelines.registration.registration_icp(
            source, target, distance, guess, self.estimation, self.criteria
        )
        self.count += 1
        fitness, rmse = float(result.fitness), float(result.inlier_rmse)
        if fitness < p.min_fitness:
            return Registration(guess, fitness, rmse, False)
        return Registration(np.asarray(result.transformation, dtype=np.float64).copy(), fitness, rmse, True)
