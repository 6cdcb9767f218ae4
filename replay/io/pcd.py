"""Point-cloud map files (PCD), through Open3D.

``write_pcd`` writes binary PCD with float32 ``x y z`` fields, the points in the order given (the
mappers hand them in a deterministic order, so the same map gives the same bytes); ``read_pcd``
reads any PCD (or another format Open3D knows by its suffix) into an (N, 3) float64 array.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import open3d as o3d

from navlog.errors import NavlogError

__all__ = ["read_pcd", "write_pcd"]


def write_pcd(path: str | Path, points: np.ndarray) -> None:
    """Write (N, 3) points to ``path`` as a binary PCD, creating the parent folder if needed."""
    path = Path(path)
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.ascontiguousarray(points, dtype=np.float64)))
    path.parent.mkdir(parents=True, exist_ok=True)
    if not o3d.io.write_point_cloud(path, pcd, write_ascii=False):
        raise NavlogError(f"{path}: cannot write the point cloud")


def read_pcd(path: str | Path) -> np.ndarray:
    """The (N, 3) float64 points of a point-cloud file; empty (0, 3) when Open3D reads no points."""
    return np.asarray(o3d.io.read_point_cloud(Path(path)).points)
