"""Trajectory metrics with known answers: rigid transforms, added noise, known drift."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navlog.analysis.metrics import trajectory as tr
from navlog.analysis.metrics.trajectory import Trajectory


def _loop(n: int = 200, seed: int = 1) -> Trajectory:
    """A wavy 3D loop with turning orientation, 10 Hz."""
    s = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    pos = np.stack([3.0 * np.cos(s), 2.0 * np.sin(s), 0.3 * np.sin(3 * s)], axis=1)
    rng = np.random.default_rng(seed)
    quats = Rotation.from_euler(
        "zyx", np.stack([s + np.pi / 2, 0.05 * rng.standard_normal(n), 0.05 * np.sin(s)], 1)
    ).as_quat()
    times = 1_000_000_000 + np.arange(n, dtype=np.int64) * 100_000_000
    return Trajectory(times, pos, quats)


def _rigid(traj: Trajectory, rot: Rotation, t, scale: float = 1.0) -> Trajectory:
    return traj.transformed(rot.as_matrix(), t, scale)


def _kabsch_rmse(ref_pos: np.ndarray, est_pos: np.ndarray) -> float:
    """Independent check: scipy's Rotation.align_vectors on centred points (Kabsch)."""
    mr, me = ref_pos.mean(0), est_pos.mean(0)
    rot, _ = Rotation.align_vectors(ref_pos - mr, est_pos - me)
    aligned = rot.apply(est_pos - me) + mr
    return float(np.sqrt(np.mean(np.sum((aligned - ref_pos) ** 2, axis=1))))


# ---------------------------------------------------------------- the type


def test_trajectory_validates_and_normalises():
    t = Trajectory(np.array([0, 5], dtype=np.int64), [[0, 0, 0], [1, 0, 0]], [[0, 0, 0, 2.0], [0, 0, 1, 1]])
    assert np.allclose(t.quaternions[0], [0, 0, 0, 1])
    assert np.allclose(np.linalg.norm(t.quaternions, axis=1), 1.0)
    with pytest.raises(tr.TrajectoryError, match="increase strictly"):
        Trajectory(np.array([0, 5, 5]), np.zeros((3, 3)), np.tile([0, 0, 0, 1.0], (3, 1)))
    with pytest.raises(tr.TrajectoryError, match="zero quaternion"):
        Trajectory(np.array([0]), np.zeros((1, 3)), np.zeros((1, 4)))
    with pytest.raises(tr.TrajectoryError, match="integer"):
        Trajectory(np.array([0.5]), np.zeros((1, 3)), [[0, 0, 0, 1.0]])


def test_matrices_roundtrip():
    traj = _loop(20)
    back = Trajectory.from_matrices(traj.times_ns, traj.matrices())
    assert np.allclose(back.positions, traj.positions)
    assert np.allclose(tr.rotation_angles_deg(back.rotations(), traj.rotations()), 0.0, atol=1e-6)
    assert traj.path_lengths()[1] == pytest.approx(np.linalg.norm(traj.positions[1] - traj.positions[0]))


# ---------------------------------------------------------------- association


def test_associate_nearest_within_window():
    ref = Trajectory(np.arange(10, dtype=np.int64) * 100_000_000, np.zeros((10, 3)), np.tile([0, 0, 0, 1.0], (10, 1)))
    # estimate at 5 stamps: 3 ms, 48 ms (too far from 0 and 100 ms), 204 ms, 296 ms, 900 ms exactly
    est_t = np.array([3, 48, 204, 296, 900], dtype=np.int64) * 1_000_000
    est = Trajectory(est_t, np.arange(15.0).reshape(5, 3), np.tile([0, 0, 0, 1.0], (5, 1)))
    r, e = tr.associate(ref, est, max_diff_ns=10_000_000)
    assert list(r.times_ns) == [0, 200_000_000, 300_000_000, 900_000_000]
    assert list(e.times_ns) == [3_000_000, 204_000_000, 296_000_000, 900_000_000]
    # an offset moves the estimate's clock: +50 ms brings 48 ms onto 100 ms... and the others away
    r2, e2 = tr.associate(ref, est, max_diff_ns=5_000_000, offset_ns=52_000_000)
    assert list(e2.times_ns) == [48_000_000]
    assert list(r2.times_ns) == [100_000_000]


