"""The motion prior (gyro track, pose track, constant velocity) and the per-point deskew."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from navlog.replay.mapping.lidar_odometry import (
    ConstantVelocity,
    GyroTrack,
    LidarOdometry,
    LidarOdometryParams,
    MotionPrior,
    PoseTrack,
)
from navlog.replay.mapping.lidar_odometry.deskew import deskew_points
from tests.replay import lidar_scene as scene
from tests.replay.mapping.lidar_odometry.helpers import SWEEP_NS, ate_rmse, share_within


def test_gyro_track_integrates_a_known_rate():
    gyro = GyroTrack()
    for k in range(41):  # 0.5 rad/s about z for 0.2 s
        gyro.add(k * 5_000_000, (0.0, 0.0, 0.5))
    rel = gyro.relative_rotations(50_000_000, np.array([150_000_000, 0]))
    angles = Rotation.from_matrix(rel).as_rotvec()
    np.testing.assert_allclose(angles, [[0, 0, 0.05], [0, 0, -0.025]], atol=1e-12)
    assert gyro.relative_rotations(0, np.array([300_000_000])) is None  # beyond the data: no guess


def test_a_gyro_sample_after_a_gap_longer_than_kept_starts_the_track_afresh():
    """A stamp 10^9 s ahead (a bit flip in a log) and a rate of 1e300 rad/s integrated over 5 ms gave an
    infinite angle and a math domain error; now the track starts again there and covers only what follows."""
    gyro = GyroTrack()
    for k in range(41):
        gyro.add(k * 5_000_000, (0.0, 0.0, 0.5))
    far = 10**18
    gyro.add(far, (0.0, 0.0, 1e300))
    gyro.add(far + 5_000_000, (0.0, 0.0, 1e300))
    # the gap started the track again at ``far``; 1e300 rad/s over 5 ms is no rotation: again at far + 5 ms
    assert not gyro.covers(0, 200_000_000) and not gyro.covers(far, far + 5_000_000)
    assert gyro.covers(far + 5_000_000, far + 5_000_000)
    for k in range(2, 42):
        gyro.add(far + k * 5_000_000, (0.0, 0.0, 0.5))
    rel = gyro.relative_rotations(far + 50_000_000, np.array([far + 150_000_000]))
    np.testing.assert_allclose(Rotation.from_matrix(rel).as_rotvec(), [[0, 0, 0.05]], atol=1e-12)


def test_deskew_reduces_error_on_a_fast_rotating_sweep(room):
    seq = scene.make_sequence(scene.spin_trajectory(rate=1.5, speed=0.2), 30, scene=room)
    gt0 = seq.ground_truth([0])[0]
    results = {}
    for deskew in (True, False):
        gyro, j = GyroTrack(), 0
        odo = LidarOdometry(LidarOdometryParams(deskew=deskew), seq.extrinsic, gt0)
        for f in seq.frames:
            while j < len(seq.imu_ns) and seq.imu_ns[j] <= f.stamp_ns + SWEEP_NS:
                gyro.add(int(seq.imu_ns[j]), seq.gyro[j])
                j += 1
            odo.process(f.stamp_ns, f.points, f.times, MotionPrior(gyro=gyro))
        stamps, poses = odo.poses()
        results[deskew] = (ate_rmse(stamps, poses, seq), share_within(odo.global_map(), 0.02, room))
    (ate_on, acc_on), (ate_off, acc_off) = results[True], results[False]
    assert ate_on <= 0.03
    assert ate_on < 0.5 * ate_off
    assert acc_on > acc_off + 0.1


def test_pose_track_interpolates_halfway():
    odom = PoseTrack()
    odom.add(0, np.eye(4))
    end = np.eye(4)
    end[:3, :3] = Rotation.from_euler("z", 0.2).as_matrix()
    end[:3, 3] = (1.0, 0.5, 0.0)
    odom.add(1_000_000_000, end)
    mid = odom.poses(np.array([500_000_000]))[0]
    np.testing.assert_allclose(mid[:3, 3], [0.5, 0.25, 0.0], atol=1e-12)
    np.testing.assert_allclose(Rotation.from_matrix(mid[:3, :3]).as_rotvec(), [0.0, 0.0, 0.1], atol=1e-12)
    rel = odom.relative(500_000_000, np.array([1_000_000_000]))[0]  # pose at 0.5 s <- pose at 1 s
    np.testing.assert_allclose(Rotation.from_matrix(rel[:3, :3]).as_rotvec(), [0.0, 0.0, 0.1], atol=1e-12)
    assert odom.relative(0, np.array([1_500_000_000])) is None  # beyond the data: no guess


def test_constant_velocity_and_deskew_of_a_known_motion():
    velocity = ConstantVelocity(np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.5]))
    rel = velocity.relative(np.array([0.2, -0.2]))
    np.testing.assert_allclose(rel[0, :3, 3], [0.2, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(Rotation.from_matrix(rel[0, :3, :3]).as_rotvec(), [0.0, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(rel[1, :3, 3], [-0.2, 0.0, 0.0], atol=1e-15)
    # a point seen 0.1 s after the reference by a body moving at 1 m/s along x, without turning
    straight = ConstantVelocity(np.array([1.0, 0.0, 0.0]), np.zeros(3))
    pts = np.array([[2.0, 0.0, 0.0], [2.0, 1.0, 0.0]])
    times = np.array([0.0, 0.1])
    out = deskew_points(pts, times, 0, 0, 2, None, straight)
    np.testing.assert_allclose(out, [[2.0, 0.0, 0.0], [2.1, 1.0, 0.0]], atol=1e-12)
    # with no motion at all, points do not move
    np.testing.assert_array_equal(deskew_points(pts, times, 0, 0, 20, None, ConstantVelocity()), pts)
