"""Nav2's AMCL: parameters from real Nav2 files, the motion and sensor models, KLD sampling, convergence in a known room."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay.nav2 import load_nav2_params, parse_nav2_text
from navlog.replay.nav2.amcl import (
    OMNI,
    AmclParams,
    LikelihoodField,
    ParticleFilter,
    Scan,
    kld_limit,
    sample_differential,
    sample_omni,
)
from navlog.replay.occupancy_map import OccupancyMap

RES = 0.05
LASER = (0.2, 0.0, 0.0)  # laser 0.2 m ahead of the base


def room() -> OccupancyMap:
    """A 6 x 6 m room (walls one cell thick at x, y = 0 and 5.95 m) with a 1 x 0.5 m box at (4, 1)-(5, 1.5)."""
    data = np.zeros((120, 120), dtype=np.int8)
    data[0, :] = data[-1, :] = data[:, 0] = data[:, -1] = 100
    data[20:30, 80:100] = 100
    return OccupancyMap(data, RES, (0.0, 0.0, 0.0))


def cast(occ: OccupancyMap, pose, n: int = 360, rmax: float = 8.0) -> Scan:
    """A 360-degree scan from the laser at ``pose`` (x, y, yaw of the base), marched in 5 mm steps."""
    x, y, yaw = pose
    ox, oy = x + math.cos(yaw) * LASER[0], y + math.sin(yaw) * LASER[0]
    bearings = -math.pi + 2 * math.pi / n * np.arange(n)
    steps = np.arange(0.005, rmax, 0.005)
    px = ox + np.cos(yaw + bearings)[:, None] * steps
    py = oy + np.sin(yaw + bearings)[:, None] * steps
    col, row = np.floor(px / RES).astype(int), np.floor(py / RES).astype(int)
    inside = (col >= 0) & (col < occ.width) & (row >= 0) & (row < occ.height)
    hit = np.zeros(px.shape, dtype=bool)
    hit[inside] = occ.data[row[inside], col[inside]] == 100
    first = np.where(hit.any(axis=1), hit.argmax(axis=1), -1)
    ranges = np.where(first >= 0, steps[np.maximum(first, 0)], np.inf)
    return Scan(ranges, bearings, 0.1, rmax)


# ---------------------------------------------------------------- parameters


def test_reads_the_amcl_block_of_the_jazzy_and_humble_files(params_dir):
    for name in ("nav2_bringup_jazzy_nav2_params.yaml", "turtlebot3_humble_waffle_nav2.yaml"):
        nav2 = load_nav2_params(params_dir / name)
        assert nav2.amcl is not None, name
        assert [p for p in nav2.errors if p.path.startswith("amcl")] == [], name
        a = nav2.amcl
        assert (a.alpha1, a.max_particles, a.min_particles, a.max_beams) == (0.2, 2000, 500, 60)
        assert (a.laser_likelihood_max_dist, a.pf_err, a.pf_z, a.update_min_d) == (2.0, 0.05, 0.99, 0.25)
        assert a.robot_model_type == "nav2_amcl::DifferentialMotionModel"
        assert "amcl" not in nav2.not_implemented


def test_reads_the_seed_001_file_frames_and_topic(seeds_dir):
    text = next(seeds_dir.glob("001_*.txt")).read_text()
    block = text[text.index("amcl:") : text.index("bt_navigator:")]
    a = parse_nav2_text(block).require_valid().amcl
    assert a is not None
    assert (a.base_frame_id, a.odom_frame_id, a.scan_topic) == ("simple_robot/base_link", "simple_robot/odom", "lidar")


def test_bad_amcl_parameters_are_named():
    nav2 = parse_nav2_text(
        "amcl:\n  ros__parameters:\n    alpah1: 0.3\n    laser_model_type: beam\n    min_particles: 3000\n"
        "    robot_model_type: differential\n    initial_pose: {x: 1.0, y: 2.0, yaw: 0.5, zz: 1}\n"
    )
    messages = {p.path: p.message for p in nav2.errors}
    assert "did you mean 'alpha1'" in messages["amcl.ros__parameters.alpah1"]
    assert "not implemented" in messages["amcl.ros__parameters.laser_model_type"]
    assert "above max_particles (2000)" in messages["amcl.ros__parameters.min_particles"]
    assert "nav2_amcl::OmniMotionModel" in messages["amcl.ros__parameters.robot_model_type"]
    assert "amcl.ros__parameters.initial_pose.zz" in messages or any("zz" in p.path for p in nav2.problems)
    assert nav2.amcl is not None and (nav2.amcl.initial_pose_x, nav2.amcl.initial_pose_yaw) == (1.0, 0.5)
    # a tolerance the published transforms' 32-bit seconds cannot hold (it failed in their serialisation)
    nav2 = parse_nav2_text("amcl:\n  ros__parameters:\n    transform_tolerance: 1.0e+30\n")
    messages = {p.path: p.message for p in nav2.errors}
    assert "must be <= 3600.0" in messages["amcl.ros__parameters.transform_tolerance"]


# ---------------------------------------------------------------- models


def test_kld_limit_follows_the_wilson_hilferty_bound():
    # k = 2 bins, z = 3, err = 0.05: x = 1 - 2/9 + sqrt(2/9) * 3 = 2.1920; n = ceil(1 / 0.1 * x^3) = 106
    assert kld_limit(2, 0.05, 3.0, 0, 10**6) == 106
    assert kld_limit(1, 0.05, 3.0, 0, 5000) == 5000  # one bin: as many as allowed
    assert kld_limit(50, 0.05, 0.99, 500, 2000) == 588  # Nav2's pf_z passed as the quantile
    assert kld_limit(2, 0.05, 0.99, 500, 2000) == 500  # clamped to min_particles
    assert kld_limit(400, 0.05, 0.99, 500, 2000) == 2000  # and to max_particles


def test_noise_free_differential_model_applies_odometry_in_each_particle_frame():
    rng = np.random.default_rng(0)
    poses = np.array([[1.0, 2.0, math.pi / 2], [0.0, 0.0, 0.0]])
    out = sample_differential(poses, np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.5]), (0.0,) * 5, rng)
    np.testing.assert_allclose(out, [[1.0, 3.0, math.pi / 2 + 0.5], [1.0, 0.0, 0.5]], atol=1e-12)


def test_noise_free_omni_model_strafes():
    rng = np.random.default_rng(0)
    poses = np.array([[0.0, 0.0, math.pi / 2]])
    # odometry moved 1 m to the robot's left: a particle facing +y moves to -x
    out = sample_omni(poses, np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]), (0.0,) * 5, rng)
    np.testing.assert_allclose(out, [[-1.0, 0.0, math.pi / 2]], atol=1e-12)


def test_differential_noise_grows_with_the_alphas():
    rng = np.random.default_rng(1)
    poses = np.zeros((4000, 3))
    out = sample_differential(poses, np.zeros(3), np.array([1.0, 0.0, 0.0]), (0.0, 0.0, 0.2, 0.0, 0.0), rng)
    # only alpha3 (translation from translation): the distance spreads by sqrt(0.2) * 1 m, the heading not at all
    assert np.std(out[:, 0]) == pytest.approx(math.sqrt(0.2), rel=0.05)
    assert np.allclose(out[:, 2], 0.0) and np.allclose(out[:, 1], 0.0)


def test_likelihood_field_measures_to_the_wall_surface():
    field = LikelihoodField(room(), 1.5)
    # the west wall's cells span x in [0, 0.05): its surface is at x = 0.05, and inside the wall reads 0
    d = field.lookup(np.array([0.05, 0.55, 1.05, 0.02, 2.5, -1.0]), np.array([3.0, 3.0, 3.0, 3.0, 3.0, 3.0]))
    np.testing.assert_allclose(d[:4], [0.0, 0.5, 1.0, 0.0], atol=1e-9)
    assert d[4] == pytest.approx(1.5)  # clipped at laser_likelihood_max_dist (nearest surface 2.1 m away)
    assert d[5] == 1.5  # off the map


def test_sensor_model_prefers_the_true_pose():
    occ = room()
    true = (2.0, 3.0, 0.3)
    pf = ParticleFilter(AmclParams(), LikelihoodField(occ, 2.0), np.random.default_rng(0))
    pf.poses = np.array([true, (2.1, 3.0, 0.3), (2.0, 3.0, 0.4), (2.5, 2.5, 0.3)])
    pf.weights = np.full(4, 0.25)
    pf.sensor_update(cast(occ, true), LASER)
    assert int(np.argmax(pf.weights)) == 0
    assert pf.weights[0] > 1.5 * pf.weights[3]


def test_a_set_heading_west_is_one_cluster_whose_mean_is_the_heading():
    """Particles around yaw = 180 degrees (std 8 degrees) keep their yaw continuous, as nav2_amcl's do: one
    cluster, its circular mean within a degree of 180. Wrapped into [-pi, pi), the set split into two
    clusters at both ends of the yaw bins and the estimate was one half's mean, ~7 degrees off."""
    pf = ParticleFilter(AmclParams(), LikelihoodField(room(), 2.0), np.random.default_rng(5))
    pf.init_gaussian((3.0, 3.0, math.pi), np.diag([0.05**2, 0.05**2, math.radians(8.0) ** 2]))
    for _ in range(5):  # turning through 180 degrees and back: the yaw stays continuous
        pf.motion_update(np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.1]))
    pf.motion_update(np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, -0.5]))
    est = pf.estimate()
    assert est.clusters == 1
    assert abs(math.degrees(math.remainder(est.pose[2] - math.pi, 2 * math.pi))) < 1.0


