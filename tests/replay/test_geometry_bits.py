"""``quat_from_rpy`` and ``quat_to_matrix`` give SciPy's results to the bit, without loading SciPy.

Recorded logs hold these numbers (sensor mounts on /tf_static, the MuJoCo model's body poses), and the
mappers, AMCL and SLAM compute with them, so a different last bit would change logs and maps.
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navlog.replay import geometry as g

# angles the configs use (mounts, start yaws, the wheels' quarter turn) and edge values: signed zeros,
# half and whole turns, subnormals, large angles
_EDGE = (0.0, -0.0, math.pi, -math.pi, math.pi / 2, 1.5708, 3.051, -1.571, 0.3, 5e-324, 1e-300, 2 * math.pi, 100.0)


def _angles() -> list[tuple[float, float, float]]:
    rng = np.random.default_rng(13)
    edge = [tuple(float(v) for v in rng.choice(_EDGE, 3)) for _ in range(2000)]
    uniform = [tuple(v) for v in rng.uniform(-7.0, 7.0, (5000, 3)).tolist()]
    yaw_only = [(0.0, 0.0, y) for y in rng.uniform(-4.0, 4.0, 1000).tolist()]
    return edge + uniform + yaw_only


def _bits(values) -> bytes:
    return np.asarray(values, dtype=np.float64).tobytes()


def test_quat_from_rpy_is_scipys_to_the_bit():
    angles = _angles()
    ours = [g.quat_from_rpy(*a) for a in angles]
    theirs = Rotation.from_euler("xyz", np.array(angles)).as_quat()
    assert _bits(ours) == _bits(theirs)
    # known values: a quarter turn about z, half a turn about x (the sign of zero included)
    s = math.sqrt(0.5)
    assert g.quat_from_rpy(0.0, 0.0, math.pi / 2) == pytest.approx((0.0, 0.0, s, s), abs=1e-15)
    assert _bits(g.quat_from_rpy(0.0, 0.0, 0.0)) == _bits((0.0, 0.0, 0.0, 1.0))
    assert all(type(v) is float for v in g.quat_from_rpy(0.1, 0.2, 0.3))


def test_quat_to_matrix_is_scipys_to_the_bit():
    rng = np.random.default_rng(14)
    quats = rng.normal(size=(5000, 4)).tolist()
    quats += [list(g.quat_from_rpy(*a)) for a in _angles()[:3000]]
    quats += [[0.0, 0.0, 0.0, 1.0], [-0.0, 0.0, -0.0, 1.0], [0.0, 0.0, 0.0, 2.0], [3.0, -0.0, 0.0, 0.0], [1e-150] * 4]
    ours = [g.quat_to_matrix(q) for q in quats]
    theirs = Rotation.from_quat(np.array(quats)).as_matrix()
    assert _bits(ours) == _bits(theirs)
    # numpy rows and tuples alike; a half turn about x flips y and z
    np.testing.assert_array_equal(g.quat_to_matrix(np.array([1.0, 0.0, 0.0, 0.0])), np.diag([1.0, -1.0, -1.0]))
    t = g.make_transform((1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 4.0))
    np.testing.assert_array_equal(t, [[1, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]])


def test_a_zero_quaternion_or_one_whose_norm_overflows_is_refused():
    with pytest.raises(ValueError, match="zero norm"):
        g.quat_to_matrix((0.0, 0.0, 0.0, 0.0))
    # (1e200)^2 passes the float range: normalised by an infinite norm it would be the zero matrix
    assert g.quat_norm(0.0, 0.0, 1e200, 1.0) == float("inf") and g.quat_norm(0.0, 0.0, 1e150, 1.0) == 1e150
    with pytest.raises(ValueError, match="no finite norm"):
        g.quat_to_matrix((0.0, 0.0, 1e200, 1.0))


def test_the_recorder_loads_no_scipy():
    """Recording starts faster without SciPy: the simulator, its sensors and the recorder never import it."""
    code = (
        "import sys\n"
        "import navlog.recorder.record, navlog.recorder.sim\n"
        "from navlog.recorder import sensors\n"
        "sensors.mount_matrix((0.2, 0.0, 0.08, 0.1, 0.2, 0.3))\n"
        "print(sorted(m for m in sys.modules if m == 'scipy' or m.startswith('scipy.')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
