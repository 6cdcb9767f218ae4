"""Scan-to-map ICP on a synthetic corner: a known offset is recovered; a scan far from the map is rejected."""

from __future__ import annotations

import numpy as np
import open3d as o3d

from navlog.replay.mapping.lidar_odometry import LidarOdometryParams, Registrar
from navlog.replay.mapping.lidar_odometry.preprocess import downsample, point_cloud


def corner() -> np.ndarray:
    """Three orthogonal 2 m planes sampled every 2 cm (a corner fixes all six degrees of freedom)."""
    g = np.arange(0.0, 2.0, 0.02)
    a, b = (v.ravel() for v in np.meshgrid(g, g))
    zero = np.zeros_like(a)
    return np.concatenate([np.stack(p, axis=1) for p in ((a, b, zero), (a, zero, b), (zero, a, b))])


def target_map(points: np.ndarray) -> o3d.geometry.PointCloud:
    cloud = point_cloud(points)
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=0.1, max_nn=20))
    return cloud


def test_recovers_a_known_offset():
    pts = corner()
    offset = np.array([0.05, -0.03, 0.02])
    scan = pts[(pts < 1.8).all(axis=1)] - offset  # within the map's planes: every point has a match
    registrar = Registrar(LidarOdometryParams())
    result = registrar.register(point_cloud(scan), target_map(pts), np.eye(4))
    assert result.accepted and result.fitness == 1.0
    np.testing.assert_allclose(result.pose[:3, 3], offset, atol=1e-9)
    np.testing.assert_allclose(result.pose[:3, :3], np.eye(3), atol=1e-9)
    assert registrar.count == 1


def test_a_scan_far_from_the_map_is_rejected_and_the_guess_kept():
    pts = corner()
    guess = np.eye(4)
    guess[:3, 3] = (10.0, 0.0, 0.0)
    result = Registrar(LidarOdometryParams()).register(downsample(pts, 0.1), target_map(pts), guess)
    assert not result.accepted and result.fitness < 0.3
    np.testing.assert_array_equal(result.pose, guess)
