"""The local map's keyframe rule and voxel merge, and the running global voxel store."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navlog.replay.mapping.background import inline
from navlog.replay.mapping.lidar_odometry import GlobalMap, LidarOdometryParams, LocalMap, VoxelStore, voxel_sums
from navlog.replay.workers.background import in_thread


def pose(x: float, yaw_deg: float = 0.0) -> np.ndarray:
    m = np.eye(4)
    m[:3, :3] = Rotation.from_euler("z", yaw_deg, degrees=True).as_matrix()
    m[0, 3] = x
    return m


def plane(n: int = 20, step: float = 0.1, z: float = 0.0) -> np.ndarray:
    g = np.arange(n) * step
    xx, yy = np.meshgrid(g, g)
    return np.stack([xx.ravel(), yy.ravel(), np.full(n * n, z)], axis=1)


def test_keyframes_every_quarter_metre_or_15_degrees():
    local = LocalMap(LidarOdometryParams())
    assert local.update(pose(0.0), plane())  # the first frame is a keyframe
    n0 = len(local)
    assert n0 == 400  # one point per 0.1 m voxel
    assert not local.is_keyframe(pose(0.2))
    assert not local.is_keyframe(pose(0.0, 14.0))
    assert local.is_keyframe(pose(0.25))
    assert local.is_keyframe(pose(0.0, 15.0))
    assert not local.update(pose(0.1), plane(z=0.5))  # not a keyframe: the map is unchanged
    assert len(local) == n0
    assert local.update(pose(0.3), plane(z=0.5))
    assert len(local) == 2 * n0
    normals = np.asarray(local.cloud.normals)
    np.testing.assert_allclose(np.abs(normals[:, 2]), 1.0, atol=1e-9)  # planes: normals along z


def test_local_map_is_cropped_around_the_pose():
    local = LocalMap(LidarOdometryParams(local_map_radius=1.0))
    local.update(pose(0.0), plane())
    pts = np.asarray(local.cloud.points)
    assert 0 < len(pts) < 400
    assert np.linalg.norm(pts, axis=1).max() <= 1.0


def test_voxel_store_is_one_voxel_filter_of_everything_added():
    rng = np.random.default_rng(0)
    pts = rng.uniform(-1.0, 1.0, (5000, 3))
    store = VoxelStore(0.2)
    store.add(pts[:2000])
    store.add(pts[2000:])
    store.add(np.zeros((0, 3)))
    uk, sums, counts = voxel_sums(pts, 0.2)
    np.testing.assert_array_equal(store.keys, uk)
    np.testing.assert_array_equal(store.counts, counts)
    np.testing.assert_allclose(store.points(), sums / counts[:, None], atol=1e-12)
    assert len(store) == len(uk)


def test_global_map_chunks_of_n_frames():
    gm = GlobalMap(0.05, save_every_n_frames=2)
    for k in range(5):
        gm.add(plane(z=0.1 * k))
    assert len(gm.chunks) == 2  # frames 1-2 and 3-4; frame 5 is still open
    gm.close_chunk()
    assert [len(c) for c in gm.chunks] == [800, 800, 400]
    gm.flush()
    assert len(gm.points()) == 5 * 400


@pytest.mark.parametrize("background", [inline, in_thread])
def test_global_map_adds_its_batches_with_the_bits_of_adding_them_in_line(monkeypatch, background):
    monkeypatch.setattr(GlobalMap, "_BATCH_POINTS", 1000)  # a batch every third frame of 400 points
    rng = np.random.default_rng(3)
    frames = [rng.uniform(-2.0, 2.0, (400, 3)) + [0.3 * k, 0.0, 0.0] for k in range(20)]
    gm = GlobalMap(0.05, background=background)
    in_line = VoxelStore(0.05)
    batch: list[np.ndarray] = []
    for f in frames:
        gm.add(f)
        batch.append(f)
        if sum(len(b) for b in batch) >= 1000:
            in_line.add(np.concatenate(batch))
            batch = []
    gm.flush()
    in_line.add(np.concatenate(batch))
    got = gm.points()
    assert gm._adding is None  # points() waited for the last batch
    assert len(got) == len(in_line) > 5000
    np.testing.assert_array_equal(gm.store.keys, in_line.keys)
    assert gm.store.sums.tobytes() == in_line.sums.tobytes()  # same batches, same order: same sums


def test_an_error_adding_a_batch_in_a_thread_is_raised_by_the_next_call(monkeypatch):
    gm = GlobalMap(0.05, background=in_thread)
    gm.add(np.zeros((10, 3)))

    def broken(points: np.ndarray) -> None:
        raise MemoryError("no room for the batch")

    monkeypatch.setattr(gm.store, "add", broken)
    gm.flush()  # the batch fails in the background
    with pytest.raises(MemoryError, match="no room"):
        gm.points()
    assert len(gm.points()) == 0  # raised once; the store is as it was