def test_associate_nothing_matches_says_why():
    ref = _loop(10)
    est = Trajectory(ref.times_ns + 10**12, ref.positions, ref.quaternions)
    with pytest.raises(tr.TrajectoryError, match="same clock"):
        tr.associate(ref, est)


# ---------------------------------------------------------------- alignment and ATE


def test_se3_alignment_recovers_known_transform_and_zero_ate():
    ref = _loop()
    rot = Rotation.from_euler("zyx", [40.0, -7.0, 12.0], degrees=True)
    shift = np.array([1.5, -2.0, 0.7])
    est = _rigid(ref, rot, shift)  # est = T * ref, so the alignment must be T^-1
    res = tr.absolute_trajectory_error(ref, est, align_mode="se3")
    assert res.pairs == len(ref)
    assert res.translation.rmse < 1e-9
    assert res.rotation.max < 1e-5
    inv = rot.inv()
    assert np.allclose(res.alignment.rotation, inv.as_matrix(), atol=1e-9)
    assert np.allclose(res.alignment.translation, -inv.apply(shift), atol=1e-9)
    # without alignment the error is the displacement of the transform itself
    raw = tr.absolute_trajectory_error(ref, est, align_mode="none")
    expected = np.linalg.norm(est.positions - ref.positions, axis=1)
    assert raw.translation.rmse == pytest.approx(np.sqrt(np.mean(expected**2)))
    assert raw.rotation.mean == pytest.approx(np.degrees(rot.magnitude()), abs=1e-6)


def test_se3_ate_with_noise_matches_independent_kabsch():
    ref = _loop(300)
    rng = np.random.default_rng(7)
    noisy = Trajectory(ref.times_ns, ref.positions + rng.normal(0.0, 0.03, ref.positions.shape), ref.quaternions)
    est = _rigid(noisy, Rotation.from_euler("z", 1.1), [4.0, 1.0, -0.5])
    res = tr.absolute_trajectory_error(ref, est, align_mode="se3")
    expected = _kabsch_rmse(ref.positions, est.positions)
    assert res.translation.rmse == pytest.approx(expected, rel=1e-9)
    # with 3 cm noise per axis, the 3D error is about 0.03 * sqrt(3)
    assert 0.045 < res.translation.rmse < 0.057
    errs = res.translation_errors
    assert res.translation.mean == pytest.approx(np.mean(errs))
    assert res.translation.median == pytest.approx(np.median(errs))
    assert res.translation.max == pytest.approx(np.max(errs))


def test_sim3_recovers_scale():
    ref = _loop()
    est = _rigid(ref, Rotation.from_euler("x", 0.3), [0.0, 2.0, 0.0], scale=0.5)
    se3 = tr.absolute_trajectory_error(ref, est, align_mode="se3")
    sim3 = tr.absolute_trajectory_error(ref, est, align_mode="sim3")
    assert sim3.alignment.scale == pytest.approx(2.0, rel=1e-9)
    assert sim3.translation.rmse < 1e-9
    assert se3.translation.rmse > 0.5  # a rigid alignment cannot undo a scale of 0.5


def test_umeyama_rejects_degenerate_input():
    line = np.stack([np.arange(10.0), np.zeros(10), np.zeros(10)], 1)
    with pytest.raises(tr.TrajectoryError, match="line"):
        tr.umeyama(line, line + 1.0)
    with pytest.raises(tr.TrajectoryError, match="at least 3"):
        tr.umeyama(line[:2], line[:2])


