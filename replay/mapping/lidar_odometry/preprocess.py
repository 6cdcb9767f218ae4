"""Preprocessing of a frame: the range crop, voxel keys and per-voxel sums, voxel downsampling
(small_gicp's filter for the per-frame reduction, Open3D's for Open3D clouds).

The voxel grid is fixed and centred on the origin (voxel centres at multiples of the voxel size), so
keys stay valid as a map grows and a surface at a round coordinate falls inside one layer of voxels.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import small_gicp

if TYPE_CHECKING:
    import open3d as o3d

_KEY_BITS = 21  # voxel indices within +-2**20 of the origin on each axis
_KEY_OFFSET = 1 << (_KEY_BITS - 1)


def finite_rows(points: np.ndarray) -> np.ndarray:
    """Boolean mask of the points (N, 3) whose three coordinates are finite (column by column: ten
    times faster than ``np.isfinite(points).all(axis=1)``, a reduction along the short axis)."""
    return np.isfinite(points[:, 0]) & np.isfinite(points[:, 1]) & np.isfinite(points[:, 2])


def valid_points(points: np.ndarray, times: np.ndarray | None, min_range: float, max_range: float) -> np.ndarray:
    """Boolean mask of the points (N, 3) that are finite (with a finite time, when ``times`` is given)
    and whose distance from the sensor is within [``min_range``, ``max_range``]."""
    finite = finite_rows(points)
    if times is not None:
        finite &= np.isfinite(times)
    safe = points if finite.all() else np.where(finite[:, None], points, 0.0)  # the usual sweep: no copy
    rng2 = np.einsum("ij,ij->i", safe, safe)  # squared ranges: no square root per point
    return finite & (rng2 >= min_range * min_range) & (rng2 <= max_range * max_range)


def point_cloud(points: np.ndarray) -> o3d.geometry.PointCloud:
    """An Open3D cloud of (N, 3) points (copied as float64)."""
    import open3d as o3d  # loaded when first asked for: the vgicp method does not use it

    return o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.ascontiguousarray(points, dtype=np.float64)))


def reduced(points: np.ndarray, voxel: float) -> np.ndarray:
    """(M, 3) one point (the mean) per ``voxel``-sized voxel of (N, 3) points, by small_gicp's voxel
    filter on one thread (deterministic); the order is the filter's."""
    cloud = small_gicp.voxelgrid_sampling(np.ascontiguousarray(points, dtype=np.float64), voxel, 1)
    return np.ascontiguousarray(cloud.points()[:, :3])


def downsample(points: np.ndarray, voxel: float) -> o3d.geometry.PointCloud:
    """Open3D's voxel filter of (N, 3) points: one point (the mean) per ``voxel``-sized voxel."""
    return point_cloud(points).voxel_down_sample(voxel)


def voxel_keys(points: np.ndarray, voxel: float) -> np.ndarray:
    """One int64 per point naming its voxel; ordered by x index, then y, then z. The grid is fixed
    (keys stay valid as a map grows) and centred on the origin: voxel centres at multiples of
    ``voxel``, so a surface at a round coordinate falls inside one layer of voxels, not across two."""
    k = np.floor(points / voxel + 0.5).astype(np.int64) + _KEY_OFFSET
    return (k[:, 0] << (2 * _KEY_BITS)) | (k[:, 1] << _KEY_BITS) | k[:, 2]


def voxel_sums(points: np.ndarray, voxel: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sorted unique voxel keys, per-voxel coordinate sums (M, 3), per-voxel counts (M,))."""
    keys = voxel_keys(points, voxel)
    uk, inv = np.unique(keys, return_inverse=True)
    counts = np.bincount(inv, minlength=len(uk))
    sums = np.stack([np.bincount(inv, weights=points[:, d], minlength=len(uk)) for d in range(3)], axis=1)
    return uk, sums, counts


def sorted_points(points: np.ndarray, voxel: float) -> np.ndarray:
    """Points in a deterministic order: by voxel index (x, then y, then z), then by coordinates."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) == 0:
        return p
    key = np.floor(p / voxel).astype(np.int64)
    order = np.lexsort((p[:, 2], p[:, 1], p[:, 0], key[:, 2], key[:, 1], key[:, 0]))
    return p[order]