# ---------------------------------------------------------------- the filter


def drive(pf: ParticleFilter, occ: OccupancyMap, start, steps: int):
    """Drive 5 cm forward and turn 0.05 rad per step from ``start``; noise-free odometry. Returns the true pose."""
    true = np.array(start, dtype=np.float64)
    odom = np.zeros(3)
    for _ in range(steps):
        new_true = true + [0.05 * math.cos(true[2]), 0.05 * math.sin(true[2]), 0.05]
        new_odom = odom + [0.05 * math.cos(odom[2]), 0.05 * math.sin(odom[2]), 0.05]
        pf.motion_update(odom, new_odom)
        pf.sensor_update(cast(occ, new_true), LASER)
        pf.resample()
        true, odom = new_true, new_odom
    return true


@pytest.mark.slow
@pytest.mark.parametrize(
    ("model", "robot"),
    [
        ("likelihood_field", "nav2_amcl::DifferentialMotionModel"),
        ("likelihood_field_prob", "nav2_amcl::DifferentialMotionModel"),
        ("likelihood_field_prob", OMNI),
    ],
)
def test_filter_converges_from_half_a_metre_and_0_3_rad(model, robot):
    occ = room()
    start = (2.0, 3.0, 0.0)
    # z_rand 0.05: the random floor is z_rand / the laser's 8 m (as nav2_amcl takes the scan's range_max under
    # laser_max_range); Nav2's 0.5 / 8 would flatten the product model so much that KLD keeps every particle
    params = AmclParams(laser_model_type=model, robot_model_type=robot, sigma_hit=0.1, max_beams=90, z_rand=0.05)
    pf = ParticleFilter(params, LikelihoodField(occ, 2.0), np.random.default_rng(7))
    pf.init_gaussian((2.5, 3.0, 0.3), np.diag([0.5**2, 0.5**2, 0.3**2]))
    first = pf.estimate()
    assert math.hypot(*(first.pose[:2] - start[:2])) > 0.3  # the estimate starts at the wrong pose
    true = drive(pf, occ, start, 30)  # 1.5 m and 1.5 rad
    est = pf.estimate()
    assert math.hypot(*(est.pose[:2] - true[:2])) < 0.05
    assert abs(math.remainder(est.pose[2] - true[2], 2 * math.pi)) < 0.05
    assert params.min_particles <= len(pf.poses) < params.max_particles  # KLD shrank the set


