"""Rotations, rigid transforms, planar poses and grid cells: the geometry every part of navlog shares.

Conventions:

- quaternions are ``(x, y, z, w)`` (ROS order; MuJoCo's ``(w, x, y, z)`` only through
  ``quat_to_wxyz`` / ``quat_from_wxyz``), Hamilton products, unit norm unless a function says it
  normalises; batched functions take ``(K, 4)`` rows;
- angles in radians; roll, pitch, yaw are extrinsic rotations about x, then y, then z;
- matrices are row-major numpy ``float64`` arrays acting on column vectors: ``p' = R @ p``; a 4x4
  homogeneous transform ``T`` maps points of its child frame into its parent frame;
- a planar pose is ``(x, y, yaw)`` in metres and radians;
- a grid has the world position of its cell (0, 0)'s corner as ``origin`` and square cells of
  ``resolution`` metres; cell ``(i, j)`` covers ``[origin + i * res, origin + (i + 1) * res)``.

Some quantities have two implementations that differ in their floating-point steps (SciPy's
``Rotation`` steps against a closed form, two slerp variants); both are kept where callers' outputs
depend on the exact bits, and each docstring says which steps it takes. ``quat_from_rpy`` and
``quat_to_matrix``, and ``matrix_to_quat``, ``matrices_to_canonical_quats`` and ``matrix_to_rotvec``
for orthonormal matrices, take SciPy's steps in plain Python floats (bit for bit SciPy's results,
without loading SciPy, which costs the recorder's start-up 0.3-1 s and a short replay half a second,
and without its per-call overhead); the rest of SciPy's conversions import it when first called.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "cell_to_world",
    "make_transform",
    "matrices_to_canonical_quats",
    "matrices_to_quats",
    "matrix_to_quat",
    "matrix_to_rotvec",
    "planar_matrix",
    "quat_exp",
    "quat_from_rpy",
    "quat_from_wxyz",
    "quat_from_yaw",
    "quat_mul",
    "quat_to_matrix",
    "quat_to_wxyz",
    "quats_mul",
    "rigid_inverse",
    "rotate_planar",
    "rotation_angle",
    "rotvecs_to_matrices",
    "se2_compose",
    "slerp",
    "slerp_rows",
    "unit_quat_to_matrix",
    "unit_quat_transform",
    "unit_quats_to_matrices",
    "world_to_cell",
    "wrap_angle",
    "yaw_from_matrix",
    "yaw_from_quat",
]

Quat = tuple[float, float, float, float]

# ------------------------------------------------------------------ quaternions from angles


def quat_from_yaw(yaw: float) -> Quat:
    """Quaternion of a rotation by ``yaw`` about z (closed form)."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def _compose(p: Quat, q: Quat) -> Quat:
    """Hamilton product ``p * q`` in SciPy's ``Rotation`` steps (``pw q + qw p + p x q``, ``pw qw - p.q``)."""
    px, py, pz, pw = p
    qx, qy, qz, qw = q
    return (
        pw * qx + qw * px + (py * qz - pz * qy),
        pw * qy + qw * py + (pz * qx - px * qz),
        pw * qz + qw * pz + (px * qy - py * qx),
        pw * qw - (px * qx + py * qy + pz * qz),
    )


def quat_from_rpy(roll: float, pitch: float, yaw: float) -> Quat:
    """Quaternion of extrinsic x-y-z rotations (roll, then pitch, then yaw).

    SciPy's ``Rotation.from_euler("xyz", ...).as_quat()`` to the bit: the three elementary rotations'
    quaternions composed as ``qz * (qy * qx)``, not normalised.
    """
    r, p, y = float(roll) / 2.0, float(pitch) / 2.0, float(yaw) / 2.0
    qx = (math.sin(r), 0.0, 0.0, math.cos(r))
    qy = (0.0, math.sin(p), 0.0, math.cos(p))
    qz = (0.0, 0.0, math.sin(y), math.cos(y))
    return _compose(qz, _compose(qy, qx))


def yaw_from_quat(q_xyzw) -> float:
    """Heading (rotation about z) of a quaternion, in (-pi, pi]."""
    x, y, z, w = q_xyzw
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


# ------------------------------------------------------------ angles
# Every angle wrapping of navlog is here, named for its convention. Each keeps the exact arithmetic of
# the formula it is named after (Nav2's results depend on its rounding), so they are not one formula.


def wrap_angle(a: float) -> float:
    """An angle wrapped into [-pi, pi], as ``atan2(sin a, cos a)``."""
    return math.atan2(math.sin(a), math.cos(a))


