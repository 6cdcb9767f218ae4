"""The maps the odometry keeps: the incremental local map it registers against, and the running
global voxel store that becomes the saved point-cloud map.

- ``LocalMap``: keyframes (every ``keyframe_distance`` m or ``keyframe_angle_deg``) are merged into
  one point per ``map_voxel`` voxel, cropped to ``local_map_radius``; normals are estimated per
  keyframe only for its new points and their neighbours (covariances too, for GICP).
- ``GlobalMap``: every registered frame is accumulated into one running per-voxel mean
  (``save_voxel``, FAST-LIO's ``interval: -1``), and optionally into chunks of
  ``save_every_n_frames`` frames.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.geometry import rotation_angle
from navlog.replay.mapping.background import Background, inline
from navlog.replay.mapping.lidar_odometry.params import LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.preprocess import downsample, point_cloud, sorted_points, voxel_sums

if TYPE_CHECKING:
    import open3d as o3d


def keyframe_due(params: LidarOdometryParams, last_key: np.ndarray | None, pose: np.ndarray) -> bool:
    """True for the first pose (``last_key`` None) and for one ``keyframe_distance`` or
    ``keyframe_angle_deg`` away from the last keyframe."""
    if last_key is None:
        return True
    rel = np.linalg.inv(last_key) @ pose
    moved = float(np.linalg.norm(rel[:3, 3]))
    turned = math.degrees(rotation_angle(rel[:3, :3]))
    return not (moved < params.keyframe_distance and turned < params.keyframe_angle_deg)


class LocalMap:
    """The local map registered against: sorted voxel keys, their points and normals, and the Open3D
    cloud built from them (with covariances for GICP)."""

    def __init__(self, params: LidarOdometryParams) -> None:
        import open3d as o3d  # loaded by the Open3D methods only (the vgicp method needs neither it nor SciPy)

        self.params = params
        self.cloud = o3d.geometry.PointCloud()
        self._keys = np.zeros(0, dtype=np.int64)  # sorted voxel keys of the local map points
        self._points = np.zeros((0, 3))
        self._normals = np.zeros((0, 3))
        self._last_key: np.ndarray | None = None  # pose of the last keyframe

    def __len__(self) -> int:
        return len(self.cloud.points)

    @property
    def target(self) -> o3d.geometry.PointCloud:
        """What the registration aligns to: the Open3D cloud."""
        return self.cloud

    def is_keyframe(self, pose: np.ndarray) -> bool:
        return keyframe_due(self.params, self._last_key, pose)

    def update(self, pose: np.ndarray, points_map: np.ndarray) -> bool:
        """Add the frame as a keyframe if it is one (returns whether it was): one point per
        ``map_voxel`` voxel (a voxel keeps the point it got first, so the map does not shift under
        the registration), cropped around the pose; normals are estimated only for the new points and
        the map points within ``normal_radius`` of them (on the cloud of their neighbourhoods), the
        others keep theirs."""
        import open3d as o3d
        from scipy.spatial import cKDTree

        p = self.params
        if not self.is_keyframe(pose):
            return False
        self._last_key = pose
        uk, sums, counts = voxel_sums(points_map, p.map_voxel)
        pos = np.searchsorted(self._keys, uk)
        found = pos < len(self._keys)
        found[found] = self._keys[pos[found]] == uk[found]
        fresh = ~found
        at = pos[fresh]
        keys = np.insert(self._keys, at, uk[fresh])
        pts = np.insert(self._points, at, sums[fresh] / counts[fresh, None], axis=0)
        normals = np.insert(self._normals, at, 0.0, axis=0)
        is_new = np.insert(np.zeros(len(self._keys), dtype=bool), at, True)
        dist = np.linalg.norm(pts - pose[:3, 3], axis=1)
        keep = np.nonzero(dist <= p.local_map_radius)[0]
        if len(keep) > p.local_map_max_points:
            keep = keep[np.argsort(dist[keep], kind="stable")[: p.local_map_max_points]]
            keep.sort()
        if len(keep) < len(pts):
            keys, pts, normals, is_new = keys[keep], pts[keep], normals[keep], is_new[keep]
        if is_new.any():
            r = p.normal_radius
            near, _ = cKDTree(pts[is_new]).query(pts, k=1, distance_upper_bound=2.0 * r)
            context = near <= 2.0 * r  # every neighbour (within r) of an updated point
            update = near[context] <= r
            sub = point_cloud(pts[context])
            sub.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=r, max_nn=p.normal_max_nn))
            idx = np.nonzero(context)[0][update]
            normals[idx] = np.asarray(sub.normals)[update]
        local = point_cloud(pts)
        local.normals = o3d.utility.Vector3dVector(normals)
        if p.method == "gicp":
            local.estimate_covariances(o3d.geometry.KDTreeSearchParamKNN(p.normal_max_nn))
        self._keys, self._points, self._normals = keys, pts, normals
        self.cloud = local
        return True


class VoxelStore:
    """A running voxel filter: per-voxel sums and counts under sorted keys; the points are the
    per-voxel means of everything added (what one voxel filter of all the points would give)."""

    def __init__(self, voxel: float) -> None:
        self.voxel = voxel
        self.keys = np.zeros(0, dtype=np.int64)
        self.sums = np.zeros((0, 3))
        self.counts = np.zeros(0, dtype=np.int64)

    def add(self, points: np.ndarray) -> None:
        if len(points) == 0:
            return
        uk, sums, counts = voxel_sums(points, self.voxel)
        pos = np.searchsorted(self.keys, uk)
        found = pos < len(self.keys)
        found[found] = self.keys[pos[found]] == uk[found]
        self.sums[pos[found]] += sums[found]
        self.counts[pos[found]] += counts[found]
        fresh = ~found
        if fresh.any():
            at = pos[fresh]
            self.keys = np.insert(self.keys, at, uk[fresh])
            self.sums = np.insert(self.sums, at, sums[fresh], axis=0)
            self.counts = np.insert(self.counts, at, counts[fresh])

    def points(self) -> np.ndarray:
        return self.sums / self.counts[:, None]

    def __len__(self) -> int:
        return len(self.keys)


class GlobalMap:
    """Every registered frame in one ``VoxelStore`` at ``save_voxel`` (frames are buffered and added
    in batches of about 400 000 points), and chunks of ``save_every_n_frames`` frames when asked.

    A batch is added to the store through ``background`` (``navlog.replay.mapping.background``: in line
    by default; the 3D mapper node runs it in a thread while the next frames are registered); the
    batches are added one at a time in the order they were flushed, so the store holds the same bits
    whatever runs them. ``points`` waits for the last batch."""

    _BATCH_POINTS = 400_000

    def __init__(self, save_voxel: float, save_every_n_frames: int = 0, *, background: Background = inline) -> None:
        self.save_voxel = save_voxel
        self.save_every_n_frames = save_every_n_frames
        self.store = VoxelStore(save_voxel)
        self.chunks: list[np.ndarray] = []
        self._buffer: list[np.ndarray] = []
        self._buffered = 0
        self._chunk: list[np.ndarray] = []
        self._chunk_frames = 0
        self._background = background
        self._adding: Callable[[], None] | None = None  # the wait of the batch being added to the store

    def add(self, points_map: np.ndarray) -> None:
        self._buffer.append(points_map)
        self._buffered += len(points_map)
        if self._buffered >= self._BATCH_POINTS:
            self.flush()
        if self.save_every_n_frames > 0:
            self._chunk.append(points_map)
            self._chunk_frames += 1
            if self._chunk_frames >= self.save_every_n_frames:
                self.close_chunk()

    def flush(self) -> None:
        """Move the buffered frames into the store (through ``background``: ``points`` waits for it)."""
        if not self._buffer:
            return
        batch, self._buffer, self._buffered = self._buffer, [], 0
        self._wait()  # one batch at a time, in order: at most one batch in flight
        self._adding = self._background(lambda: self.store.add(np.concatenate(batch)))

    def _wait(self) -> None:
        """Wait for the batch being added; raise what it raised."""
        wait, self._adding = self._adding, None
        if wait is not None:
            wait()

    @property
    def chunk_open(self) -> bool:
        """True while frames wait in a chunk not yet closed (``close_chunk`` then filters them with Open3D)."""
        return bool(self._chunk)

    def close_chunk(self) -> None:
        """End the current chunk (if it holds any frame): voxel-filtered at ``save_voxel``, sorted."""
        if self._chunk:
            pts = np.asarray(downsample(np.concatenate(self._chunk), self.save_voxel).points)
            self.chunks.append(sorted_points(pts, self.save_voxel))
        self._chunk, self._chunk_frames = [], 0

    def points(self) -> np.ndarray:
        """(N, 3) the store's points (after ``flush``) in a deterministic order."""
        self._wait()
        return sorted_points(self.store.points(), self.save_voxel)