def test_same_seed_same_particles_and_recovery_particles_when_lost():
    occ = room()
    params = AmclParams(
        laser_model_type="likelihood_field_prob",
        recovery_alpha_slow=0.001,
        recovery_alpha_fast=0.1,
        max_particles=800,
        min_particles=200,
    )
    runs = []
    for _ in range(2):
        pf = ParticleFilter(params, LikelihoodField(occ, 2.0), np.random.default_rng(3))
        pf.init_gaussian((2.0, 3.0, 0.0), np.diag([0.01, 0.01, 0.01]))
        pf.sensor_update(cast(occ, (2.0, 3.0, 0.0)), LASER)
        pf.resample()
        # the robot is elsewhere: w_fast drops below w_slow and random particles appear in free space
        for _ in range(3):
            pf.sensor_update(cast(occ, (4.5, 4.5, 2.0)), LASER)
        w_diff = 1.0 - pf.w_fast / pf.w_slow
        before = pf.poses.copy()
        pf.resample()
        runs.append(pf.poses)
        assert w_diff > 0.05
        moved = ~np.isin(pf.poses[:, 0], before[:, 0])
        assert moved.sum() > 0.05 * len(pf.poses)
        assert (pf.w_slow, pf.w_fast) == (0.0, 0.0)
    np.testing.assert_array_equal(runs[0], runs[1])