def test_planar_trajectory_aligns_with_proper_rotation():
    # a ground robot: all z = 0; the alignment must be a rotation (det +1), not a reflection
    s = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    pos = np.stack([np.cos(s), 2 * np.sin(s), np.zeros_like(s)], 1)
    ref = Trajectory(np.arange(50, dtype=np.int64), pos, Rotation.from_euler("z", s[:, None]).as_quat())
    est = _rigid(ref, Rotation.from_euler("z", -0.8), [0.2, 0.1, 0.0])
    res = tr.absolute_trajectory_error(ref, est, max_diff_ns=0)
    assert np.linalg.det(res.alignment.rotation) == pytest.approx(1.0)
    assert res.translation.rmse < 1e-9


def test_planar_ate_is_the_error_no_rigid_motion_in_the_plane_removes():
    # eight poses on a circle of 2 m, estimated on one of 2.1 m, turned and moved: no rotation or translation
    # takes one circle onto the other, and the best (the circles' centres together) leaves 0.1 m everywhere
    s = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    ref = np.stack([2.0 * np.cos(s), 2.0 * np.sin(s), s + np.pi / 2], axis=1)
    c, d = np.cos(0.7), np.sin(0.7)
    est = np.stack([2.1 * (c * np.cos(s) - d * np.sin(s)) + 3.0, 2.1 * (d * np.cos(s) + c * np.sin(s)) - 1.0, s], 1)
    assert tr.planar_ate(est, ref) == pytest.approx(0.1, abs=1e-12)
    assert tr.planar_ate(ref + [3.0, -1.0, 0.2], ref) == pytest.approx(0.0, abs=1e-12)


def test_a_position_in_a_planar_frame():
    """(1, 3) seen from a robot at (1, 2) facing +y is 1 m straight ahead; (0, 0) seen from the origin turned
    a half turn is still the origin; (2, 0) from there is 2 m behind."""
    frames = np.array([[1.0, 2.0, math.pi / 2], [0.0, 0.0, math.pi], [0.0, 0.0, math.pi]])
    xy = np.array([[1.0, 3.0], [0.0, 0.0], [2.0, 0.0]])
    assert np.allclose(tr.planar_in_frame(frames, xy), [[1.0, 0.0], [0.0, 0.0], [-2.0, 0.0]], atol=1e-12)


def test_three_trajectories_give_each_ones_own_relative_error():
    # a 2.5 km straight run of 0.5 m steps; three estimates, each the truth with seeded position noise of its
    # own (1, 2 and 3 cm per axis): a move over 1 m (two steps) differs by two noises, RMS 2 x sigma x sqrt(2)
    n = 5000
    truth = np.stack([np.arange(n) * 0.5, np.zeros(n), np.zeros(n)], axis=1)
    rng = np.random.default_rng(7)
    noisy = []
    for sigma in (0.01, 0.02, 0.03):
        t = truth.copy()
        t[:, :2] += rng.normal(0.0, sigma, (n, 2))
        noisy.append(t)
    own = tr.own_relative_errors(*noisy, travel=1.0)
    assert own == pytest.approx([2 * 0.01, 2 * 0.02, 2 * 0.03], rel=0.06)
    # the pairs taken along the truth's path: the same answer (the smallest figure, a difference of larger ones,
    # carries the most sampling noise)
    along = tr.own_relative_errors(*noisy, travel=1.0, along=truth)
    assert along == pytest.approx([2 * 0.01, 2 * 0.02, 2 * 0.03], rel=0.08)
    # what the reference-based figure says of the best of them against the worst: both errors together
    rmse = math.sqrt(np.mean(np.sum(np.square(np.diff(noisy[0][::2, :2] - noisy[2][::2, :2], axis=0)), axis=1)))
    assert rmse == pytest.approx(math.hypot(own[0], own[2]), rel=0.06)


