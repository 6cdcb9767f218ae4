"""Scenarios that name their world by path: the path starts at the scenario file."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.recorder.record import prepare

WORLD = """name: my_corridor
walls: {size: [6.0, 3.0], thickness: 0.2, height: 2.0}
"""
SCENARIO = """name: corridor_tour
kind: tour
world: {world}
start: [-2.0, 0.0, 0.0]
waypoints: [[2.0, 0.0]]
"""


def _files(tmp_path: Path, world_ref: str) -> Path:
    (tmp_path / "worlds").mkdir()
    (tmp_path / "worlds" / "my_world.yaml").write_text(WORLD)
    (tmp_path / "scenarios").mkdir()
    scenario = tmp_path / "scenarios" / "tour.yaml"
    scenario.write_text(SCENARIO.format(world=world_ref))
    return scenario


def test_a_scenario_names_its_world_relative_to_itself(tmp_path, monkeypatch):
    scenario = _files(tmp_path, "../worlds/my_world.yaml")
    monkeypatch.chdir("/")  # not where the scenario is
    setup = prepare(None, "go2", str(scenario))
    assert setup.world.name == "my_corridor" and setup.world.path == tmp_path / "scenarios/../worlds/my_world.yaml"
    again = prepare(str(tmp_path / "worlds" / "my_world.yaml"), "go2", str(scenario))  # the same file named on --world
    assert again.world.name == "my_corridor"


def test_a_scenario_refuses_another_world_file(tmp_path):
    scenario = _files(tmp_path, "../worlds/my_world.yaml")
    with pytest.raises(ConfigError, match=r"laid out for world .*my_world.yaml, not .*walled_room.yaml"):
        prepare("walled_room", "go2", str(scenario))


@pytest.mark.parametrize(
    "line, message",
    [
        ("hold: 1.0e+300", r"hold: 1e\+300 is out of range: must be <= 1000000.0"),
        ("hold: .nan", "hold: nan is out of range"),
        ("hold: -1", r"hold: -1.0 is out of range: must be >= 0.0"),
        ("max_duration: 1.0e+300", r"max_duration: 1e\+300 is out of range"),
        ("max_duration: .nan", "max_duration: nan is out of range"),
        ("speed: .nan", "speed: nan is out of range"),
        ("turn_rate: 1.0e+300", r"turn_rate: 1e\+300 is out of range: must be <= 100.0"),
        ("tolerance: .nan", "tolerance: nan is out of range"),
    ],
)
def test_a_scenario_refuses_a_hold_a_duration_or_a_speed_out_of_range_naming_the_file(tmp_path, line, message):
    """A hold or max_duration of 1e300 s or NaN ended the recording in an OverflowError or a ValueError
    (their nanoseconds are integers); each is refused with the file and key, before anything runs."""
    scenario = _files(tmp_path, "../worlds/my_world.yaml")
    scenario.write_text(scenario.read_text() + line + "\n")
    with pytest.raises(ConfigError, match=f"{scenario.name}: {message}"):
        prepare(None, "go2", str(scenario))


def test_a_world_without_a_scenario_laid_out_in_it_is_told_which_scenarios_fit(tmp_path, shared_dir):
    """The default scenario tours indoor_room: another world without --scenario is refused, naming navlog's
    scenarios laid out for a world of that name (a map file by its file name) and those that fit any world."""
    with pytest.raises(ConfigError) as err:
        prepare("walled_room", "kibot", "mapping")
    msg = str(err.value)
    assert "laid out for world 'indoor_room', not 'walled_room'" in msg
    assert "--scenario nav_kibot or nav_simple_robot or teleop_obstacle" in msg and msg.endswith("--scenario teleop")
    (tmp_path / "depot.pgm").write_bytes(b"P5\n4 4\n255\n" + bytes([0] * 4 + [254] * 12))
    (tmp_path / "depot.yaml").write_text(
        "image: depot.pgm\nresolution: 0.5\norigin: [0.0, 0.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\n"
        "free_thresh: 0.25\n"
    )
    with pytest.raises(ConfigError, match="laid out for it: --scenario nav2_tb4_depot; in any world"):
        prepare(str(tmp_path / "depot.yaml"), "kibot", "mapping")
    # the scenario refused is not the one suggested: another depot.yaml than the one it names
    with pytest.raises(ConfigError) as err:
        prepare(str(tmp_path / "depot.yaml"), "kibot", "nav2_tb4_depot", package_paths=[shared_dir / "external-data"])
    assert "depot.yaml, not " in str(err.value) and "--scenario nav2_tb4_depot" not in str(err.value)


def test_a_robot_yaml_asking_for_a_rate_off_the_physics_step_is_told_its_published_rate(tmp_path):
    """Every sensor goes out at the multiple of the 5 ms step nearest its period: a robot YAML asking for 30 Hz
    odometry is told it gets 28.57 Hz (a robot from a description file was; a whole-robot YAML was not)."""
    from navlog.replay.config import named_config

    kibot = named_config("robots", "kibot").read_text()
    (tmp_path / "kibot30.yaml").write_text(kibot + "odom: {rate: 30.0}\n")
    notes = prepare("walled_room", str(tmp_path / "kibot30.yaml"), "teleop_obstacle").notes()
    assert notes == ["rates published at the nearest multiple of the 5 ms physics step: odometry 30 -> 28.57 Hz"]
    assert prepare("walled_room", "kibot", "teleop_obstacle").notes() == []
