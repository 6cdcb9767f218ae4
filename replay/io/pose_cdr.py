"""The CDR bytes of planar pose lists from arrays: ``nav_msgs/msg/Path`` and ``geometry_msgs/msg/PoseArray``.

A planner's path and a particle filter's cloud are (N, 3) arrays of x, y, yaw. Their messages are
written from the arrays (``cdr.UniformSequence``), not from N ``PoseStamped`` or ``Pose`` objects: each
pose at z 0 with the quaternion ``geometry.quat_from_yaw`` gives (``math.sin`` and ``math.cos`` of half
the yaw, as that function computes them), every pose of a path stamped and framed as the path. The bytes
are those ``messages.serialize`` gives for the message built pose by pose.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from navlog.replay import messages
from navlog.replay.io.cdr import UniformSequence

__all__ = ["path", "pose_array"]


@cache
def _sequence(typename: str) -> UniformSequence:
    return UniformSequence(typename)


def _planar(xyyaw: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[float], list[float]]:
    """x, y and the quaternion's z and w of each row of an (N, 3) array."""
    rows = np.asarray(xyyaw)
    half = (rows[:, 2] / 2.0).tolist()
    return rows[:, 0], rows[:, 1], [math.sin(h) for h in half], [math.cos(h) for h in half]


def path(t_ns: int, frame: str, xyyaw: np.ndarray) -> bytes:
    """nav_msgs/Path of the (N, 3) x, y, yaw poses, the path and each pose stamped ``t_ns`` in ``frame``."""
    sec, nanosec = divmod(int(t_ns), 1_000_000_000)
    x, y, qz, qw = _planar(xyyaw)
    columns = (sec, nanosec, x, y, 0.0, 0.0, 0.0, qz, qw)
    return _sequence(messages.PATH).encode((sec, nanosec, frame), len(x), columns, (frame,))


def pose_array(t_ns: int, frame: str, xyyaw: np.ndarray) -> bytes:
    """geometry_msgs/PoseArray of the (N, 3) x, y, yaw poses, stamped ``t_ns`` in ``frame``."""
    sec, nanosec = divmod(int(t_ns), 1_000_000_000)
    x, y, qz, qw = _planar(xyyaw)
    return _sequence(messages.POSE_ARRAY).encode((sec, nanosec, frame), len(x), (x, y, 0.0, 0.0, 0.0, qz, qw))
