"""The ``vgicp`` method (small_gicp): a known offset of a synthetic corner is recovered, a scan far
from the map is rejected, keyframes feed the Gaussian voxel map, a run over the test room's sweeps
keeps to the true trajectory, and the scan covariances give the same bits on any thread count."""

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


def _room_sweep(room) -> np.ndarray:
    """The first sweep of the test room's loop, in base_link (N, 3)."""
    seq = scene.make_sequence(scene.loop_trajectory(), 1, scene=room)
    return seq.frames[0].points.astype(np.float64) @ seq.extrinsic[:3, :3].T + seq.extrinsic[:3, 3]


def test_covariances_are_the_same_bits_on_any_thread_count(room):
    # each point's covariance comes from its own exact nearest neighbours: the thread count of the
    # covariances and of their k-d tree changes no bit (unlike the registration's reductions)
    sweep = _room_sweep(room)
    clouds = [GaussianRegistrar(LidarOdometryParams(covariance_threads=n)).source(sweep) for n in (1, 2, 3)]
    assert clouds[0].size() > 2000
    covs = np.asarray(clouds[0].covs())
    # a wall point's covariance is flat: its smallest eigenvalue far below its largest
    eig = np.linalg.eigvalsh(covs[:, :3, :3])
    assert np.median(eig[:, 0] / eig[:, 2]) < 0.05
    for cloud in clouds[1:]:
        assert np.asarray(cloud.points()).tobytes() == np.asarray(clouds[0].points()).tobytes()
        assert np.asarray(cloud.covs()).tobytes() == covs.tobytes()


def test_covariance_threads_leave_the_poses_and_the_map_unchanged(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 8, scene=room)
    runs = []
    for n in (1, 2):
        odo = LidarOdometry(LidarOdometryParams(covariance_threads=n), seq.extrinsic, seq.ground_truth([0])[0])
        for f in seq.frames:
            odo.process(f.stamp_ns, f.points, f.times)
        runs.append((odo.poses()[1].tobytes(), odo.global_map().tobytes()))
    assert odo.registrations == 7 and not odo.skipped
    assert runs[0] == runs[1]


def test_openmp_threads_wait_passively_unless_told_otherwise():
    # set before small_gicp loads its OpenMP runtime; a value the user gave is kept
    import os
    import subprocess
    import sys

    code = "import os, navlog.replay.mapping.lidar_odometry.voxel_map; print(os.environ['OMP_WAIT_POLICY'])"
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    for given, expected in ((None, "PASSIVE"), ("ACTIVE", "ACTIVE")):
        run_env = env if given is None else {**env, "OMP_WAIT_POLICY": given}
        out = subprocess.run([sys.executable, "-c", code], env=run_env, capture_output=True, text=True, check=True)
        assert out.stdout.strip() == expected


def _covariances_in_a_fork(sweep: np.ndarray, queue) -> None:
    cloud = GaussianRegistrar(LidarOdometryParams(covariance_threads=2)).source(sweep)
    queue.put(np.asarray(cloud.covs()).tobytes())


def test_a_process_forked_after_openmp_threads_started_computes_on_one_thread(room):
    # GNU OpenMP's pool does not survive a fork: on two threads the forked process would wait forever
    import multiprocessing

    from navlog.replay.mapping.lidar_odometry import voxel_map

    sweep = _room_sweep(room)
    here = np.asarray(GaussianRegistrar(LidarOdometryParams(covariance_threads=2)).source(sweep).covs()).tobytes()
    assert voxel_map.omp_threads(2) == 2 and voxel_map.omp_threads(1) == 1
    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=_covariances_in_a_fork, args=(sweep, queue))
    child.start()
    try:
        got = queue.get(timeout=60)  # read before joining: the child's queue flushes its bytes at exit
    finally:
        child.join(10)
        if child.is_alive():
            child.kill()
    assert child.exitcode == 0 and got == here
