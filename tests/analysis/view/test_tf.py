"""The TF tree: transforms, the frames entities are drawn in, frames with no path linked."""

from __future__ import annotations

import numpy as np

from tests.analysis.view.rrd import column


def test_tf_tree_and_frames(data):
    child = column(data, "/tf/base_footprint", "Transform3D:child_frame")
    parent = column(data, "/tf/base_footprint", "Transform3D:parent_frame")
    trans = column(data, "/tf/base_footprint", "Transform3D:translation")
    assert len(trans) == 101 and child[0][1] == ["base_footprint"] and parent[0][1] == ["odom"]
    assert np.allclose(trans[-1][1], [[1.0, 0.0, 0.0]])  # odom x = 0.5 m/s * 2 s
    frames = {
        e: column(data, e, "CoordinateFrame:frame", static=True)[0][1][0]
        for e in ("/sensors/scan", "/sensors/livox/lidar", "/trajectories/odom/path")
    }
    assert frames == {
        "/sensors/scan": "front_laser",
        "/sensors/livox/lidar": "livox_frame",
        "/trajectories/odom/path": "odom",
    }
    # ground truth is in `world`, which has no TF path to map: linked as coincident
    assert "/tf/_unlinked/world" in data