def wrap_angles(a: Any) -> Any:
    """``wrap_angle`` element-wise with NumPy (arrays and NumPy scalars): ``arctan2(sin a, cos a)``."""
    return np.arctan2(np.sin(a), np.cos(a))


def normalize_angle(a: float) -> float:
    """``a`` in [-pi, pi), computed as ROS ``angles::normalize_angle`` does (same rounding)."""
    r = math.fmod(a + math.pi, 2.0 * math.pi)
    if r < 0.0:
        r += 2.0 * math.pi
    return r - math.pi


def remainder_angle(a: float) -> float:
    """``a`` wrapped to [-pi, pi] by the IEEE remainder of a full turn (``math.remainder``: the nearest
    multiple of 2 pi taken away, exact)."""
    return math.remainder(a, 2.0 * math.pi)


def shortest_angular_distance(a_from: float, a_to: float) -> float:
    """The signed angle from ``a_from`` to ``a_to`` (ROS ``angles::shortest_angular_distance``):
    ``normalize_angle(a_to - a_from)``."""
    return normalize_angle(a_to - a_from)


def shortest_angular_distances(a_from: Any, a_to: Any) -> Any:
    """``a_to - a_from`` wrapped to [-pi, pi), element-wise, as Nav2's MPPI computes it (its own rounding:
    ``fmod(d + pi, 2 pi)`` shifted by pi)."""
    t = np.fmod(np.asarray(a_to) - np.asarray(a_from) + np.pi, 2.0 * np.pi)
    return np.where(t < 0.0, t + np.pi, t - np.pi)


def angle_diff(a: Any, b: Any) -> Any:
    """``a - b`` wrapped to [-pi, pi) by a floored modulo (Nav2 AMCL's ``angle_diff``, up to the sign of
    exactly pi); element-wise on arrays."""
    return (a - b + math.pi) % (2.0 * math.pi) - math.pi


def yaw_from_matrix(r: np.ndarray) -> float:
    """Heading of a rotation (3x3, or the rotation part of a 4x4): ``atan2(r[1, 0], r[0, 0])``."""
    return math.atan2(r[1, 0], r[0, 0])


def quat_to_wxyz(q_xyzw) -> Quat:
    """The same quaternion in MuJoCo's ``(w, x, y, z)`` order."""
    x, y, z, w = q_xyzw
    return (w, x, y, z)


def quat_from_wxyz(q_wxyz) -> Quat:
    """An ``(x, y, z, w)`` quaternion from MuJoCo's ``(w, x, y, z)`` order."""
    w, x, y, z = q_wxyz
    return (x, y, z, w)


# ------------------------------------------------------------------ quaternion algebra


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of two quaternions."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


def quats_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise Hamilton products of (K, 4) quaternions (the same steps as ``quat_mul``)."""
    ax, ay, az, aw = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    bx, by, bz, bw = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=1,
    )


def quat_exp(rotvec: np.ndarray) -> np.ndarray:
    """Unit quaternion of a rotation vector (axis times angle in radians); first order below 1e-12 rad."""
    angle = float(np.linalg.norm(rotvec))
    if angle < 1e-12:
        return np.array([0.5 * rotvec[0], 0.5 * rotvec[1], 0.5 * rotvec[2], 1.0])
    axis = rotvec / angle
    return np.concatenate([axis * math.sin(angle / 2), [math.cos(angle / 2)]])


def slerp(q0: np.ndarray, q1: np.ndarray, a: float) -> np.ndarray:
    """Spherical interpolation of two unit quaternions at fraction ``a``, the shorter way round.

    When the two are closer than ``dot > 0.9995`` it interpolates linearly and renormalises;
    ``slerp_rows`` is the batched variant with a different near-equal rule.
    """
    dot = float(q0 @ q1)
    if dot < 0.0:
        q1, dot = -q1, -dot
    if dot > 0.9995:  # nearly equal: linear interpolation is exact to rounding
        q = q0 + a * (q1 - q0)
        return q / math.sqrt(float(q @ q))
    theta = math.acos(dot)
    s = math.sin(theta)
    return (math.sin((1.0 - a) * theta) / s) * q0 + (math.sin(a * theta) / s) * q1


def slerp_rows(q0: np.ndarray, q1: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Row-wise shortest-path slerp of unit quaternions (K, 4) at fractions ``a`` (K,).

    Unlike ``slerp`` it uses the slerp weights for all but (numerically) equal rotations
    (``sin(theta) < 1e-9``: linear weights) and always renormalises the result.
    """
    dot = np.sum(q0 * q1, axis=1)
    q1 = np.where(dot[:, None] < 0, -q1, q1)
    dot = np.minimum(np.abs(dot), 1.0)
    theta = np.arccos(dot)
    s = np.sin(theta)
    small = s < 1e-9
    s_safe = np.where(small, 1.0, s)
    w0 = np.where(small, 1.0 - a, np.sin((1.0 - a) * theta) / s_safe)
    w1 = np.where(small, a, np.sin(a * theta) / s_safe)
    q = w0[:, None] * q0 + w1[:, None] * q1
    return q / np.linalg.norm(q, axis=1, keepdims=True)


