"""Robot-world contacts: the pre-flight check of a scenario's path, and the contacts of a run in its
summary and exit status."""

from __future__ import annotations

import dataclasses

import pytest

from navlog.errors import ConfigError
from navlog.recorder.record import RecordSetup, format_contacts, format_summary, prepare, record
from navlog.recorder.robot import RobotSpec
from navlog.recorder.scenarios import ScenarioSpec, TimedCommand, robot_reach
from navlog.recorder.world import load_world


def test_kibot_reaches_beyond_its_nav2_radius():
    setup = prepare("walled_room", "kibot", "teleop_wall")
    assert setup.robot.radius == 0.34
    assert robot_reach(setup.robot) == pytest.approx(0.3905, abs=1e-4)  # half of the 0.6 x 0.5 m body's diagonal


def test_teleop_with_kibot_in_walled_room_names_the_obstacle_it_would_hit():
    # the teleop arc ends at (1.45, 1.79): 0.09 m from the cylinder obstacle_1 (r 0.5 at (2, 2))
    with pytest.raises(ConfigError) as exc:
        prepare("walled_room", "kibot", "teleop")
    text = str(exc.value)
    assert "would collide with obstacle_1/body" in text
    assert "within the robot's reach of it at (1.19, 1.64) after 12.5 s of commands" in text
    assert "passes (1.45, 1.79), 0.09 m from an obstacle" in text
    assert "reaches 0.39 m from its centre" in text and "expect_contact: true" in text


def test_teleop_with_kibot_in_indoor_room_is_refused_for_its_body_corners():
    # 0.38 m from wall_block_1 is clear of the 0.34 m radius, not of the body's 0.39 m corners (the run
    # used to pass this check and touch wall_block_1 at 13.16 s)
    with pytest.raises(ConfigError, match=r"would collide with wall_block_1/right .* 0\.38 m from an obstacle"):
        prepare("indoor_room", "kibot", "teleop")
    prepare("indoor_room", "simple_robot", "teleop")  # its 0.5 x 0.4 m body reaches 0.32 m: clear


def _into_the_east_wall(expect_contact: bool, robot_name: str = "kibot", x0: float = 3.5) -> RecordSetup:
    """The robot ``4.9 - x0`` m before the east wall's inner face (x 4.9) at full speed for 5 s, without
    the pre-flight check (which refuses this path unless the scenario expects contact)."""
    world = load_world("walled_room")
    robot: RobotSpec = prepare("walled_room", robot_name, "teleop_wall").robot
    scenario = ScenarioSpec(
        name="into_wall",
        kind="teleop",
        start=(x0, 0.0, 0.0),
        commands=[TimedCommand(5.0, (robot.drive.max_vx, 0.0, 0.0))],
        hold=0.5,
        expect_contact=expect_contact,
    )
    return RecordSetup(world, robot, scenario, seed=0, noise=False)


def test_an_unexpected_contact_is_in_the_summary_and_fails_the_run(tmp_path):
    res = record(_into_the_east_wall(False), tmp_path / "hit.mcap", progress=False, sensor_worker=False)
    assert res.collisions == 1
    t, what = res.contacts[0]
    assert what == "wall_1/body"
    # the front (0.3 m ahead of the centre) covers 1.1 m: 0.56 s to reach 0.45 m/s at 0.8 m/s², then 2.3 s
    assert 2.6 < t < 3.2
    assert res.failed == "1 collision(s)"
    summary = format_summary(res)
    assert f"contacts: 1 (not expected by the scenario), first at {t:.2f} s with wall_1/body" in summary
    assert summary.splitlines()[-1] == "FAILED: 1 collision(s)"


def test_a_legged_robot_reports_where_its_footprint_overlaps_an_obstacle(tmp_path):
    # the Go2's trunk does not collide (its legs are not simulated): it used to drive through the wall
    # with nothing reported; its 0.22 m footprint reaches the wall's face (x 4.9) when its centre is at
    # x 4.68: 0.28 m from x0 = 4.4 at 0.3 m/s, after 0.25 s of response
    res = record(_into_the_east_wall(False, "go2", 4.4), tmp_path / "go2.mcap", progress=False, sensor_worker=False)
    assert [name for _, name in res.contacts] == ["wall_1/body"]
    assert 1.0 < res.contacts[0][0] < 1.5
    assert res.failed == "1 collision(s)"


def test_an_expected_contact_is_reported_and_passes(tmp_path):
    res = record(_into_the_east_wall(True), tmp_path / "hit.mcap", progress=False, sensor_worker=False)
    assert res.collisions == 1 and res.failed is None
    assert "contacts: 1 (expected: the scenario sets expect_contact), first at" in format_summary(res)


def test_contact_line_lists_every_object_touched_once():
    setup = _into_the_east_wall(False)
    res = dataclasses.replace(
        _result(setup), contacts=[(2.5, "wall_1/body"), (4.0, "obstacle_1/body"), (6.25, "wall_1/body")]
    )
    assert format_contacts(res) == (
        "contacts: 3 (not expected by the scenario), first at 2.50 s with wall_1/body; "
        "touched: obstacle_1/body, wall_1/body"
    )
    assert format_contacts(dataclasses.replace(res, contacts=[])) == "contacts: none"


def _result(setup: RecordSetup):
    from pathlib import Path

    from navlog.recorder.record import RecordResult

    return RecordResult(Path("x.mcap"), 7.0, 1.0, 1000, {}, metadata=setup.metadata())
