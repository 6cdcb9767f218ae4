"""The top-down view: scans on the wall, the grid image, the footprint where the robot is."""

from __future__ import annotations

import numpy as np
import pytest

from tests.analysis import sample_nav_log as sample
from tests.analysis.view.rrd import column

NS = 1_000_000_000


def test_scan_points_land_on_the_wall_in_the_top_view(data):
    # the wall x = 4 m in the map frame, the canvas starts at the grid origin x = -1 m, 0.05 m per pixel
    u_wall = (sample.WALL_X - sample.GRID_ORIGIN[0]) / sample.GRID_RES
    rows = column(data, "/top/scans/scan", "Points2D:positions")
    assert len(rows) == 20
    for _, pts in rows:
        uv = np.asarray(pts)
        assert len(uv) > 50
        assert np.allclose(uv[:, 0], u_wall, atol=1e-3)
    # and in 3D, in the laser frame: the first scan (robot at x=1.05 map, laser at 1.15) sees the wall 2.85 m ahead
    t0, pts3 = column(data, "/sensors/scan", "Points3D:positions")[0]
    x_laser = sample.WALL_X - (sample.robot_x_map(0.1, 0.5) + sample.LASER_X)
    assert np.allclose(np.asarray(pts3)[:, 0], x_laser, atol=1e-5)


def test_grid_image_marks_the_wall_column(data):
    ((_, buf),) = column(data, "/top/grid", "Image:buffer")
    ((_, fmt),) = column(data, "/top/grid", "Image:format")
    width, height = sample.GRID_SIZE
    img = np.asarray(buf, dtype=np.uint8).reshape(height, width)
    wall_col = int(round((sample.WALL_X - sample.GRID_ORIGIN[0]) / sample.GRID_RES))
    assert (img[:, wall_col] == 0).all()  # occupied: black
    assert (img[:, :wall_col] == 254).all()  # free: white
    assert (img[:, wall_col + 1 :] == 205).all()  # unknown: grey


def test_footprint_follows_the_robot(data):
    rows = column(data, "/top/footprint", "LineStrips2D:strips")
    assert len(rows) == 20
    for t, strips in rows:
        strip = np.asarray(strips[0])
        centre = strip[:-1].mean(axis=0)
        x_map = sample.robot_x_map(t / NS, 0.5)
        assert centre[0] == pytest.approx((x_map - sample.GRID_ORIGIN[0]) / sample.GRID_RES, abs=1e-3)
        assert centre[1] == pytest.approx(
            (sample.GRID_ORIGIN[1] + sample.GRID_SIZE[1] * sample.GRID_RES) / sample.GRID_RES, abs=1e-3
        )
