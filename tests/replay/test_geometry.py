"""Rotations, transforms, planar poses and grid cells with known numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navlog.replay import geometry as g

S = math.sqrt(0.5)  # sin and cos of 45 degrees


def test_yaw_and_quaternion_of_a_quarter_turn():
    q = g.quat_from_yaw(math.pi / 2)
    assert q == pytest.approx((0.0, 0.0, S, S), abs=1e-15)
    assert g.yaw_from_quat(q) == pytest.approx(math.pi / 2, abs=1e-15)
    assert g.yaw_from_quat((0.0, 0.0, 1.0, 0.0)) == pytest.approx(math.pi)  # half a turn
    assert g.quat_from_rpy(0.0, 0.0, math.pi / 2) == pytest.approx(q, abs=1e-15)
    assert g.quat_from_rpy(math.pi, 0.0, 0.0) == pytest.approx((1.0, 0.0, 0.0, 0.0), abs=1e-15)
    assert g.quat_to_wxyz((1.0, 2.0, 3.0, 4.0)) == (4.0, 1.0, 2.0, 3.0)
    assert g.quat_from_wxyz((4.0, 1.0, 2.0, 3.0)) == (1.0, 2.0, 3.0, 4.0)


def test_quaternion_and_matrix_of_a_quarter_turn_about_z():
    r = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    q = np.array(g.quat_from_yaw(math.pi / 2))
    for m in (g.quat_to_matrix(q), g.unit_quat_to_matrix(q), g.unit_quats_to_matrices(q[None])[0]):
        np.testing.assert_allclose(m, r, atol=1e-15)
    np.testing.assert_allclose(g.matrix_to_quat(r), q, atol=1e-15)
    np.testing.assert_allclose(g.matrices_to_quats(r[None])[0], q, atol=1e-15)
    assert g.rotation_angle(r) == pytest.approx(math.pi / 2)
    assert g.yaw_from_matrix(r) == pytest.approx(math.pi / 2)
    # SciPy's conversion normalises its input; the closed form expects a unit quaternion
    np.testing.assert_allclose(g.quat_to_matrix(2.0 * q), r, atol=1e-15)


def test_matrix_quaternion_round_trips():
    rots = Rotation.from_euler("xyz", [[0.1, -0.2, 0.3], [3.0, 0.5, -2.0], [0.0, 0.0, math.pi], [-1.2, 1.5, 0.7]])
    mats = rots.as_matrix()
    quats = g.matrices_to_quats(mats)
    np.testing.assert_allclose(g.unit_quats_to_matrices(quats), mats, atol=1e-14)
    for m, q in zip(mats, quats):
        q1 = np.array(g.matrix_to_quat(m))
        assert q1[3] >= 0
        np.testing.assert_allclose(abs(q1 @ q), 1.0, atol=1e-14)  # the same rotation, up to sign
        np.testing.assert_allclose(g.quat_to_matrix(q1), m, atol=1e-14)
        np.testing.assert_allclose(g.unit_quat_to_matrix(q1), m, atol=1e-14)


def test_products_and_rotation_vectors():
    qz = np.array(g.quat_from_yaw(0.3))
    both = g.quat_mul(qz, np.array(g.quat_from_yaw(0.4)))
    np.testing.assert_allclose(both, g.quat_from_yaw(0.7), atol=1e-15)
    np.testing.assert_allclose(g.quats_mul(qz[None], qz[None])[0], g.quat_from_yaw(0.6), atol=1e-15)
    np.testing.assert_allclose(g.quat_exp(np.array([0.0, 0.0, 0.7])), g.quat_from_yaw(0.7), atol=1e-15)
    np.testing.assert_allclose(g.quat_exp(np.zeros(3)), [0.0, 0.0, 0.0, 1.0])
    r = g.rotvecs_to_matrices(np.array([[0.0, 0.0, math.pi / 2], [0.0, 0.0, 0.0]]))
    np.testing.assert_allclose(r[0], [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-15)
    np.testing.assert_array_equal(r[1], np.eye(3))
    np.testing.assert_allclose(g.matrix_to_rotvec(r[0]), [0.0, 0.0, math.pi / 2], atol=1e-15)


def test_slerp_halfway_between_two_known_rotations():
    q0, q1 = np.array(g.quat_from_yaw(0.0)), np.array(g.quat_from_yaw(math.pi / 2))
    np.testing.assert_allclose(g.slerp(q0, q1, 0.5), g.quat_from_yaw(math.pi / 4), atol=1e-15)
    np.testing.assert_allclose(g.slerp_rows(q0[None], q1[None], np.array([0.5]))[0], g.quat_from_yaw(math.pi / 4))
    # the shorter way round: -q1 is the same rotation
    np.testing.assert_allclose(g.slerp(q0, -q1, 0.5), g.quat_from_yaw(math.pi / 4), atol=1e-15)
    # the ends, and nearly equal rotations
    np.testing.assert_allclose(g.slerp(q0, q1, 1.0), q1, atol=1e-15)
    near = np.array(g.quat_from_yaw(1e-3))
    np.testing.assert_allclose(g.slerp(q0, near, 0.5), g.quat_from_yaw(5e-4), atol=1e-12)
    np.testing.assert_allclose(g.slerp_rows(q0[None], q0[None], np.array([0.3]))[0], q0)


def test_transforms_and_planar_poses():
    t = g.make_transform((1.0, 2.0, 3.0), g.quat_from_yaw(math.pi / 2))
    np.testing.assert_allclose(t @ [1.0, 0.0, 0.0, 1.0], [1.0, 3.0, 3.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(g.unit_quat_transform((1.0, 2.0, 3.0), np.array(g.quat_from_yaw(math.pi / 2))), t)
    p = g.planar_matrix(1.0, 2.0, math.pi / 2)
    np.testing.assert_allclose(p, [[0, -1, 0, 1], [1, 0, 0, 2], [0, 0, 1, 0], [0, 0, 0, 1]], atol=1e-15)
    assert g.rotate_planar(1.0, 0.0, math.pi / 2) == pytest.approx((0.0, 1.0), abs=1e-15)
    # a part 1 m ahead and turned by 0.1, on a body at (1, 2) facing +y
    x, y, yaw = g.se2_compose((1.0, 2.0, math.pi / 2), (1.0, 0.0, 0.1))
    assert (x, y, yaw) == pytest.approx((1.0, 3.0, math.pi / 2 + 0.1), abs=1e-15)
    m = g.planar_matrix(1.0, 2.0, math.pi / 2) @ g.planar_matrix(1.0, 0.0, 0.1)
    assert (m[0, 3], m[1, 3], g.yaw_from_matrix(m)) == pytest.approx((x, y, yaw), abs=1e-15)
    assert g.wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert g.wrap_angle(-0.5) == -0.5


def test_world_to_cell_and_back_on_a_known_grid():
    origin, res = (-1.0, 2.0), 0.5
    xy = np.array([[-1.0, 2.0], [-0.76, 2.49], [0.26, 2.5], [-1.01, 1.99]])
    np.testing.assert_array_equal(g.world_to_cell(xy, origin, res), [[0, 0], [0, 0], [2, 1], [-1, -1]])
    np.testing.assert_allclose(g.cell_to_world(np.array([[0, 0], [2, 1]]), origin, res), [[-0.75, 2.25], [0.25, 2.75]])
    # one axis with a scalar origin
    np.testing.assert_allclose(g.cell_to_world(np.arange(3), -1.0, res), [-0.75, -0.25, 0.25])
    np.testing.assert_array_equal(g.world_to_cell(np.array([-0.75, -0.25, 0.25]), -1.0, res), [0, 1, 2])


def test_rigid_inverse_undoes_a_transform_as_a_general_inverse_does():
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = rng.normal(size=4)
        t = g.make_transform(rng.normal(size=3) * 10, q / np.linalg.norm(q))
        inv = g.rigid_inverse(t)
        np.testing.assert_allclose(inv @ t, np.eye(4), atol=1e-12)
        np.testing.assert_allclose(inv, np.linalg.inv(t), atol=1e-12)
        assert inv[3].tolist() == [0.0, 0.0, 0.0, 1.0]
    # a known one: 90 degrees about z at (1, 2, 3) -> back: (-2, 1, -3)
    t = g.unit_quat_transform((1.0, 2.0, 3.0), g.quat_from_yaw(math.pi / 2))
    np.testing.assert_allclose(g.rigid_inverse(t)[:3, 3], (-2.0, 1.0, -3.0), atol=1e-15)


def rotations_of_every_kind(seed: int) -> np.ndarray:
    """Random rotations, compositions of them, small angles, half turns (w = 0), the identity and the
    axis-aligned half turns: each of the quaternion formulas and both rotation-vector branches."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(4000, 4))
    mats = g.unit_quats_to_matrices(q / np.linalg.norm(q, axis=1, keepdims=True))
    axes = rng.normal(size=(500, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    small = g.rotvecs_to_matrices(axes * rng.choice([1e-2, 2e-3, 1e-3, 1e-5], size=(500, 1)))
    half = g.rotvecs_to_matrices(axes * math.pi)
    special = np.array([np.eye(3), np.diag([1.0, -1, -1]), np.diag([-1.0, 1, -1]), np.diag([-1.0, -1, 1])])
    return np.concatenate([mats, mats[:500] @ mats[500:1000], small, half, special])


def test_matrix_quaternions_and_rotation_vectors_are_scipys_to_the_bit():
    mats = rotations_of_every_kind(9)
    want_q = Rotation.from_matrix(mats).as_quat(canonical=True)
    assert g.matrices_to_canonical_quats(mats).tobytes() == want_q.tobytes()
    assert np.array(g.matrix_to_quat(mats[-2])).tolist() == [0.0, 1.0, 0.0, 0.0]  # diag(-1, 1, -1)
    for m, q in zip(mats[::7], want_q[::7]):
        assert np.array(g.matrix_to_quat(m)).tobytes() == q.tobytes()
        assert g.matrix_to_rotvec(m).tobytes() == Rotation.from_matrix(m).as_rotvec().tobytes()
    np.testing.assert_allclose(g.matrix_to_rotvec(np.diag([-1.0, -1, 1])), [0.0, 0.0, math.pi])


def test_a_matrix_that_is_not_a_rotation_goes_through_scipy():
    # SciPy makes it orthonormal first (an SVD): the result is SciPy's, not the formula's on the raw matrix
    skewed = np.array([[1.0, 1e-6, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    assert g._scipy_quat(skewed) is None and g._scipy_quat(np.diag([1.0, 1.0, -1.0])) is None  # a reflection
    assert g._scipy_quat(np.full((3, 3), np.nan)) is None
    assert (
        np.array(g.matrix_to_quat(skewed)).tobytes() == Rotation.from_matrix(skewed).as_quat(canonical=True).tobytes()
    )
    assert g.matrix_to_rotvec(skewed).tobytes() == Rotation.from_matrix(skewed).as_rotvec().tobytes()
    both = np.stack([np.eye(3), skewed])
    assert g.matrices_to_canonical_quats(both).tobytes() == Rotation.from_matrix(both).as_quat(canonical=True).tobytes()
    assert g.matrices_to_canonical_quats(np.zeros((0, 3, 3))).shape == (0, 4)


# ------------------------------------------------------------ angles
def test_every_wrapping_agrees_on_the_angle_and_states_its_sign():
    from navlog.replay.geometry import (
        angle_diff,
        normalize_angle,
        shortest_angular_distance,
        shortest_angular_distances,
        wrap_angle,
        wrap_angles,
    )

    for a, b in [(0.0, 0.5), (0.5, 0.0), (3.0, -3.0), (-3.0, 3.0), (10.0, -7.5)]:
        want = math.atan2(math.sin(b - a), math.cos(b - a))  # the signed angle from a to b
        assert wrap_angle(b - a) == pytest.approx(want)
        assert float(wrap_angles(np.float64(b - a))) == pytest.approx(want)
        assert shortest_angular_distance(a, b) == pytest.approx(want)
        assert float(shortest_angular_distances(a, b)) == pytest.approx(want)
        assert angle_diff(b, a) == pytest.approx(want)  # Nav2 AMCL's angle_diff(a, b) is a - b
        assert normalize_angle(b - a) == pytest.approx(want)
    # [-pi, pi): pi wraps to -pi in the ROS forms
    assert normalize_angle(math.pi) == -math.pi and float(shortest_angular_distances(0.0, math.pi)) == -math.pi
    assert angle_diff(math.pi, 0.0) == -math.pi


def test_the_element_wise_angle_differences_take_a_batch():
    from navlog.replay.geometry import angle_diff, shortest_angular_distances

    a = np.array([[0.0, 1.0], [2.0, -2.0]], dtype=np.float32)
    got = shortest_angular_distances(a, 1.5)
    assert got.shape == (2, 2)
    assert got == pytest.approx(np.array([[1.5, 0.5], [-0.5, 3.5 - 2 * math.pi]]), abs=1e-6)
    assert angle_diff(np.array([7.0, -7.0]), 0.0) == pytest.approx([7.0 - 2 * math.pi, 2 * math.pi - 7.0])
