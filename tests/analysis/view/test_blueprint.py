"""The default layout read as data: the camera on the robot, every plot shown with units and ranges,
the top-down view on the known cells; and what the view thins, crops and holds so that it reads."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from navlog.analysis.view.blueprint import (
    CAMERA_BACK_M,
    CAMERA_UP_M,
    PLOTS,
    TITLE_CHARS,
    make_blueprint,
    plan_views,
    y_range,
)
from navlog.analysis.view.grids import crop_known
from navlog.cli import main
from tests.analysis import sample_nav_log as sample
from tests.analysis.view.rrd import column, read_rrd

NS = 1_000_000_000
MS = 1_000_000


@pytest.fixture(scope="module")
def summary(sample_log, tmp_path_factory):
    from navlog.analysis.view import save_view

    return save_view(sample_log, tmp_path_factory.mktemp("bp") / "s.rrd")


def test_camera_starts_behind_the_robot_looking_at_it(summary):
    from navlog.analysis.view import ViewOptions

    x0 = sample.robot_x_map(0.1, 0.5)  # the robot at the first scan, in map (heading +x)
    assert summary.robot_start == pytest.approx((x0, 0.0, 0.0, 0.0), abs=1e-9)
    plan = plan_views(summary)
    assert plan.camera_target == pytest.approx((x0, 0.0, 0.0))
    assert plan.camera_position == pytest.approx((x0 - CAMERA_BACK_M, 0.0, CAMERA_UP_M))
    assert math.dist(plan.camera_target, plan.camera_position) == pytest.approx(math.hypot(3.5, 3.0))
    assert plan.follow == ""
    assert plan_views(summary, ViewOptions(follow=True)).follow == "/robot"


def test_every_plot_is_shown_with_its_unit_and_range(summary):
    plan = plan_views(summary)
    titles = {p.title: p for p in plan.plots}
    assert list(titles) == ["forward (m/s)", "turn (rad/s)", "odom drift (m)", "accel x (m/s²)"]
    fwd = titles["forward (m/s)"]
    assert set(fwd.entities) == {
        "/plots/cmd_vel/vx/cmd_vel_nav",
        "/plots/cmd_vel/vx/cmd_vel_smoothed",
        "/plots/cmd_vel/vx/cmd_vel",
        "/plots/speed/odom",
        "/plots/speed/odom/ground_truth",
    }
    assert fwd.y_range == pytest.approx((0.0, 0.66))  # /cmd_vel_nav 0.6 m/s is the largest, plus 10 %
    drift = titles["odom drift (m)"]
    assert drift.y_range == pytest.approx((0.0, 0.07))  # 0.02 m of drift: the 0.05 m least margin
    # every series drawn is in a plot: nothing hidden
    plotted = {e for p in plan.plots for e in p.entities}
    assert plotted == set(summary.plot_ranges)
    assert plan.text_logs == [("events", "/events")]


def test_plot_titles_fit_their_tab():
    # four plots in a 1600 px window show about 18 characters of a title beside the view's buttons
    # (the titles of 32 characters and more were cut to "forward (m/s): comn")
    assert max(len(title) for title, _ in PLOTS) <= TITLE_CHARS == 16


def test_y_range_includes_zero_and_a_margin():
    assert y_range(-0.2, 0.5) == pytest.approx((-0.27, 0.57))
    assert y_range(0.0, 0.0) == pytest.approx((0.0, 0.05))
    assert y_range(2.0, 3.0) == pytest.approx((0.0, 3.3))


def test_top_down_opens_on_the_known_cells(summary):
    # the corridor grid: x -1..6 m, known up to the wall column x = 4 m; + 0.5 m, at 0.05 m a pixel
    wall_col = round((sample.WALL_X - sample.GRID_ORIGIN[0]) / sample.GRID_RES)
    u0, u1, v0, v1 = summary.top_bounds
    assert (u0, v0, v1) == pytest.approx((0.0, 0.0, sample.GRID_SIZE[1]))
    assert u1 == pytest.approx(wall_col + 1 + 0.5 / sample.GRID_RES)


def test_blueprint_builds_with_panels_collapsed(summary):
    import rerun.blueprint as rrb

    bp = make_blueprint(summary)
    assert bp.blueprint_panel.state == "collapsed" and bp.selection_panel.state == "collapsed"
    assert bp.time_panel.timeline == "sim_time"
    root = bp.root_container
    assert isinstance(root, rrb.Vertical)
    (top, bottom) = root.contents
    assert [type(v).__name__ for v in top.contents] == ["Spatial3DView", "Spatial2DView"]
    assert [type(v).__name__ for v in bottom.contents] == ["Grid", "TextLogView"]  # plots | events, no tabs
    assert len(bottom.contents[0].contents) == 4


def test_grid_is_cropped_to_its_known_cells():
    cells = np.full((100, 200), -1, np.int8)
    cells[40:50, 120:130] = 0  # 10 x 10 known cells
    q90 = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
    sub, origin = crop_known(cells, 0.1, (1.0, 2.0, 0.0), (0, 0, 0, 1), 0.5)
    assert sub.shape == (20, 20) and origin == pytest.approx((1.0 + 11.5, 2.0 + 3.5, 0.0))
    # a grid turned 90 degrees: the cell offset (x 11.5 m, y 3.5 m along the grid) turns with it
    _, origin = crop_known(cells, 0.1, (1.0, 2.0, 0.0), q90, 0.5)
    assert origin == pytest.approx((1.0 - 3.5, 2.0 + 11.5, 0.0))
    whole, origin = crop_known(np.full((5, 5), -1, np.int8), 0.1, (1.0, 2.0, 0.0), (0, 0, 0, 1), 0.5)
    assert whole.shape == (5, 5) and origin == (1.0, 2.0, 0.0)


def test_lidar_clouds_are_thinned_to_two_a_second(data, summary):
    times = [t for t, _ in column(data, "/sensors/livox/lidar", "Points3D:positions")]
    assert times == [100 * MS, 600 * MS, 1100 * MS, 1600 * MS]  # 20 clouds at 10 Hz over 0.1..2 s
    assert summary.thinned == {"/livox/lidar: one cloud per 0.5 s": 16}


def test_robot_is_drawn_in_its_base_frame(data):
    ((_, frame),) = column(data, "/robot", "CoordinateFrame:frame", static=True)
    assert frame == ["base_footprint"]
    ((_, strips),) = column(data, "/robot", "LineStrips3D:strips", static=True)
    outline = np.asarray(strips[0])
    assert np.allclose(outline[0], outline[-1]) and len(strips) == 2  # closed outline + heading


def test_a_late_transform_is_held_from_the_log_start(tmp_path):
    from navlog.replay import messages as m
    from navlog.replay.io.logwriter import McapLogWriter

    log = tmp_path / "late_tf.mcap"
    with McapLogWriter(log) as w:
        for k in range(11):
            t = k * 100 * MS
            odo = m.odometry(t, "odom", "base_link", (0.1 * k, 0, 0), (0, 0, 0, 1), (1.0, 0, 0), (0, 0, 0))
            w.write_raw("/odom", m.ODOMETRY, t, m.serialize(odo, m.ODOMETRY))
            if t >= 500 * MS:  # map -> odom arrives half a second late
                tf = m.tf_message([m.transform_stamped(t, "map", "odom", (2.0, 0, 0), (0, 0, 0, 1))])
                w.write_raw("/tf", m.TF_MESSAGE, t, m.serialize(tf, m.TF_MESSAGE))
    rrd = tmp_path / "late_tf.rrd"
    assert main(["-q", "view", str(log), "--save", str(rrd)]) == 0
    rows = column(read_rrd(rrd), "/tf/odom", "Transform3D:translation")
    assert [t for t, _ in rows] == [0] + [k * 100 * MS for k in range(5, 11)]
    assert np.allclose(rows[0][1], [[2.0, 0.0, 0.0]])


def test_cli_options_reach_the_view(sample_log, monkeypatch):
    import navlog.analysis.view as view

    seen = {}

    def fake_stream_view(log_path, **kw):
        seen.update(kw)
        return view.ViewSummary(fixed_frame="map")

    monkeypatch.setattr(view, "stream_view", fake_stream_view)
    assert main(["-q", "view", str(sample_log), "--spawn", "--paused", "--follow", "--cloud-period", "0"]) == 0
    opt = seen["options"]
    assert (opt.play_state, opt.follow, opt.cloud_period_s, seen["spawn"]) == ("paused", True, 0.0, True)


@pytest.mark.parametrize(
    ("option", "value"), [("cloud_period_s", math.inf), ("cloud_period_s", math.nan), ("grid_period_s", 1e308)]
)
def test_a_thinning_period_not_finite_is_refused_with_its_name(option, value):
    # (an infinite cloud period overflowed the nanoseconds; a NaN one was taken as no thinning)
    from navlog.analysis.view import ViewOptions
    from navlog.errors import NavlogError

    with pytest.raises(NavlogError, match=re.escape(f"{option}: must be from 0 to 1e+06, got {value}")):
        ViewOptions(**{option: value}).validate()
    ViewOptions(cloud_period_s=1e6, grid_period_s=0.0).validate()
