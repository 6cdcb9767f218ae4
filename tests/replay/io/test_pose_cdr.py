"""Paths and pose clouds written from (N, 3) arrays: the bytes of the messages built pose by pose, and the poses back."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay import messages as m
from navlog.replay.geometry import quat_from_yaw
from navlog.replay.io import pose_cdr
from navlog.replay.io.cdr import UniformSequence

T_NS = 12_345_678_901


def _path_object(frame: str, rows: np.ndarray):
    stamped = m.msg_class(m.POSE_STAMPED)
    poses = [stamped(header=m.header(T_NS, frame), pose=m.pose((x, y, 0.0), quat_from_yaw(yaw))) for x, y, yaw in rows]
    return m.msg_class(m.PATH)(header=m.header(T_NS, frame), poses=poses)


def _cloud_object(frame: str, rows: np.ndarray):
    poses = [m.pose((x, y, 0.0), quat_from_yaw(yaw)) for x, y, yaw in rows.tolist()]
    return m.msg_class(m.POSE_ARRAY)(m.header(T_NS, frame), poses)


# frame names of every length modulo 8: the first pose of a path starts 0 or 4 bytes past an 8-byte boundary
@pytest.mark.parametrize("frame", ["", "a", "ab", "map", "odom", "base_", "global", "gridmap"])
@pytest.mark.parametrize("n", [0, 1, 2, 7])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_paths_and_clouds_are_the_bytes_of_the_messages_built_pose_by_pose(frame, n, dtype):
    rng = np.random.default_rng(n + len(frame))
    rows = (rng.normal(size=(n, 3)) * [5.0, 5.0, 3.0]).astype(dtype)
    assert pose_cdr.path(T_NS, frame, rows) == m.serialize(_path_object(frame, rows), m.PATH)
    assert pose_cdr.pose_array(T_NS, frame, rows) == m.serialize(_cloud_object(frame, rows), m.POSE_ARRAY)


def test_a_path_reads_back_as_its_poses():
    rows = np.array([[1.0, -2.0, math.pi / 2], [3.5, 0.25, -math.pi]])
    msg = m.deserialize(pose_cdr.path(T_NS, "map", rows), m.PATH)
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (12, 345_678_901, "map")
    first, second = msg.poses
    assert (first.header.stamp.sec, first.header.frame_id) == (12, "map")
    assert (first.pose.position.x, first.pose.position.y, first.pose.position.z) == (1.0, -2.0, 0.0)
    q = first.pose.orientation
    assert (q.x, q.y) == (0.0, 0.0) and (q.z, q.w) == pytest.approx((math.sqrt(0.5), math.sqrt(0.5)))
    assert (second.pose.orientation.z, second.pose.orientation.w) == pytest.approx((-1.0, 0.0))
    cloud = m.deserialize(pose_cdr.pose_array(T_NS, "map", rows), m.POSE_ARRAY)
    assert [(p.position.x, p.position.y) for p in cloud.poses] == [(1.0, -2.0), (3.5, 0.25)]


def test_a_uniform_sequence_refuses_what_it_cannot_write():
    with pytest.raises(ValueError, match="not a sequence of messages"):
        UniformSequence(m.TWIST)
    with pytest.raises(ValueError, match="not a sequence of messages"):
        UniformSequence("sensor_msgs/msg/JointState")  # its last field is a sequence of float64
    path = UniformSequence(m.PATH)
    with pytest.raises(ValueError, match="4 columns for 9 numbers"):
        path.encode((0, 0, "map"), 2, (0, 0, 1.0, 2.0), ("map",))
    with pytest.raises(ValueError, match="fewer strings"):
        path.encode((0, 0, "map"), 2, (0,) * 9)
    with pytest.raises(ValueError, match="more strings"):
        path.encode((0, 0, "map"), 2, (0,) * 9, ("map", "odom"))
