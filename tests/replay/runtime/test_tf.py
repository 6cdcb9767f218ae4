"""The TF buffer: chains, static and dynamic edges, interpolation, no extrapolation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay import messages
from navlog.replay.runtime.tf import TFBuffer, TransformError


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
