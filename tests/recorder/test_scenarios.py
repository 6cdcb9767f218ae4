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
