"""The log-odds grid and the point-cloud projection, on hand-made input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay.mapping.occupancy import OccupancyGrid2D, OccupancyParams, logit, project_points


def square_room_ranges(n=720, half=2.0):
    ang = -math.pi + 2 * math.pi * np.arange(n) / n
    return ang, half / np.maximum(np.abs(np.cos(ang)), np.abs(np.sin(ang)))


def test_one_scan_marks_walls_and_clears_inside():
    g = OccupancyGrid2D(OccupancyParams())
    ang, r = square_room_ranges()
    g.insert_scan(np.eye(4), ang, r, 0.1, 6.0)
    m = g.to_map()
    assert m.value_at(2.01, 0.0) == 100 and m.value_at(-1.99, 1.0) == 100
    assert m.value_at(1.0, 0.5) == -1  # one miss (p 0.4) is not yet free (< 0.196)
    for _ in range(4):
        g.insert_scan(np.eye(4), ang, r, 0.1, 6.0)
    m = g.to_map()
    assert m.value_at(1.0, 0.5) == 0 and m.value_at(2.01, 0.0) == 100 and m.value_at(2.5, 0.0) == -1
    assert g.logodds.max() == pytest.approx(logit(0.97), abs=1e-5)  # clamped


def test_no_return_clears_to_range_max_and_nan_is_counted():
    g = OccupancyGrid2D(OccupancyParams())
    ang = np.array([0.0, math.pi / 2, math.pi])
    r = np.array([np.inf, np.nan, -np.inf])
    for _ in range(5):
        g.insert_scan(np.eye(4), ang, r, 0.1, 3.0)
    m = g.to_map()
    assert m.value_at(2.9, 0.02) == 0 and m.value_at(3.1, 0.02) == -1
    assert (m.data == 100).sum() == 0
    assert (g.stats.no_return, g.stats.nan, g.stats.too_close) == (5, 5, 5)
    assert m.value_at(-1.0, 0.02) in (None, -1)  # the -inf beam marks nothing (not even grows the map)


def test_project_points_between_heights():
    floor = np.array([[x, y, 0.0] for x in np.arange(0, 2, 0.05) for y in np.arange(0, 2, 0.05)])
    wall = np.array([[1.0, y, z] for y in np.arange(0, 2, 0.02) for z in (0.3, 0.6)])
    lamp = np.array([[0.5, 0.5, 2.5]] * 5)
    m = project_points(np.vstack([floor, wall, lamp]), 0.1, 1.0, 0.05, min_points=2, floor_below=0.1)
    assert m.value_at(1.01, 1.0) == 100
    assert m.value_at(0.5, 0.5) == 0  # the lamp is above z_max: floor seen, free
    assert m.value_at(1.5, 1.5) == 0 and m.value_at(3.0, 3.0) is None
    with pytest.raises(ValueError):
        project_points(np.zeros((0, 3)), 0.1, 1.0)
