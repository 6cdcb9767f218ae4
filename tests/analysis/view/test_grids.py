"""Occupancy grids: fast costmaps thinned to one per period; /map stays the top-down grid."""

from __future__ import annotations

import pytest

from tests.analysis import sample_nav_log as sample
from tests.analysis.view.rrd import column, read_rrd

NS = 1_000_000_000


def test_fast_grids_are_thinned_to_one_per_period(tmp_path):
    from navlog.analysis.view import ViewOptions, save_view

    log = sample.write_sample_log(tmp_path / "c.mcap", costmap_hz=5.0, with_events=False)
    summary = save_view(log, tmp_path / "c.rrd", options=ViewOptions(grid_period_s=1.0))
    data = read_rrd(tmp_path / "c.rrd")
    times = [t for t, _ in column(data, "/grids/global_costmap/costmap", "GridMap:data")]
    assert times == [0, NS, 2 * NS]  # 11 costmaps at 5 Hz over 0..2 s
    assert summary.skipped == {"grid thinned to one per 1 s on /global_costmap/costmap": 8}
    # /map stays the top-down grid; the costmap is drawn in 3D only
    assert summary.grid_source == "/map"


def test_costmaps_are_drawn_above_the_map(tmp_path):
    from navlog.analysis.view import save_view

    log = sample.write_sample_log(tmp_path / "c.mcap", costmap_hz=1.0, with_events=False)
    save_view(log, tmp_path / "c.rrd")
    data = read_rrd(tmp_path / "c.rrd")
    ((_, xyz),) = column(data, "/grids/map", "GridMap:translation")
    lifted = column(data, "/grids/global_costmap/costmap", "GridMap:translation")[0][1]
    assert lifted[0][2] - xyz[0][2] == pytest.approx(0.01)
    assert lifted[0][:2] == pytest.approx(xyz[0][:2])  # same known cells: the same crop


def test_plans_are_drawn_above_the_costmaps(data):
    # the sample's /plan lies on the floor (z = 0); the local costmap is drawn 0.02 m above the map
    from navlog.analysis.view.grids import COSTMAP_LIFT_M

    (_, strips), *_ = column(data, "/plans/plan", "LineStrips3D:strips")
    z = {round(p[2], 6) for strip in strips for p in strip}
    assert z == {0.05} and max(COSTMAP_LIFT_M.values()) < 0.05
    assert [round(p[0], 6) for p in strips[0]][:2] == pytest.approx([sample.MAP_TO_ODOM_X, sample.MAP_TO_ODOM_X + 0.25])
