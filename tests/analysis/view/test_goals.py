"""Goals labelled from the navigation events that follow them; the events as a text log."""

from __future__ import annotations

import numpy as np

from tests.analysis.view.rrd import column


def test_events_and_goal_labels(data):
    texts = column(data, "/events", "TextLog:text")
    assert [v for _, v in texts] == [
        ["goal_accepted [navigator]: corridor_end"],
        ["goal_reached [navigator]: corridor_end (0.12)"],
    ]
    labels = column(data, "/goals/goal_pose", "Arrows3D:labels")
    assert labels[0][1] == ["goal 1: corridor_end"]
    origins = column(data, "/goals/goal_pose", "Arrows3D:origins")
    assert np.allclose(origins[0][1], [[3.0, 0.0, 0.0]])
