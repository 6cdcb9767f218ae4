"""navlog export --to tum: TUM files hold the known poses of a topic, a Path or a TF chain."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.cli import main
from navlog.replay import messages as m
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.io.tum import read_tum
from tests.analysis import sample_nav_log as sample

NS = 1_000_000_000


def test_tum_from_odometry_and_from_the_tf_chain(sample_log, tmp_path):
    gt = tmp_path / "gt.tum"
    assert main(["-q", "export", str(sample_log), "--to", "tum", "--topic", "/odom/ground_truth", "-o", str(gt)]) == 0
    traj = read_tum(gt)
    assert len(traj.times_ns) == 101
    assert np.array_equal(traj.times_ns, np.arange(101) * 20_000_000)
    assert np.allclose(traj.positions[:, 0], 0.5 * traj.times_ns / NS, atol=1e-9)
    assert np.allclose(traj.positions[:, 2], 0.2)
    # the pose of base_link in map through map -> odom -> base_footprint -> base_link
    chain = tmp_path / "chain.tum"
    assert main(["-q", "export", str(sample_log), "--to", "tum", "--tf", "map:base_link", "-o", str(chain)]) == 0
    traj = read_tum(chain)
    assert len(traj.times_ns) == 101
    assert np.allclose(
        traj.positions,
        np.c_[sample.MAP_TO_ODOM_X + 0.5 * traj.times_ns / NS, np.zeros(101), np.full(101, 0.2)],
        atol=1e-9,
    )
    assert np.allclose(traj.quaternions, [0, 0, 0, 1])
    # every line is the 8 numbers evo reads
    lines = [ln for ln in chain.read_text().splitlines() if not ln.startswith("#")]
    assert all(len(ln.split()) == 8 for ln in lines)


def test_tum_from_a_path_and_time_window(tmp_path):
    log = tmp_path / "path.mcap"
    poses = [sample.pose_stamped(k * NS, "map", (k * 0.5, k * 0.25, 0.0), m.quat_from_yaw(0.1 * k)) for k in range(6)]
    path_msg = m.msg_class(m.PATH)(header=m.header(5 * NS, "map"), poses=poses)
    with McapLogWriter(log) as w:
        w.write_raw("/trajectory", m.PATH, 5 * NS, m.serialize(path_msg, m.PATH))
        w.write_raw("/goal", m.POSE_STAMPED, 6 * NS, m.serialize(poses[2], m.POSE_STAMPED))
    out = tmp_path / "path.tum"
    assert main(["-q", "export", str(log), "--to", "tum", "--topic", "/trajectory", "-o", str(out)]) == 0
    traj = read_tum(out)
    assert np.array_equal(traj.times_ns, np.arange(6) * NS)
    assert np.allclose(traj.positions[:, :2], np.c_[np.arange(6) * 0.5, np.arange(6) * 0.25])
    assert np.allclose([m.yaw_from_quat(q) for q in traj.quaternions], 0.1 * np.arange(6))


@pytest.mark.parametrize(
    "args, message",
    [
        (["--to", "tum", "--topic", "/scan"], "has no pose"),
        (["--to", "tum", "--topic", "/odm"], "did you mean '/odom'"),
        (["--to", "tum", "--tf", "map:base_lnk"], "did you mean 'base_link'"),
        (["--to", "tum", "--tf", "map"], "expected TARGET:SOURCE"),
        (["--to", "tum"], "exactly one of --topic"),
    ],
)
def test_bad_pose_sources_are_clear_errors_and_write_nothing(args, message, refused):
    refused(args, message)
