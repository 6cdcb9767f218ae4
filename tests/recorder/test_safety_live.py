"""The safety filters live: KiBot driven at a wall, an obstacle and backwards into a box stops short with
the filters and collides without them (the simulator's contact events); live and replay give the same bytes."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from navlog.cli import main
from navlog.errors import ConfigError
from navlog.recorder.record import prepare, record, scenario_command_topic
from navlog.recorder.scenarios import check_scenario
from navlog.recorder.world import clearance
from navlog.replay.io import open_log
from navlog.replay.pipelines import pipeline_spec
from navlog.replay.session import pipeline_params, run_replay

pytestmark = pytest.mark.slow

PADDED_RADIUS = 0.35  # KiBot's footprint: robot_radius 0.34 + Nav2's footprint_padding 0.01
STEP = 0.1  # FootprintApproach's simulation_time_step (Nav2's default)
REPO = Path(__file__).resolve().parents[2]


def run(tmp_path: Path, scenario: str, filters: bool):
    setup = prepare("walled_room", "kibot", scenario, seed=2)
    pipe = pipeline_spec("safety").build(pipeline_params("safety"), setup.topics()) if filters else None
    res = record(setup, tmp_path / f"{scenario}_{filters}.mcap", progress=False, pipeline=pipe)
    with open_log(res.path) as r:
        events = [(e.msg.kind, e.msg.source, e.msg.detail) for e in r.messages(["/navlog/events"])]
        last = list(r.messages(["/odom/ground_truth"]))[-1].msg.pose.pose.position
        topics = set(r.topics)
    gap = float(clearance(setup.world, np.array([[last.x, last.y]]))[0]) - PADDED_RADIUS
    return setup, events, gap, topics


@pytest.mark.parametrize(
    ("scenario", "speed", "obstacle"),
    [
        ("teleop_wall", 0.45, "wall_1/body"),
        ("teleop_obstacle", 0.45, "obstacle_1/body"),
        ("teleop_reverse", 0.2, "obstacle_2/body"),
    ],
)
def test_kibot_stops_short_with_the_filters_and_collides_without(tmp_path, scenario, speed, obstacle):
    setup, events, gap, topics = run(tmp_path, scenario, filters=True)
    assert not [e for e in events if e[0] == "collision"]
    assert ("collision_monitor_approach", "collision_monitor", "FootprintApproach") in events
    assert {"/cmd_vel_nav", "/cmd_vel_smoothed", "/cmd_vel"} <= topics
    # the approach model stops the command once the footprint, moved one simulation step at the commanded
    # speed, would hold the obstacle: the robot halts within speed * step of it (the laser's 1 cm noise
    # may stop it a little earlier)
    assert 0.0 < gap <= speed * STEP + 0.015, gap
    assert gap > speed * STEP - 0.03, gap
    _, events, gap, topics = run(tmp_path, scenario, filters=False)
    assert "/cmd_vel_nav" not in topics
    assert [e for e in events if e[0] == "collision"] == [("collision", "sim", obstacle)]  # once, not every tick
    assert gap < -0.009  # the chassis (0.3 m from base_link) touches: 0.05 m inside the padded footprint


def test_live_filters_equal_their_replay_byte_for_byte(tmp_path):
    log = tmp_path / "live.mcap"
    nav2 = REPO / "config" / "nav2" / "kibot_safety.yaml"
    args = ["-q", "record", "--world", "walled_room", "--robot", "kibot", "--scenario", "teleop_wall", "--seed", "4"]
    assert main([*args, "--pipeline", "safety", "--params", str(nav2), "-o", str(log)]) == 0
    params = pipeline_params("safety", nav2)
    res = run_replay(log, "safety", tmp_path / "out", params=params, progress=False)

    def raw(path: Path, topic: str) -> list[tuple[int, bytes]]:
        with open_log(path) as r:
            return [(e.time_ns, e.msg) for e in r.messages([topic], decode=False)]

    for topic, least in (("/cmd_vel_smoothed", 200), ("/cmd_vel", 150), ("/navlog/events", 2)):
        live, replayed = raw(log, topic), raw(res.out_dir / "replay.mcap", topic)
        assert len(live) >= least, topic
        assert live == replayed, topic
    summary = json.loads((res.out_dir / "safety.json").read_text())
    assert summary["commands_in"] == 301  # 15 s at 20 Hz, the last at 15.0 s
    assert summary["polygons"]["FootprintApproach"]["min_time_to_collision_s"] == 0.0
    assert summary["polygons"]["FootprintApproach"]["stopped_s"] > 3.0


def test_expect_contact_is_an_explicit_checked_opt_in():
    setup = prepare("walled_room", "kibot", "teleop_wall")
    blind = dataclasses.replace(setup.scenario, expect_contact=False)
    with pytest.raises(ConfigError, match="would collide.*sets expect_contact: true"):
        check_scenario(blind, setup.robot, setup.world)
    short = dataclasses.replace(
        setup.scenario, commands=[dataclasses.replace(setup.scenario.commands[0], duration=2.0)]
    )
    with pytest.raises(
        ConfigError, match="expect_contact: true, but its path stays 1.50 m from every obstacle.*remove expect_contact"
    ):
        check_scenario(short, setup.robot, setup.world)


def test_the_scenario_publishes_where_the_live_pipeline_takes_commands():
    setup = prepare("walled_room", "kibot", "teleop_wall")
    safety = pipeline_spec("safety")
    assert scenario_command_topic(None) == "/cmd_vel"
    mapping = pipeline_spec("mapping").build(pipeline_params("mapping"), setup.topics())
    assert scenario_command_topic(mapping) == "/cmd_vel"
    assert scenario_command_topic(safety.build(pipeline_params("safety"), setup.topics())) == "/cmd_vel_nav"
    off = safety.build(pipeline_params("safety", overrides=["output_topic=/cmd_vel_safe"]), setup.topics())
    with pytest.raises(ConfigError, match="gives its commands on /cmd_vel_safe, but the robot drives on /cmd_vel"):
        scenario_command_topic(off)
