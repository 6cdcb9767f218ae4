"""The safety pipeline over logs: KiBot's smoother and FootprintApproach in front of a known wall, the
filters switched off in turn, the invalid-source stop, the summary, byte-identical replays, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from navlog.errors import ConfigError, NavlogError
from navlog.replay import messages as m
from navlog.replay.io import open_log
from navlog.replay.pipelines.safety import Params, build
from navlog.replay.runtime.executor import Envelope
from navlog.replay.session import pipeline_params, run_replay
from tests.replay.nav2.test_collision_monitor import wall_scan
from tests.replay.pipelines.test_mapping_replay import scan_msg, write_log

MS = 1_000_000
DATA = Path(__file__).resolve().parents[1] / "nav2" / "data"


def teleop_log(path: Path, *, vx: float = 0.45, seconds: float = 3.0, scans: bool = True, topic="/cmd_vel") -> Path:
    """A robot standing at the odom origin, a wall 0.65 m ahead of base_link (0.3 m ahead of KiBot's padded
    0.35 m footprint), a joystick asking for ``vx`` at 20 Hz on ``topic``; TF at 100 Hz, scans at 10 Hz."""
    envs = []
    for k in range(int(seconds * 100)):
        t = k * 10 * MS
        tf = m.transform_stamped(t, "odom", "base_link", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        envs.append(Envelope("/tf", m.TF_MESSAGE, t, m.tf_message([tf])))
        if scans and k % 10 == 0:
            envs.append(Envelope("/scan", m.LASER_SCAN, t, scan_msg(t, wall_scan(0.0, wall_x=0.65), "base_link")))
        if k % 5 == 0:
            envs.append(Envelope(topic, m.TWIST, t, m.twist(vx, 0.0, 0.0)))
    return write_log(path, envs)


def read(path: Path, topic: str) -> list:
    with open_log(path) as r:
        return [(e.time_ns, e.msg) for e in r.messages([topic])]


def test_kibot_filters_ramp_the_command_and_scale_it_by_the_time_to_the_wall(tmp_path):
    log = teleop_log(tmp_path / "teleop.mcap")
    res = run_replay(log, "safety", tmp_path / "out", remap={"/cmd_vel_nav": "/cmd_vel"}, progress=False)
    out = res.out_dir / "replay.mcap"
    # the smoother: KiBot's accel 0.8 m/s^2 at 20 Hz, 0.04 m/s per tick, up to max 0.45
    smoothed = [msg.linear.x for _, msg in read(out, "/cmd_vel_smoothed")]
    assert smoothed[:3] == pytest.approx([0.04, 0.08, 0.12]) and smoothed[-1] == pytest.approx(0.45)
    # the monitor: at 0.45 m/s the 0.35 m footprint passes the wall (0.3 m ahead) in its 7th 0.045 m
    # step, Nav2's t = 0.6 s: the command is scaled by 0.6 / 1.2
    cmd = [msg.linear.x for _, msg in read(out, "/cmd_vel")]
    assert cmd[-1] == pytest.approx(0.225) and max(cmd) < 0.45
    events = [(e.kind, e.detail) for _, e in read(out, "/navlog/events")]
    assert events == [("collision_monitor_approach", "FootprintApproach")]
    summary = json.loads((res.out_dir / "safety.json").read_text())
    assert (
        summary["commands_in"] == 60
        and summary["commands_out"] == len(cmd) == summary["velocity_smoother"]["published"]
    )
    approach = summary["polygons"]["FootprintApproach"]
    assert approach["min_time_to_collision_s"] == pytest.approx(0.6)
    assert approach["approach"] > 30 and approach["stopped"] == approach["slowed"] == approach["limited"] == 0
    assert approach["stopped_s"] == 0.0
    assert summary["nav2_params"] == "kibot_safety.yaml"
    assert res.manifest["pipeline_info"]["chain"] == (
        "/cmd_vel_nav -> velocity_smoother -> /cmd_vel_smoothed -> collision_monitor -> /cmd_vel"
    )
    assert res.manifest["pipeline_info"]["footprint"] == "costmap footprint from the Nav2 file"


def test_each_filter_can_be_switched_off(tmp_path):
    log = teleop_log(tmp_path / "nav.mcap", topic="/cmd_vel_nav")
    smoother = run_replay(log, "safety", tmp_path / "s", overrides=["collision_monitor=off"], progress=False)
    ramp = [msg.linear.x for _, msg in read(smoother.out_dir / "replay.mcap", "/cmd_vel")]
    assert ramp[:2] == pytest.approx([0.04, 0.08]) and ramp[-1] == pytest.approx(0.45)
    assert smoother.manifest["pipeline_info"]["chain"] == "/cmd_vel_nav -> velocity_smoother -> /cmd_vel"
    monitor = run_replay(log, "safety", tmp_path / "c", overrides=["velocity_smoother=off"], progress=False)
    direct = [msg.linear.x for _, msg in read(monitor.out_dir / "replay.mcap", "/cmd_vel")]
    assert len(direct) == 60 and direct[-1] == pytest.approx(0.225)  # one decision per command, as it came
    with pytest.raises(ConfigError, match="both off"):
        build(Params(velocity_smoother="off", collision_monitor="off"), set())


def test_no_scan_is_nav2s_invalid_source_stop_counted(tmp_path):
    log = teleop_log(tmp_path / "blind.mcap", scans=False)
    res = run_replay(log, "safety", tmp_path / "out", remap={"/cmd_vel_nav": "/cmd_vel"}, progress=False)
    cmd = [msg.linear.x for _, msg in read(res.out_dir / "replay.mcap", "/cmd_vel")]
    assert cmd and set(cmd) == {0.0}  # zeros until stop_pub_timeout (1 s), then silence
    summary = json.loads((res.out_dir / "safety.json").read_text())
    assert summary["polygons"]["invalid source"]["stopped"] == 60
    assert res.manifest["skipped"]["collision_monitor: scan: no message on /scan yet"] == 60


def test_replays_are_byte_identical(tmp_path):
    log = teleop_log(tmp_path / "teleop.mcap")
    for name in ("a", "b"):
        run_replay(log, "safety", tmp_path / name, remap={"/cmd_vel_nav": "/cmd_vel"}, progress=False)
    for f in ("replay.mcap", "safety.json"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def test_params_default_and_bad_input(tmp_path):
    params = pipeline_params("safety")
    assert params.nav2_params == "kibot_safety" and params.input_topic == "/cmd_vel_nav"
    given = pipeline_params("safety", DATA / "kibot_nav2_fixed.yaml")
    assert Path(given.nav2_params) == (DATA / "kibot_nav2_fixed.yaml").resolve()
    with pytest.raises(ConfigError, match="no collision_monitor polygons"):
        build(given, set())  # the fixed KiBot file has costmap and planner only
    with pytest.raises(ConfigError, match=r"'kibot_safty' not found \(did you mean 'kibot_safety'\?\)"):
        build(Params(nav2_params="kibot_safty"), set())
    # a log with the footprint topic: the approach polygon follows it instead of the costmap's
    pipe = build(Params(), {"/cmd_vel_nav", "/scan", "/local_costmap/published_footprint"})
    assert "footprint" not in pipe.info and "/local_costmap/published_footprint" in pipe.optional_inputs
    assert pipe.commands == ("/cmd_vel_nav", "/cmd_vel")
    assert pipe.nothing_produced() == (
        "no command on /cmd_vel_nav (for a teleop log, read its commands with --remap /cmd_vel_nav=/cmd_vel)"
    )
    # a teleop log without the remap: the missing input is named with the remedy
    log = teleop_log(tmp_path / "teleop.mcap", seconds=0.2)
    with pytest.raises(NavlogError, match="missing /cmd_vel_nav.*--remap"):
        run_replay(log, "safety", tmp_path / "out", progress=False)


def test_nav2_overrides_reach_the_filters(tmp_path):
    """``--set nav2.KEY`` overrides the Nav2 file's keys, full or short, as the planner pipeline's do."""
    log = teleop_log(tmp_path / "teleop.mcap")
    overrides = ["nav2.velocity_smoother.max_accel=[0.4,0.0,1.5]", "nav2.FootprintApproach.time_before_collision=2.4"]
    res = run_replay(
        log, "safety", tmp_path / "out", remap={"/cmd_vel_nav": "/cmd_vel"}, overrides=overrides, progress=False
    )
    out = res.out_dir / "replay.mcap"
    # half KiBot's acceleration: 0.02 m/s per 20 Hz tick instead of 0.04
    smoothed = [msg.linear.x for _, msg in read(out, "/cmd_vel_smoothed")]
    assert smoothed[:3] == pytest.approx([0.02, 0.04, 0.06]) and smoothed[-1] == pytest.approx(0.45)
    # twice the time before collision: the footprint that reaches the wall at 0.6 s scales by 0.6 / 2.4
    cmd = [msg.linear.x for _, msg in read(out, "/cmd_vel")]
    assert cmd[-1] == pytest.approx(0.45 * 0.6 / 2.4)
    with pytest.raises(ConfigError, match="max_acel: no such parameter.*did you mean 'max_accel'"):
        build(pipeline_params("safety", overrides=["nav2.velocity_smoother.max_acel=[1,0,1]"]), set())
