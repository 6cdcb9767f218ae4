"""The range crop and the fixed voxel grid of the odometry's preprocessing, on hand-made points."""

from __future__ import annotations

import numpy as np

from navlog.replay.mapping.lidar_odometry import sorted_points, voxel_keys, voxel_sums
from navlog.replay.mapping.lidar_odometry.preprocess import downsample, finite_rows, valid_points


def test_valid_points_keeps_finite_points_within_the_range_limits():
    pts = np.array(
        [
            [0.1, 0.0, 0.0],  # too close (0.1 m)
            [3.0, 4.0, 0.0],  # 5 m
            [np.nan, 0.0, 0.0],  # not finite
            [0.0, 0.0, 31.0],  # too far
            [0.0, 0.3, 0.0],  # exactly min_range
        ]
    )
    np.testing.assert_array_equal(valid_points(pts, None, 0.3, 30.0), [False, True, False, False, True])
    times = np.array([0.0, np.inf, 0.0, 0.0, 0.05])  # a point without a finite time is dropped too
    np.testing.assert_array_equal(valid_points(pts, times, 0.3, 30.0), [False, False, False, False, True])
    # all finite (the usual sweep): the same ranges without the masked copy
    np.testing.assert_array_equal(valid_points(pts[[0, 1, 3, 4]], None, 0.3, 30.0), [False, True, False, True])


def test_finite_rows_is_a_row_wise_isfinite():
    pts = np.zeros((6, 3))
    pts[1, 0], pts[2, 1], pts[3, 2], pts[4] = np.nan, np.inf, -np.inf, np.nan
    pts[5] = 1e308  # finite, however large
    np.testing.assert_array_equal(finite_rows(pts), [True, False, False, False, False, True])
    np.testing.assert_array_equal(finite_rows(pts), np.isfinite(pts).all(axis=1))
    assert finite_rows(np.zeros((0, 3))).shape == (0,)


def test_voxels_are_centred_on_the_origin():
    pts = np.array([[0.04, 0.0, 0.0], [-0.04, 0.0, 0.0], [0.06, 0.0, 0.0], [0.1, 0.2, -0.1]])
    keys = voxel_keys(pts, 0.1)
    assert keys[0] == keys[1]  # both within 0.05 of the voxel centre 0.0
    assert keys[2] != keys[0]  # 0.06 belongs to the voxel centred at 0.1
    uk, sums, counts = voxel_sums(pts, 0.1)
    assert len(uk) == 3 and list(uk) == sorted(uk)
    np.testing.assert_array_equal(counts[np.searchsorted(uk, keys[0])], 2)
    np.testing.assert_allclose(sums[np.searchsorted(uk, keys[0])], [0.0, 0.0, 0.0], atol=1e-15)
    # keys order by the x index first
    assert voxel_keys(np.array([[-1.0, 5.0, 5.0]]), 0.1)[0] < voxel_keys(np.array([[1.0, -5.0, -5.0]]), 0.1)[0]


def test_sorted_points_and_downsample():
    pts = np.array([[0.31, 0.0, 0.0], [0.01, 0.2, 0.0], [0.02, 0.1, 0.0], [0.01, 0.1, 0.0]])
    np.testing.assert_array_equal(sorted_points(pts, 0.1), pts[[3, 2, 1, 0]])
    assert sorted_points(np.zeros((0, 3)), 0.1).shape == (0, 3)
    cloud = downsample(np.array([[0.01, 0.01, 0.01], [0.03, 0.03, 0.03], [1.0, 1.0, 1.0]]), 0.5)
    got = np.asarray(cloud.points)
    assert len(got) == 2
    np.testing.assert_allclose(got[np.argsort(got[:, 0])], [[0.02, 0.02, 0.02], [1.0, 1.0, 1.0]], atol=1e-12)
