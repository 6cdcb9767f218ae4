"""The TF buffer: chains, static and dynamic edges, interpolation, no extrapolation."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from navlog.replay import messages
from navlog.replay.runtime.tf import (
    IDENTITY_POSE,
    TFBuffer,
    TransformError,
    compose_poses,
    invert_pose,
    relative_pose,
)


def buffer() -> TFBuffer:
    tf = TFBuffer()
    tf.add("map", "odom", 0, (1.0, 0.0, 0.0), messages.quat_from_yaw(0.0))
    tf.add("map", "odom", 10, (1.0, 0.0, 0.0), messages.quat_from_yaw(0.0))
    tf.add("odom", "base_link", 0, (0.0, 0.0, 0.0), messages.quat_from_yaw(0.0))
    tf.add("odom", "base_link", 10, (2.0, 0.0, 0.0), messages.quat_from_yaw(math.pi / 2))
    tf.add("base_link", "laser", 0, (0.5, 0.0, 0.2), (0, 0, 0, 1), static=True)
    return tf


def test_interpolates_translation_linearly_and_rotation_by_slerp():
    tf = buffer()
    t = tf.lookup("map", "laser", 5)
    yaw = math.atan2(t[1, 0], t[0, 0])
    assert yaw == pytest.approx(math.pi / 4)
    # base at (1 + 1, 0) turned 45°, laser 0.5 m ahead of it
    assert t[:3, 3] == pytest.approx([2.0 + 0.5 * math.cos(math.pi / 4), 0.5 * math.sin(math.pi / 4), 0.2])


def test_inverse_direction_and_static_edges_at_any_time():
    tf = buffer()
    a = tf.lookup("map", "laser", 10)
    b = tf.lookup("laser", "map", 10)
    assert np.allclose(a @ b, np.eye(4))
    assert np.allclose(tf.lookup("base_link", "laser", 123456), tf.lookup("base_link", "laser", None))


def test_no_extrapolation_and_unconnected_frames():
    tf = buffer()
    with pytest.raises(TransformError, match="no transform odom -> base_link at"):
        tf.lookup("map", "laser", 11)
    tf.add("world", "other", 0, (0, 0, 0), (0, 0, 0, 1), static=True)
    with pytest.raises(TransformError, match="not connected"):
        tf.lookup("map", "other", 5)


def test_tf_messages_and_frame_prefix():
    tf = TFBuffer(frame_prefix="simple_robot/")
    msg = messages.tf_message(
        [messages.transform_stamped(7, "simple_robot/odom", "simple_robot/base_link", (1, 2, 0), (0, 0, 0, 1))]
    )
    tf.add_message(msg)
    assert tf.frames() == ["base_link", "odom"]
    assert tf.lookup("simple_robot/odom", "base_link", 7)[:3, 3] == pytest.approx([1, 2, 0])


def test_a_transform_not_finite_far_off_or_without_a_rotation_is_counted_not_added():
    skipped = Counter()
    tf = TFBuffer(skipped=skipped)
    tf.add("odom", "base_link", 0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 2.0))  # any finite length: normalised
    tf.add("odom", "base_link", 10, (2.0, 0.0, 0.0), messages.quat_from_yaw(math.pi / 2))
    tf.add("odom", "base_link", 4, (math.nan, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    tf.add("odom", "base_link", 5, (0.0, 0.0, 0.0), (-3e166, 0.0, 0.0, 1.0))  # its length squared overflows
    tf.add("odom", "base_link", 6, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0))
    # farther than any frame a robot uses (a rolling costmap's origin overflowed at 1e308 m)
    tf.add("odom", "base_link", 7, (0.0, -1e308, 0.0), (0.0, 0.0, 0.0, 1.0))
    tf.add("odom", "base_link", 8, (1.0000001e8, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    tf.add("map", "odom", 0, (-1e8, 5.6e6, 0.0), (0.0, 0.0, 0.0, 1.0), static=True)  # a UTM northing, the bound: kept
    tf.add("base_link", "laser", 0, (0.5, 0.0, 0.0), (0.0, 0.0, math.inf, 1.0), static=True)
    assert tf.added == 3
    assert skipped == {
        "/tf: transform odom -> base_link not finite, farther than 1e+08 m or with a zero rotation (ignored)": 5,
        "/tf_static: transform base_link -> laser not finite, farther than 1e+08 m or with a zero rotation (ignored)": 1,
    }
    t = tf.lookup("odom", "base_link", 5)  # between the two samples kept
    assert t[:3, 3] == pytest.approx([1.0, 0.0, 0.0])
    assert math.atan2(t[1, 0], t[0, 0]) == pytest.approx(math.pi / 4)
    assert not tf.connected("base_link", "laser")
    assert tf.lookup("map", "base_link", 5)[:3, 3] == pytest.approx([-1e8 + 1.0, 5.6e6, 0.0])
    named = TFBuffer(skipped=skipped, topic="/odom")
    named.add("__pose_origin__", "base_link", 0, (0.0, math.inf, 0.0), (0.0, 0.0, 0.0, 1.0))
    reason = "not finite, farther than 1e+08 m or with a zero rotation (ignored)"
    assert skipped[f"/odom: transform __pose_origin__ -> base_link {reason}"] == 1


def test_kept_paths_and_static_matrices_give_the_same_bits_and_follow_a_changed_tree():
    tf = buffer()
    # map <- laser at 10: (odom at (1, 0)) @ (base at (2, 0) turned 90 deg) @ (laser 0.5 m ahead, 0.2 m up)
    expected = np.array([[0.0, -1.0, 0.0, 3.0], [1.0, 0.0, 0.0, 0.5], [0.0, 0.0, 1.0, 0.2], [0.0, 0.0, 0.0, 1.0]])
    first = tf.lookup("map", "laser", 10)
    assert first == pytest.approx(expected, abs=1e-12)
    assert np.array_equal(tf.lookup("map", "laser", 10), first)  # the kept path: the same bits again
    assert np.array_equal(tf.lookup("laser", "map", 10), np.linalg.inv(first))  # target side: inverted
    # a static edge's matrix is kept, but each caller gets its own copy
    mount = tf.lookup("base_link", "laser", None)
    mount[0, 3] = 99.0
    assert tf.lookup("base_link", "laser", None)[0, 3] == 0.5
    # re-parenting the laser (a new tree) is seen by the next lookup and by latest_common_time
    assert tf.latest_common_time("map", "laser") == 10
    tf.add("map", "laser", 0, (5.0, 0.0, 0.0), (0, 0, 0, 1), static=True)
    assert tf.lookup("map", "laser", 10)[:3, 3] == pytest.approx([5.0, 0.0, 0.0])
    assert tf.latest_common_time("map", "laser") is None  # only a static edge joins them now
    # re-sending a static edge with a new value replaces its kept matrix
    tf.add("map", "laser", 0, (6.0, 0.0, 0.0), (0, 0, 0, 1), static=True)
    assert tf.lookup("map", "laser", None)[0, 3] == 6.0
    assert tf.latest_common_time("map", "nowhere") is None


def test_old_samples_are_dropped_once_the_next_one_is_older_than_the_cache():
    tf = TFBuffer(cache_ns=100)
    for t in range(0, 301, 50):
        tf.add("odom", "base_link", t, (t / 100, 0.0, 0.0), (0, 0, 0, 1))
    assert tf.time_range("base_link") == (150, 300)  # 150 is the last sample at or before 300 - 100
    assert tf.lookup("odom", "base_link", 175)[0, 3] == pytest.approx(1.75)
    with pytest.raises(TransformError, match="buffer holds 0.000..0.000 s"):
        tf.lookup("odom", "base_link", 100)


def test_a_lookup_holds_while_only_newer_samples_arrive():
    """``holds``: newer samples keep a past lookup valid; a sample inside the history, a static transform,
    a re-parented edge or the cache window moving past the lookup's time do not."""
    tf = buffer()
    epoch, before = tf.epoch, tf.lookup("map", "laser", 5).copy()
    added = tf.added
    tf.add("odom", "base_link", 20, (9.0, 9.0, 0.0), messages.quat_from_yaw(1.0))  # newer: 5 still interpolates
    tf.add("map", "odom", 20, (7.0, 0.0, 0.0), messages.quat_from_yaw(0.0))
    assert tf.added == added + 2 and tf.newest == 20
    assert tf.holds(epoch, 5) and np.array_equal(tf.lookup("map", "laser", 5), before)
    tf.add("odom", "base_link", 5, (3.0, 0.0, 0.0), (0, 0, 0, 1))  # inside the history: 5 gives another pose
    assert not tf.holds(epoch, 5) and not np.array_equal(tf.lookup("map", "laser", 5), before)
    for change in (
        lambda: tf.add("base_link", "laser", 0, (0.6, 0.0, 0.2), (0, 0, 0, 1), static=True),
        lambda: tf.add("map", "base_link", 30, (0.0, 0.0, 0.0), (0, 0, 0, 1)),  # re-parented
    ):
        epoch = tf.epoch
        change()
        assert tf.epoch == epoch + 1 and not tf.holds(epoch, 25)
    epoch = tf.epoch
    tf.add("map", "base_link", 30 + tf.cache_ns, (0.0, 0.0, 0.0), (0, 0, 0, 1))
    assert tf.holds(epoch, 30) and not tf.holds(epoch, 29)  # older than the cache window before the newest