# ------------------------------------------------------------------ quaternions and matrices


def quat_norm(x: float, y: float, z: float, w: float) -> float:
    """``sqrt(x^2 + y^2 + z^2 + w^2)``: a quaternion names a rotation only where this is positive and finite
    (``0 < n < inf``: not zero, no NaN, no component whose square passes the float range)."""
    return math.sqrt(x * x + y * y + z * z + w * w)


def quat_to_matrix(q_xyzw) -> np.ndarray:
    """3x3 rotation matrix of a quaternion of any positive, finite norm (``quat_norm``), normalised first.

    SciPy's ``Rotation.from_quat(q).as_matrix()`` to the bit: divided by ``sqrt(x^2 + y^2 + z^2 + w^2)``,
    then the diagonal as ``x^2 - y^2 - z^2 + w^2`` (and its permutations), the rest as ``2 (xy - zw)`` etc.
    """
    x, y, z, w = np.asarray(q_xyzw, dtype=np.float64).reshape(4).tolist()
    n = quat_norm(x, y, z, w)
    if n == 0.0:
        raise ValueError(f"quaternion {tuple(q_xyzw)} has zero norm: it is no rotation")
    if not n < math.inf:
        raise ValueError(f"quaternion {tuple(q_xyzw)} has no finite norm: it is no rotation")
    x, y, z, w = x / n, y / n, z / n, w / n
    x2, y2, z2, w2 = x * x, y * y, z * z, w * w
    xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
    return np.array(
        [
            [x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)],
            [2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)],
            [2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2],
        ]
    )