def test_two_equal_trajectories_leave_the_third_all_the_difference():
    s = np.linspace(0, 4 * np.pi, 200)
    a = np.stack([5 * np.cos(s), 5 * np.sin(s), s + np.pi / 2], axis=1)
    c = a.copy()
    c[:, :2] += 0.05 * np.stack([np.cos(3 * s), np.sin(5 * s)], axis=1)
    own = tr.own_relative_errors(a, a, c, travel=1.0)
    moves = [tr._planar_moves(a, 1.0, x)[0] for x in (a, c)]
    assert own[0] == own[1] == 0.0
    assert own[2] == pytest.approx(math.sqrt(np.mean(np.sum((moves[0] - moves[1]) ** 2, axis=1))), rel=1e-12)
    assert all(math.isnan(v) for v in tr.own_relative_errors(a[:2], a[:2], a[:2], travel=100.0))


# ---------------------------------------------------------------- RPE


def _straight(n: int, step: float) -> Trajectory:
    pos = np.stack([np.arange(n) * step, np.zeros(n), np.zeros(n)], 1)
    return Trajectory(np.arange(n, dtype=np.int64) * 100_000_000, pos, np.tile([0, 0, 0, 1.0], (n, 1)))


def _drifting(n: int, step: float, yaw_per_step: float) -> Trajectory:
    """Each step: move `step` along the body x axis, then turn by yaw_per_step."""
    s = np.eye(4)
    s[:3, :3] = Rotation.from_euler("z", yaw_per_step).as_matrix()
    s[0, 3] = step
    poses = [np.eye(4)]
    for _ in range(n - 1):
        poses.append(poses[-1] @ s)
    return Trajectory.from_matrices(np.arange(n, dtype=np.int64) * 100_000_000, np.array(poses))


def test_rpe_on_known_drift_per_frame():
    alpha = np.radians(0.5)
    ref = _straight(50, 0.1)
    est = _drifting(50, 0.11, alpha)  # 1 cm per step too far and 0.5 deg per step of yaw drift
    res = tr.relative_pose_error(ref, est, delta=1, unit="frames")
    assert res.pairs == 49
    assert res.translation.max == pytest.approx(0.01, abs=1e-12)
    assert res.translation.min == pytest.approx(0.01, abs=1e-12)
    assert res.rotation.rmse == pytest.approx(0.5, abs=1e-9)


def test_rpe_over_two_frames_matches_closed_form():
    alpha = np.radians(0.5)
    ref = _straight(51, 0.1)
    est = _drifting(51, 0.11, alpha)
    res = tr.relative_pose_error(ref, est, delta=2, unit="frames")
    # est over 2 steps: (0.11 + 0.11 cos a, 0.11 sin a); ref: (0.2, 0)
    expected = np.hypot(0.11 + 0.11 * np.cos(alpha) - 0.2, 0.11 * np.sin(alpha))
    assert res.pairs == 25
    assert res.translation.rmse == pytest.approx(expected, rel=1e-9)
    assert res.rotation.mean == pytest.approx(1.0, abs=1e-9)
    all_pairs = tr.relative_pose_error(ref, est, delta=2, unit="frames", all_pairs=True)
    assert all_pairs.pairs == 49


def test_rpe_in_metres_and_seconds_picks_pairs_along_reference():
    ref = _straight(51, 0.1)  # 5 m at 1 m/s
    i, j = tr.pair_indices(ref, 0.5, "m")
    assert list(i) == list(range(0, 50, 5)) and list(j) == list(range(5, 51, 5))
    i, j = tr.pair_indices(ref, 1.0, "s")
    assert list(i) == list(range(0, 50, 10)) and list(j) == list(range(10, 51, 10))
    # a delta below the samples' spacing (down to none: 1e-9 m once looped for ever) pairs neighbours
    for tiny in (1e-9, 1e-300):
        for unit in ("m", "s"):
            i, j = tr.pair_indices(ref, tiny, unit)
            assert list(i) == list(range(50)) and list(j) == list(range(1, 51))
    est = _drifting(51, 0.11, 0.0)
    res = tr.relative_pose_error(ref, est, delta=1.0, unit="m")
    assert res.pairs == 5
    assert res.translation.mean == pytest.approx(0.1, abs=1e-9)  # 10 steps x 1 cm