def test_a_long_stream_keeps_exactly_the_cache_window_and_late_samples_land_in_it():
    """Dropped samples leave the lists in batches; what a lookup sees is the window all along: the last
    sample at or before newest - cache_ns and those after it."""
    tf = TFBuffer(cache_ns=100)
    sent: list[int] = []
    for t in range(0, 5000, 7):
        tf.add("odom", "base_link", t, (t / 100, 0.0, 0.0), (0, 0, 0, 1))
        sent.append(t)
        first = max(s for s in sent if s <= t - 100) if t >= 100 else 0
        assert tf.time_range("base_link") == (first, t)
    assert len(tf._edges["base_link"].times) < 2 * 16  # (15 samples in the window)
    with pytest.raises(TransformError, match=r"buffer holds 0.000..0.000 s"):
        tf.lookup("odom", "base_link", 4800)
    # late samples: one older than the window is dropped at once; one after the window's first sample
    # (4893), still before the cutoff (4898), becomes that first sample
    tf.add("odom", "base_link", 4850, (99.0, 0.0, 0.0), (0, 0, 0, 1))
    assert tf.time_range("base_link") == (4893, 4998)
    tf.add("odom", "base_link", 4895, (99.0, 0.0, 0.0), (0, 0, 0, 1))
    assert tf.time_range("base_link") == (4895, 4998)
    assert tf.lookup("odom", "base_link", 4896)[0, 3] == pytest.approx(99.0 + (49.0 - 99.0) / 5)


