"""What the controllers share: Nav2's first_after_integrated_distance."""

from __future__ import annotations

import numpy as np

from navlog.replay.nav2.controllers.base import first_after_integrated_distance


def test_first_after_integrated_distance_on_a_metre_spaced_line() -> None:
    xy = np.stack([np.arange(10.0), np.zeros(10)], axis=1)  # poses at x = 0, 1, ..., 9
    assert first_after_integrated_distance(xy, 3.5) == 4  # 4 m run at index 4
    assert first_after_integrated_distance(xy, 3.0) == 4  # strictly more than 3 m
    assert first_after_integrated_distance(xy, 2.5, start=5) == 8  # counted from index 5
    assert first_after_integrated_distance(xy, 100.0) == 10  # never: the length of the path
    assert first_after_integrated_distance(xy, 1.0, start=10) == 10
    assert first_after_integrated_distance(np.zeros((0, 2)), 1.0) == 0
