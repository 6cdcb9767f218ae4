"""The safety filters in the view: collision-monitor polygons coloured by their action, the approach
prediction, the three velocity streams and the monitor's events, read back from the .rrd of a log
recorded through the KiBot smoother and collision monitor (``safety_log``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.analysis.view.polygons import STATE_COLORS, event_state, polygon_name
from navlog.cli import main
from tests.analysis.view.rrd import column, read_rrd, verify
from tests.analysis.view.safety_log import write_safety_log

NS = 1_000_000_000
MS = 1_000_000


def rgba(c: tuple[int, int, int, int]) -> int:
    """A colour as Rerun stores it (0xRRGGBBAA)."""
    return (c[0] << 24) | (c[1] << 16) | (c[2] << 8) | c[3]


GREY, RED, ORANGE = rgba(STATE_COLORS["idle"]), rgba(STATE_COLORS["stop"]), rgba(STATE_COLORS["approach"])


@pytest.fixture(scope="module")
def safety(tmp_path_factory) -> tuple[Path, dict]:
    d = tmp_path_factory.mktemp("safety")
    log = write_safety_log(d / "safety.mcap")
    out = d / "safety.rrd"
    assert main(["-q", "view", str(log), "--save", str(out)]) == 0
    return out, read_rrd(out)


def colour_at(rows: list, t: int) -> int:
    """The colour a colour column shows at time t (the latest row at or before it)."""
    return [v for ts, v in rows if ts <= t][-1][0]


def test_stop_polygon_turns_red_while_the_stop_lasts(safety):
    rrd, data = safety
    strips = column(data, "/safety/PolygonStop", "LineStrips3D:strips")
    assert len(strips) == 281  # one per decision: a 20 Hz command stream for 14 s
    assert all(len(v) == 1 and len(v[0]) == 5 for _, v in strips)  # 4 vertices, closed
    assert strips[0][1][0][0][:2] == pytest.approx([0.5, 0.3])
    colours = column(data, "/safety/PolygonStop", "LineStrips3D:colors")
    # the box (1 m ahead of the wall) stops the robot at 4.3 s until it is gone at 6.0 s
    assert [colour_at(colours, t) for t in (4250 * MS, 4300 * MS, 5950 * MS, 6000 * MS)] == [GREY, RED, RED, GREY]
    changes = [t for (t, v), (_, w) in zip(colours, colours[1:], strict=False) if v != w]
    assert changes == [4250 * MS, 5950 * MS, 12100 * MS]  # the row before each change
    assert column(data, "/safety/PolygonStop", "CoordinateFrame:frame", static=True)[0][1] == ["base_link"]
    assert verify(rrd).returncode == 0


def test_approach_polygon_and_its_prediction(safety):
    _, data = safety
    shape = column(data, "/safety/FootprintApproach", "LineStrips3D:strips")
    assert {len(v[0]) for _, v in shape} == {17}  # KiBot's robot_radius 0.34: Nav2's 16-gon, closed
    colours = column(data, "/safety/FootprintApproach", "LineStrips3D:colors")
    assert [colour_at(colours, t) for t in (2750 * MS, 2800 * MS, 4300 * MS)] == [GREY, ORANGE, GREY]
    pred = column(data, "/safety/navlog/collision_monitor/FootprintApproach/collision_footprint", "LineStrips3D:strips")
    shown = [t for t, v in pred if v]
    # predicted only while the 1.2 s simulation meets the box or the wall: never at the start, never while stopped
    assert shown and min(shown) > 2 * NS and not any(4300 * MS < t < 6000 * MS for t in shown)
    first = next(v for _, v in pred if v)[0]
    assert max(p[0] for p in first) > 0.34 + 0.45  # ahead of the robot's own footprint


def test_three_velocity_streams_and_events(safety):
    _, data = safety
    for axis in ("vx", "wz"):
        names = {}
        for topic in ("cmd_vel_nav", "cmd_vel_smoothed", "cmd_vel"):
            style = column(data, f"/plots/cmd_vel/{axis}/{topic}", "SeriesLines:names", static=True)
            widths = column(data, f"/plots/cmd_vel/{axis}/{topic}", "SeriesLines:widths", static=True)
            names[style[0][1][0]] = widths[0][1][0]
        assert names == {"/cmd_vel_nav": 5.0, "/cmd_vel_smoothed": 3.0, "/cmd_vel": 1.5}
    nav = column(data, "/plots/cmd_vel/vx/cmd_vel_nav", "Scalars:scalars")
    smoothed = column(data, "/plots/cmd_vel/vx/cmd_vel_smoothed", "Scalars:scalars")
    final = column(data, "/plots/cmd_vel/vx/cmd_vel", "Scalars:scalars")
    assert {v[0] for _, v in nav} == {0.45}
    # KiBot's max_accel 0.8 m/s^2 at 20 Hz: 0.04 m/s a tick from the first tick at 0 s
    assert [v[0] for _, v in smoothed[:3]] == pytest.approx([0.04, 0.08, 0.12])
    assert min(v[0] for _, v in final) == 0.0 and len(final) < len(smoothed)  # stops, then silence
    texts = column(data, "/events", "TextLog:text")
    levels = column(data, "/events", "TextLog:level")
    assert [(t, v[0]) for t, v in texts][:4] == [
        (2800 * MS, "FootprintApproach: approach started (collision monitor)"),
        (4300 * MS, "FootprintApproach: approach ended (collision monitor)"),
        (4300 * MS, "PolygonStop: stop started (collision monitor)"),
        (6000 * MS, "PolygonStop: stop ended (collision monitor)"),
    ]
    assert [v[0] for _, v in levels][:4] == ["INFO", "INFO", "WARN", "INFO"]


def test_polygon_names_and_event_states():
    assert polygon_name("/FootprintApproach") == ("FootprintApproach", False)
    assert polygon_name("/collision_monitor/slow_zone") == ("slow_zone", False)
    assert polygon_name("/navlog/collision_monitor/Stop/collision_footprint") == ("Stop", True)
    assert [event_state(k) for k in ("collision_monitor_limit", "collision_monitor_limit_end", "goal_reached")] == [
        "limit",
        "idle",
        None,
    ]
