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


def test_goal_labels_are_not_shifted_by_the_previous_goals_end():
    # nav_tour: the navigator ends a goal and accepts the next in the same tick, so the second goal's
    # stamp carries the first goal's success before the second's acceptance
    from navlog.analysis.view.goals import goal_labels

    ns = 1_000_000_000
    goals = [(0, "map", (-1.0, -1.0, 0.0), (0, 0, 0, 1)), (15_310_000_000, "map", (1.2, -1.0, 0.0), (0, 0, 0, 1))]
    goals.append((27_080_000_000, "map", (1.2, 0.8, 0.0), (0, 0, 0, 1)))
    events = [
        (0, "goal_accepted [bt_navigator]: inner_southwest", "INFO"),
        (15_310_000_000, "goal_succeeded [bt_navigator]: inner_southwest", "INFO"),
        (15_310_000_000, "goal_accepted [bt_navigator]: inner_southeast", "INFO"),
        (27_080_000_000, "goal_failed [bt_navigator]: inner_southeast", "WARN"),
        (27_080_000_000, "goal_accepted [bt_navigator]: inner_northeast", "INFO"),
        (30 * ns, "goal_succeeded [bt_navigator]: inner_northeast", "INFO"),
    ]
    assert goal_labels(goals, events) == [
        "goal 1: inner_southwest",
        "goal 2: inner_southeast",
        "goal 3: inner_northeast",
    ]
    # an end event alone still labels its goal (a log without acceptance events), once
    ends = [(0, "goal_reached [navigator]: a (0.1)", "INFO"), (0, "goal_reached [navigator]: b (0.1)", "INFO")]
    assert goal_labels(goals[:1] + [(0, "map", (2.0, 0.0, 0.0), (0, 0, 0, 1))], ends) == [
        "goal 1: a (0.1)",
        "goal 2: b (0.1)",
    ]