def test_rpe_pairs_along_the_estimate_path():
    ref = _straight(31, 0.1)
    est = _drifting(31, 0.2, 0.0)  # twice as fast: 0.5 m of its own path every 3 steps
    from_ref = tr.relative_pose_error(ref, est, delta=0.5, unit="m")
    from_est = tr.relative_pose_error(ref, est, delta=0.5, unit="m", pairs_from="estimate")
    assert from_ref.pairs == 6 and from_est.pairs == 10
    assert from_ref.translation.mean == pytest.approx(0.5)  # 1.0 m against 0.5 m
    assert from_est.translation.mean == pytest.approx(0.3)  # 0.6 m against 0.3 m


def test_rpe_ignores_a_rigid_offset():
    ref = _loop()
    est = _rigid(ref, Rotation.from_euler("zyx", [30, 10, -5], degrees=True), [5.0, 5.0, 1.0])
    res = tr.relative_pose_error(ref, est, delta=1.0, unit="m")
    assert res.translation.max < 1e-9
    assert res.rotation.max < 1e-5


def test_rpe_delta_too_large_is_explained():
    with pytest.raises(tr.TrajectoryError, match="smaller delta"):
        tr.relative_pose_error(_straight(10, 0.1), _straight(10, 0.1), delta=5.0, unit="m")


# ---------------------------------------------------------------- interpolation


def _arc(times_ns: np.ndarray, radius: float = 2.0, omega: float = 0.5) -> Trajectory:
    """A robot on a circle at constant yaw rate, heading along the circle."""
    th = omega * times_ns.astype(np.float64) / 1e9
    pos = np.stack([radius * np.cos(th), radius * np.sin(th), np.zeros_like(th)], 1)
    return Trajectory(times_ns, pos, Rotation.from_euler("z", (th + np.pi / 2)[:, None]).as_quat())


def test_interpolated_association_removes_the_stamp_offset_error():
    ref = _arc(np.arange(0, 10_000_000_000, 20_000_000, dtype=np.int64))  # 50 Hz for 10 s
    est_t = np.arange(100_000_000, 9_900_000_000, 100_000_000, dtype=np.int64) + 7_000_000  # 10 Hz, 7 ms late
    est = _arc(est_t)
    nearest = tr.absolute_trajectory_error(ref, est, align_mode="none")
    chord = 2 * 2.0 * np.sin(0.5 * 0.007 / 2)  # the arc travelled in 7 ms
    assert nearest.translation.rmse == pytest.approx(chord, rel=1e-6)
    r, e = tr.associate_interpolated(ref, est)
    assert list(r.times_ns) == list(est_t)
    interp = tr.absolute_trajectory_error(r, e, align_mode="none", max_diff_ns=None)
    # linear interpolation between poses 20 ms apart on a 2 m circle: sagitta below 3e-5 m
    assert interp.translation.max < 3e-5
    assert interp.rotation.max < 1e-9


def test_interpolation_drops_times_outside_and_across_gaps():
    t = np.array([0, 100, 200, 1200, 1300], dtype=np.int64)
    ref = Trajectory(t, np.stack([t / 100.0, np.zeros(5), np.zeros(5)], 1), np.tile([0, 0, 0, 1.0], (5, 1)))
    at, keep = tr.interpolate(ref, np.array([-5, 0, 150, 700, 1250, 1300, 1400]), max_gap_ns=200)
    assert list(keep) == [1, 2, 4, 5]
    assert at.positions[:, 0].tolist() == pytest.approx([0.0, 1.5, 12.5, 13.0])
    with pytest.raises(tr.TrajectoryError, match="time span"):
        tr.associate_interpolated(ref, Trajectory(np.array([5000]), np.zeros((1, 3)), [[0, 0, 0, 1.0]]))


