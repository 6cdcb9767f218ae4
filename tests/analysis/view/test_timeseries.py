"""Time series: the velocity chain, speed and odometry drift with known values."""

from __future__ import annotations

import math

import pytest

from tests.analysis import sample_nav_log as sample
from tests.analysis.view.rrd import column

NS = 1_000_000_000


def test_velocity_chain_speed_and_drift_series(data):
    nav = column(data, "/plots/cmd_vel/vx/cmd_vel_nav", "Scalars:scalars")
    smoothed = column(data, "/plots/cmd_vel/vx/cmd_vel_smoothed", "Scalars:scalars")
    final = column(data, "/plots/cmd_vel/wz/cmd_vel_smoothed", "Scalars:scalars")
    assert len(nav) == 41 and {v[0] for _, v in nav} == {0.6}
    assert {v[0] for _, v in smoothed} == {0.55}
    assert {v[0] for _, v in final} == {0.05}
    speed = column(data, "/plots/speed/odom", "Scalars:scalars")
    assert len(speed) == 101 and all(math.isclose(v[0], 0.5) for _, v in speed)
    drift = column(data, "/plots/metrics/drift/odom", "Scalars:scalars")
    t_end, d_end = drift[-1]
    assert t_end == 2 * NS
    assert d_end[0] == pytest.approx(sample.DRIFT * 2.0, abs=1e-9)  # 0.01 m/s sideways for 2 s
