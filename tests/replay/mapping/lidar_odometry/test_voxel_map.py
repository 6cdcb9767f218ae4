"""The ``vgicp`` method (small_gicp): a known offset of a synthetic corner is recovered, a scan far
from the map is rejected, keyframes feed the Gaussian voxel map, and a run over the test room's
sweeps keeps to the true trajectory."""

from __future__ import annotations

import numpy as np

from navlog.replay.mapping.lidar_odometry import LidarOdometry, LidarOdometryParams
from navlog.replay.mapping.lidar_odometry.voxel_map import GaussianLocalMap, GaussianRegistrar, lru_horizon
from tests.replay import lidar_scene as scene
from tests.replay.mapping.lidar_odometry.helpers import ate_rmse, share_within
from tests.replay.mapping.lidar_odometry.test_registration import corner

MID_VOXEL = 0.1  # the corner's planes lie mid-voxel: VGICP matches a point to the voxel it falls in only


def corner_map(params: LidarOdometryParams) -> GaussianLocalMap:
    local = GaussianLocalMap(params)
    assert local.update(np.eye(4), GaussianRegistrar(params).source(corner() + MID_VOXEL))
    return local


def test_recovers_a_known_offset():
    params = LidarOdometryParams(scan_voxel=0.05, gaussian_voxel=0.2)
    local = corner_map(params)
    offset = np.array([0.05, -0.03, 0.02])
    pts = corner()
    registrar = GaussianRegistrar(params)
    scan = registrar.source(pts[(pts < 1.8).all(axis=1)] + MID_VOXEL - offset)
    result = registrar.register(scan, local.target, np.eye(4))
    assert result.accepted and result.fitness > 0.95
    np.testing.assert_allclose(result.pose[:3, 3], offset, atol=2e-3)
    np.testing.assert_allclose(result.pose[:3, :3], np.eye(3), atol=2e-3)
    assert registrar.count == 1


def test_a_scan_far_from_the_map_is_rejected_and_the_guess_kept():
    params = LidarOdometryParams()
    local = corner_map(params)
    guess = np.eye(4)
    guess[:3, 3] = (10.0, 0.0, 0.0)
    registrar = GaussianRegistrar(params)
    result = registrar.register(registrar.source(corner() + MID_VOXEL), local.target, guess)
    assert not result.accepted and result.fitness < 0.3
    np.testing.assert_array_equal(result.pose, guess)


def test_only_keyframes_enter_the_map_and_old_voxels_expire():
    params = LidarOdometryParams()
    local = corner_map(params)
    n0 = len(local)
    assert n0 > 0
    far = np.eye(4)
    far[0, 3] = 0.2  # under keyframe_distance (0.25 m): nothing is inserted
    assert not local.update(far, GaussianRegistrar(params).source(corner() + [5.0, 0.0, 0.0]))
    assert len(local) == n0
    # a voxel survives the keyframes of twice the local map radius of travel (15 m / 0.25 m * 2)
    assert lru_horizon(params) == 120


def test_vgicp_run_over_the_room_keeps_to_the_true_trajectory(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 40, scene=room)
    odo = LidarOdometry(LidarOdometryParams(), seq.extrinsic, seq.ground_truth([0])[0])
    assert odo.params.method == "vgicp"
    for f in seq.frames:
        odo.process(f.stamp_ns, f.points, f.times)
    stamps, poses = odo.poses()
    assert len(stamps) == 40 and odo.registrations == 39 and not odo.skipped
    assert ate_rmse(stamps, poses, seq) <= 0.02
    assert share_within(odo.global_map(), 0.05, room) >= 0.95


def test_same_input_same_poses(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 10, scene=room)
    runs = []
    for _ in range(2):
        odo = LidarOdometry(LidarOdometryParams(), seq.extrinsic, seq.ground_truth([0])[0])
        for f in seq.frames:
            odo.process(f.stamp_ns, f.points, f.times)
        runs.append(odo.poses()[1])
    np.testing.assert_array_equal(runs[0], runs[1])