def unit_quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """3x3 rotation matrix of a unit quaternion, closed form (no normalisation; not SciPy's steps)."""
    x, y, z, w = (float(v) for v in q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def unit_quats_to_matrices(q: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotation matrices of unit quaternions (K, 4), the same steps as ``unit_quat_to_matrix``."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    out = np.empty((len(q), 3, 3))
    out[:, 0, 0] = 1 - 2 * (y * y + z * z)
    out[:, 0, 1] = 2 * (x * y - z * w)
    out[:, 0, 2] = 2 * (x * z + y * w)
    out[:, 1, 0] = 2 * (x * y + z * w)
    out[:, 1, 1] = 1 - 2 * (x * x + z * z)
    out[:, 1, 2] = 2 * (y * z - x * w)
    out[:, 2, 0] = 2 * (x * z - y * w)
    out[:, 2, 1] = 2 * (y * z + x * w)
    out[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def _scipy_quat(r: np.ndarray) -> Quat | None:
    """The quaternion SciPy's ``Rotation.from_matrix(r)`` holds (sign as it leaves it), to the bit, in
    plain Python floats: the largest of the diagonal and the trace picks the formula (Markley's
    method), then divided by ``sqrt(x^2 + y^2 + z^2 + w^2)``. None unless ``r`` is orthonormal to
    1e-13 and right-handed: SciPy first projects other matrices onto a rotation (an SVD), so they go
    through SciPy."""
    rows = np.asarray(r, dtype=np.float64).reshape(3, 3).tolist()
    for p in range(3):
        for q in range(p, 3):
            dot = rows[p][0] * rows[q][0] + rows[p][1] * rows[q][1] + rows[p][2] * rows[q][2]
            if not abs(dot - (1.0 if p == q else 0.0)) <= 1e-13:  # (NaN fails too)
                return None
    (a, b, c), (d, e, f), (g, h, i) = rows
    if not a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g) > 0:
        return None
    trace = a + e + i
    decision = (a, e, i, trace)
    choice = max(range(4), key=decision.__getitem__)  # the first largest, as numpy's argmax
    if choice == 3:
        x, y, z, w = h - f, c - g, d - b, 1 + trace
    else:
        j, k = (choice + 1) % 3, (choice + 2) % 3
        out = [0.0, 0.0, 0.0, 0.0]
        out[choice] = 1 - trace + 2 * rows[choice][choice]
        out[j] = rows[j][choice] + rows[choice][j]
        out[k] = rows[k][choice] + rows[choice][k]
        out[3] = rows[k][j] - rows[j][k]
        x, y, z, w = out
    n = math.sqrt(x * x + y * y + z * z + w * w)
    return x / n, y / n, z / n, w / n


def _canonical(q: Quat) -> Quat:
    """``q`` or ``-q``, whichever has its first non-zero of w, x, y, z positive (SciPy's canonical sign)."""
    x, y, z, w = q
    if w < 0 or (w == 0 and (x < 0 or (x == 0 and (y < 0 or (y == 0 and z < 0))))):
        return -x, -y, -z, -w
    return q


def matrix_to_quat(r: np.ndarray) -> Quat:
    """Quaternion (w >= 0) of a 3x3 rotation matrix: SciPy's ``Rotation.from_matrix(r).as_quat(canonical=True)``
    to the bit (``_scipy_quat``; SciPy itself for a matrix that is not orthonormal)."""
    q = _scipy_quat(r)
    if q is None:
        from scipy.spatial.transform import Rotation

        return tuple(Rotation.from_matrix(np.asarray(r, dtype=np.float64)).as_quat(canonical=True))  # type: ignore[return-value]
    return _canonical(q)


def matrices_to_canonical_quats(r: np.ndarray) -> np.ndarray:
    """(K, 4) quaternions (w >= 0) of rotation matrices (K, 3, 3), ``matrix_to_quat`` of each: SciPy's
    ``Rotation.from_matrix(r).as_quat(canonical=True)`` to the bit (SciPy itself when a matrix is not
    orthonormal)."""
    m = np.asarray(r, dtype=np.float64).reshape(-1, 3, 3)
    quats = [_scipy_quat(one) for one in m]
    if any(q is None for q in quats):
        from scipy.spatial.transform import Rotation

        return Rotation.from_matrix(m).as_quat(canonical=True)
    return np.array([_canonical(q) for q in quats if q is not None], dtype=np.float64).reshape(-1, 4)


def matrices_to_quats(r: np.ndarray) -> np.ndarray:
    """(K, 4) unit quaternions of rotation matrices (K, 3, 3) by Shepperd's method (sign not canonical)."""
    m = np.asarray(r, dtype=np.float64).reshape(-1, 3, 3)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    d = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2], tr], axis=1)
    choice = np.argmax(d, axis=1)
    q = np.empty((len(m), 4))
    for c in range(4):
        sel = choice == c
        if not sel.any():
            continue
        s = m[sel]
        if c == 3:
            w = np.sqrt(1.0 + tr[sel]) * 2
            q[sel] = np.stack(
                [(s[:, 2, 1] - s[:, 1, 2]) / w, (s[:, 0, 2] - s[:, 2, 0]) / w, (s[:, 1, 0] - s[:, 0, 1]) / w, 0.25 * w],
                axis=1,
            )
        else:
            i, j, k = c, (c + 1) % 3, (c + 2) % 3
            f = np.sqrt(1.0 + s[:, i, i] - s[:, j, j] - s[:, k, k]) * 2
            out = np.empty((len(s), 4))
            out[:, i] = 0.25 * f
            out[:, j] = (s[:, j, i] + s[:, i, j]) / f
            out[:, k] = (s[:, k, i] + s[:, i, k]) / f
            out[:, 3] = (s[:, k, j] - s[:, j, k]) / f
            q[sel] = out
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def rotvecs_to_matrices(v: np.ndarray) -> np.ndarray:
    """(K, 3, 3) rotation matrices of rotation vectors (K, 3), through their unit quaternions."""
    angle = np.linalg.norm(v, axis=1)
    half = 0.5 * angle
    small = angle < 1e-12
    scale = np.where(small, 0.5, np.sin(half) / np.where(small, 1.0, angle))
    q = np.concatenate([v * scale[:, None], np.cos(half)[:, None]], axis=1)
    return unit_quats_to_matrices(q)


