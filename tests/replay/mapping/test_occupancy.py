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


def test_no_return_clears_along_its_own_length_when_asked_and_nan_is_counted():
    g = OccupancyGrid2D(OccupancyParams(no_return_ray_length=3.0))
    ang = np.array([0.0, math.pi / 2, math.pi])
    r = np.array([np.inf, np.nan, -np.inf])
    for _ in range(5):
        g.insert_scan(np.eye(4), ang, r, 0.1, 3.0)
    m = g.to_map()
    assert m.value_at(2.9, 0.02) == 0 and m.value_at(3.1, 0.02) == -1
    assert (m.data == 100).sum() == 0
    assert (g.stats.no_return, g.stats.nan, g.stats.too_close) == (5, 5, 5)
    assert m.value_at(-1.0, 0.02) in (None, -1)  # the -inf beam marks nothing (not even grows the map)


def free_cells_outside(m, half=2.05):
    """Free cells whose centre lies beyond the square room's walls (|x| or |y| > ``half``)."""
    xs, ys = m.cell_to_world(*np.meshgrid(np.arange(m.width), np.arange(m.height)))
    return int(((m.data == 0) & ((np.abs(xs) > half) | (np.abs(ys) > half))).sum())


def mapped(params: OccupancyParams, ang, r, times: int = 5) -> OccupancyGrid2D:
    """A grid after ``times`` scans (range_min 0.1, range_max 6 m) from the origin."""
    g = OccupancyGrid2D(params)
    for _ in range(times):
        g.insert_scan(np.eye(4), ang, r, 0.1, 6.0)
    return g


def room_scan_with_dropouts(n=720, half=2.0, every=4):
    """The square room's scan with every ``every``-th beam lost (inf), as glass or a dark wall returns."""
    ang, r = square_room_ranges(n, half)
    r = r.copy()
    r[::every] = np.inf
    return ang, r


def test_inf_beams_in_a_known_room_leave_no_free_cell_beyond_a_wall():
    # walls at |x| = 2 or |y| = 2 m, range_max 6 m, a quarter of the beams inf
    ang, r = room_scan_with_dropouts()
    g = mapped(OccupancyParams(), ang, r)
    m = g.to_map()
    assert free_cells_outside(m) == 0
    assert (m.data == 0).sum() > 4000  # the room (4 m x 4 m = 6400 cells) is still cleared by the returns
    assert m.value_at(2.01, 0.3) == 100 and m.value_at(1.0, 0.5) == 0
    assert (g.stats.no_return, g.stats.hits) == (5 * 180, 5 * 540)
    # the old rule (clear every no-return beam to range_max) leaks through the walls
    assert free_cells_outside(mapped(OccupancyParams(no_return_ray_length=6.0), ang, r).to_map()) > 1000


def test_no_return_ray_length_clears_only_its_own_length():
    ang, r = room_scan_with_dropouts()
    g = mapped(OccupancyParams(no_return_ray_length=1.0), ang, r)
    m = g.to_map()
    assert free_cells_outside(m) == 0 and g.stats.no_return == 5 * 180
    assert free_cells_outside(m, half=1.0) > 0  # the no-return rays did clear (up to 1 m)


def test_readings_at_range_max_or_range_min_mark_and_clear_nothing():
    g = OccupancyGrid2D(OccupancyParams())
    ang = np.array([0.0, math.pi / 2, math.pi])
    g.insert_scan(np.eye(4), ang, np.array([3.0, 0.1, 2.5]), 0.1, 3.0)  # = range_max, = range_min, valid
    assert (g.stats.no_return, g.stats.too_close, g.stats.hits) == (1, 1, 1)
    m = g.to_map()
    assert m.value_at(-2.49, 0.02) == 100  # the valid beam
    assert m.value_at(1.5, 0.02) in (None, -1) and m.value_at(0.02, 1.5) in (None, -1)


def test_max_laser_range_clips_long_readings_as_slam_toolbox_does():
    # a 2 m half-width room, readings clipped at 1.5 m: free up to 1.5 m, no wall marked
    g = mapped(OccupancyParams(max_laser_range=1.5), *square_room_ranges())
    m = g.to_map()
    assert (m.data == 100).sum() == 0 and g.stats.clipped == 5 * 720
    assert m.value_at(1.4, 0.0) == 0 and m.value_at(1.6, 0.0) in (None, -1)
    with pytest.raises(ValueError, match="max_laser_range"):
        OccupancyParams(max_laser_range=-1.0)
    with pytest.raises(ValueError, match="no_return_ray_length"):
        OccupancyParams(no_return_ray_length=math.inf)


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