def test_an_edge_matrix_asked_again_at_the_same_time_is_shared_until_the_sample_changes():
    tf = buffer()
    first = tf.lookup("map", "base_link", 10)
    first[0, 3] = -1.0  # the caller's own copy: the next lookup is not affected
    again = tf.lookup("odom", "base_link", 10)  # one edge, kept from the lookup above
    assert again[0, 3] == 2.0 and again.flags.writeable
    assert np.array_equal(tf.lookup("map", "base_link", 10)[:3, 3], [3.0, 0.0, 0.0])
    tf.add("odom", "base_link", 10, (5.0, 0.0, 0.0), messages.quat_from_yaw(math.pi / 2))  # rewritten: new epoch
    assert tf.lookup("odom", "base_link", 10)[0, 3] == 5.0
    assert tf.lookup("odom", "base_link", None)[0, 3] == 5.0  # the latest is the same sample


def _pose_matrix(pose) -> np.ndarray:
    x, y, z, qx, qy, qz, qw = pose
    out = np.eye(4)
    out[:3, :3] = [
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
        [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
        [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
    ]
    out[:3, 3] = (x, y, z)
    return out


def test_compose_and_invert_poses_in_floats():
    # laser 0.5 m ahead of a base at (2, 0) turned 90 degrees: at (2, 0.5), turned 90 degrees
    s = math.sqrt(0.5)
    base = (2.0, 0.0, 0.0, 0.0, 0.0, s, s)
    x, y, z, *q = compose_poses(base, (0.5, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0))
    assert (x, y, z) == pytest.approx((2.0, 0.5, 0.2), abs=1e-15) and q == pytest.approx([0.0, 0.0, s, s])
    back = compose_poses(invert_pose(base), base)
    assert back == pytest.approx(IDENTITY_POSE, abs=1e-15)
    # the laser seen from the base, both given in the map: 0.5 m ahead, not turned
    laser = compose_poses(base, (0.5, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0))
    assert relative_pose(base, laser) == pytest.approx((0.5, 0.0, 0.2, 0.0, 0.0, 0.0, 1.0), abs=1e-15)


def test_lookup_pose_is_the_lookup_to_rounding_and_fails_where_it_fails():
    """Chains up and down, static and dynamic edges, samples hit and interpolated (slerp), the latest:
    the pose in floats is the matrix to 1e-12, and asks that ``lookup`` refuses are refused alike."""
    tf = buffer()
    tf.add("odom", "base_link", 20, (2.5, 0.3, 0.0), messages.quat_from_rpy(0.05, -0.02, 2.0))
    tf.add("map", "odom", 20, (1.2, -0.4, 0.0), messages.quat_from_yaw(0.3))
    tf.add("map", "other", 0, (3.0, 1.0, 0.5), messages.quat_from_rpy(0.1, 0.2, -1.0), static=True)
    pairs = [("map", "laser"), ("laser", "map"), ("odom", "laser"), ("other", "laser"), ("laser", "laser")]
    for target, source in pairs:
        for t in (0, 3, 10, 14, 20, None):
            got = _pose_matrix(tf.lookup_pose(target, source, t))
            assert np.abs(got - tf.lookup(target, source, t)).max() < 1e-12, (target, source, t)
    for target, source, t in [("map", "laser", 21), ("map", "laser", -1)]:
        with pytest.raises(TransformError, match="no transform") as pose_error:
            tf.lookup_pose(target, source, t)
        with pytest.raises(TransformError) as matrix_error:
            tf.lookup(target, source, t)
        assert str(pose_error.value) == str(matrix_error.value)
    tf.add("world", "apart", 0, (0, 0, 0), (0, 0, 0, 1), static=True)
    with pytest.raises(TransformError, match="not connected"):
        tf.lookup_pose("map", "apart", 5)