def matrix_to_rotvec(r: np.ndarray) -> np.ndarray:
    """Rotation vector (axis times angle, radians) of a 3x3 rotation matrix: SciPy's
    ``Rotation.from_matrix(r).as_rotvec()`` to the bit (``_scipy_quat`` with w made >= 0, angle
    ``2 atan2(|xyz|, w)``, scaled by ``angle / sin(angle / 2)`` or, at most 1e-3 rad, its series;
    SciPy itself for a matrix that is not orthonormal)."""
    q = _scipy_quat(r)
    if q is None:
        from scipy.spatial.transform import Rotation

        return Rotation.from_matrix(r).as_rotvec()
    x, y, z, w = (-v for v in q) if q[3] < 0 else q
    angle = 2 * math.atan2(math.sqrt(x * x + y * y + z * z), w)
    if angle <= 1e-3:
        angle2 = angle * angle
        scale = 2 + angle2 / 12 + 7 * angle2 * angle2 / 2880
    else:
        scale = angle / math.sin(angle / 2)
    return np.array([scale * x, scale * y, scale * z])


def rotation_angle(r: np.ndarray) -> float:
    """Angle (radians, in [0, pi]) of a 3x3 rotation matrix, from its trace."""
    return math.acos(max(-1.0, min(1.0, (float(np.trace(r)) - 1.0) / 2.0)))


# ------------------------------------------------------------------ homogeneous transforms


def make_transform(xyz, q_xyzw) -> np.ndarray:
    """4x4 homogeneous matrix from a translation and a quaternion (``quat_to_matrix``: SciPy's steps, normalising)."""
    t = np.eye(4)
    t[:3, :3] = quat_to_matrix(q_xyzw)
    t[:3, 3] = np.asarray(xyz, dtype=np.float64)
    return t


def rigid_inverse(t: np.ndarray) -> np.ndarray:
    """The inverse of a 4x4 rigid transform: rotation transposed, translation ``-R^T p`` (a few times
    cheaper than a general inverse, equal to it to rounding)."""
    out = np.empty((4, 4))
    rt = t[:3, :3].T
    out[:3, :3] = rt
    out[:3, 3] = -(rt @ t[:3, 3])
    out[3] = (0.0, 0.0, 0.0, 1.0)
    return out


def unit_quat_transform(xyz, q) -> np.ndarray:
    """4x4 homogeneous matrix from a translation and a unit quaternion (``unit_quat_to_matrix``: closed form,
    the same values)."""
    x, y, z, w = map(float, q)
    tx, ty, tz = map(float, xyz)
    # fmt: off
    out = np.array((  # one flat row-major sequence: cheaper to build than nested rows
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), tx,
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), ty,
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), tz,
        0.0, 0.0, 0.0, 1.0,
    ))
    # fmt: on
    out.shape = (4, 4)
    return out


# ------------------------------------------------------------------ planar poses


def planar_matrix(x: float, y: float, yaw: float) -> np.ndarray:
    """4x4 homogeneous matrix of the planar pose ``(x, y, yaw)``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c, -s, 0.0, x, s, c, 0.0, y, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]).reshape(4, 4)


def rotate_planar(vx: float, vy: float, yaw: float) -> tuple[float, float]:
    """The planar vector ``(vx, vy)`` rotated by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return (c * vx - s * vy, s * vx + c * vy)


def se2_compose(a, b) -> tuple[float, float, float]:
    """Planar pose ``a ⊕ b``: the pose ``b``, given in the frame of ``a``, in ``a``'s parent frame.

    Computes ``(xa + c*xb - s*yb, ya + s*xb + c*yb, yaw_a + yaw_b)`` with ``c, s`` of ``yaw_a``, in that
    order of operations; the yaw is not wrapped.
    """
    xa, ya, ta = a
    xb, yb, tb = b
    c, s = math.cos(ta), math.sin(ta)
    return (xa + c * xb - s * yb, ya + s * xb + c * yb, ta + tb)


# ------------------------------------------------------------------ grids


def world_to_cell(xy: np.ndarray, origin, resolution: float) -> np.ndarray:
    """int64 indices of the cells holding world coordinates: ``floor((xy - origin) / resolution)``.

    ``xy`` is (N, 2) points with ``origin`` (x, y), or coordinates along one axis with a scalar ``origin``.
    """
    return np.floor((np.asarray(xy, dtype=np.float64) - np.asarray(origin, dtype=np.float64)) / resolution).astype(
        np.int64
    )


def cell_to_world(ij: np.ndarray, origin, resolution: float) -> np.ndarray:
    """World coordinates of cell centres: ``origin + (ij + 0.5) * resolution`` (shapes as in ``world_to_cell``)."""
    return np.asarray(origin, dtype=np.float64) + (np.asarray(ij, dtype=np.float64) + 0.5) * resolution