# ---------------------------------------------------------------- the node's /initialpose


def initial_pose_msg(frame: str, x: float, y: float, yaw: float, cov: np.ndarray):
    from navlog.replay import messages

    return messages.planar_pose_with_covariance(0, frame, (x, y, yaw), cov)


def test_initialpose_restarts_the_filter_around_the_given_gaussian():
    from navlog.replay.nodes.amcl import AmclNode

    node = AmclNode(AmclParams(max_particles=4000), room(), np.random.default_rng(0))
    assert node.initialised_ns is None
    cov = np.diag([0.3**2, 0.1**2, 0.2**2])
    node._on_initial_pose(initial_pose_msg("odom", 2.0, 3.0, 0.5, cov), 0)
    assert node.initialised_ns is None  # not in the global frame: ignored and counted
    assert any("is not the global frame 'map'" in k for k in node.skipped_counts())
    node._on_initial_pose(initial_pose_msg("map", 2.0, 3.0, 0.5, cov), 0)
    assert node.initialised_ns == 0 and len(node.filter.poses) == 4000
    np.testing.assert_allclose(node.filter.poses.mean(axis=0), [2.0, 3.0, 0.5], atol=0.02)
    np.testing.assert_allclose(node.filter.poses.std(axis=0), [0.3, 0.1, 0.2], rtol=0.05)


def test_closing_up_empty_bins_keeps_neighbours_and_bounds_the_axis():
    """Bins stay neighbours (one apart or the same) exactly when they were; 600 turns of yaw bins (10 deg)
    close up to at most twice the occupied bins instead of a grid 21,600 bins deep."""
    from navlog.replay.nav2.amcl import _closed_up

    rng = np.random.default_rng(3)
    keys = np.concatenate([rng.integers(-40, 40, 300), rng.integers(21_560, 21_600, 50), [-18, 17]])
    closed = _closed_up(keys)
    near = np.abs(keys[:, None] - keys[None, :]) <= 1
    assert np.array_equal(near, np.abs(closed[:, None] - closed[None, :]) <= 1)
    assert closed.min() == 0 and closed.max() < 2 * len(np.unique(keys))