def test_from_tum_reads_the_file_and_normalises_quaternions(tmp_path):
    from navlog.errors import NavlogError

    path = tmp_path / "t.tum"
    path.write_text("# t x y z qx qy qz qw\n1.5 1 2 3 0 0 0 2\n2.000000001 4 5 6 0 0 3 4\n")
    traj = Trajectory.from_tum(path)
    assert traj.times_ns.tolist() == [1_500_000_000, 2_000_000_001]
    assert traj.positions.tolist() == [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]
    assert traj.quaternions.tolist() == [[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.6, 0.8]]
    path.write_text("1.0 1 2 3 0 0 0 1\n2.0 1 2 3 0 0 1\n")
    with pytest.raises(NavlogError, match=r"t\.tum:2: expected 8 numbers"):
        Trajectory.from_tum(path)


@pytest.mark.slow
def test_three_cornered_hat_on_a_slam_run_whose_truth_is_known(tmp_path):
    """navlog's mapping tour (kibot, its wheel odometry drifting, no localiser) and the SLAM's replay of it: the
    SLAM's and the odometry's errors over 1 m hardly correlate, and the comparison of a reference made of the
    truth plus known noise with the SLAM and the odometry finds that noise and the odometry's own error."""
    from navlog.recorder.record import prepare, record
    from navlog.replay.io.formats import open_log
    from navlog.replay.session import run_replay
    from tests.replay.mapping.lap_logs import yaw_of
    from tests.replay.mapping.planar_logs import planar_tum

    log = tmp_path / "mapping.mcap"
    record(prepare("indoor_room", "kibot", "mapping", localization="none"), log, progress=False, sensor_worker=False)
    run_replay(log, "mapping", tmp_path / "out", overrides=["pose_source=slam", "lidar_mapper=off"], progress=False)
    stamps, slam = planar_tum(tmp_path / "out" / "trajectory.tum")
    series: dict[str, tuple[list, list]] = {"/odom": ([], []), "/odom/ground_truth": ([], [])}
    with open_log(log) as reader:
        for env in reader.messages(list(series)):
            m = env.msg
            series[env.topic][0].append(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec)
            p = m.pose.pose.position
            series[env.topic][1].append([p.x, p.y, yaw_of(m.pose.pose.orientation)])

    def at_stamps(topic: str) -> np.ndarray:
        times, poses = np.array(series[topic][0]), np.array(series[topic][1])
        i = np.clip(np.searchsorted(times, stamps), 0, len(times) - 1)
        assert np.all(np.abs(times[i] - stamps) < 30_000_000)  # odometry at 50 Hz, scans at 10 Hz
        return poses[i]

    truth, odom = at_stamps("/odom/ground_truth"), at_stamps("/odom")
    true_moves, slam_moves, odom_moves = tr._planar_moves(truth, 1.0, truth, slam, odom)
    e_slam, e_odom = slam_moves - true_moves, odom_moves - true_moves
    own_slam, own_odom = (math.sqrt(np.mean(np.sum(e**2, axis=1))) for e in (e_slam, e_odom))
    assert own_odom > 2 * own_slam > 0  # the wheels drift; the laser holds the SLAM
    assert abs(np.mean(np.sum(e_slam * e_odom, axis=1))) < 0.15 * own_slam * own_odom
    # the truth itself as the reference: nothing of its own, and the other two their true figures
    ref_own, slam_own, odom_own = tr.own_relative_errors(truth, slam, odom, 1.0)
    assert ref_own < own_slam  # the truth scores below the best estimate (its own figure: 0.0011 against 0.0030)
    assert slam_own == pytest.approx(own_slam, rel=0.25) and odom_own == pytest.approx(own_odom, rel=0.1)
    noisy = truth.copy()
    noisy[:, :2] += np.random.default_rng(0).normal(0.0, 0.02, (len(truth), 2))
    ref_own, _, _ = tr.own_relative_errors(noisy, slam, odom, 1.0, along=truth)
    assert ref_own == pytest.approx(0.04, rel=0.1)  # 2 cm on each axis of both ends of a move
