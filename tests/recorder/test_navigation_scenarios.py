"""Navigate scenarios: what is refused before anything is simulated, and the map they publish."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.recorder.navigation import world_map_node
from navlog.recorder.record import prepare
from navlog.recorder.robot import load_robot
from navlog.recorder.scenarios import check_scenario, load_scenario
from navlog.recorder.world import load_world


def goals_file(tmp_path: Path, *goals: tuple[str, float, float]) -> str:
    lines = ["frame_id: map", "goals:"] + [f"  - {{name: {n}, x: {x}, y: {y}, yaw: 0.0}}" for n, x, y in goals]
    path = tmp_path / "goals.yaml"
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_the_shipped_navigation_scenarios_pass_their_checks() -> None:
    for name in ("nav_tour", "nav_simple_robot", "nav_kibot"):
        setup = prepare(None, None, name)  # world and robot from the scenario
        assert setup.scenario.kind == "navigate"
        assert setup.world.name == setup.scenario.world and setup.robot.name == setup.scenario.robot


def test_a_goal_inside_an_obstacle_is_refused_naming_it(tmp_path: Path) -> None:
    # cinder block wall_block_1 stands at (2, 1.5) in indoor_room
    s = replace(load_scenario("nav_tour"), goals=goals_file(tmp_path, ("ok", -1.0, -1.0), ("in_block", 2.0, 1.5)))
    with pytest.raises(ConfigError, match=r"goal 'in_block' \(2.00, 1.50\) is inside an obstacle"):
        check_scenario(s, load_robot("go2"), load_world("indoor_room"))


def test_a_goal_outside_the_world_is_refused(tmp_path: Path) -> None:
    s = replace(load_scenario("nav_tour"), goals=goals_file(tmp_path, ("far", 40.0, 0.0)))
    with pytest.raises(ConfigError, match=r"goal 'far' \(40.00, 0.00\) is outside world 'indoor_room'"):
        check_scenario(s, load_robot("go2"), load_world("indoor_room"))


def test_a_scenario_for_another_robot_is_refused() -> None:
    with pytest.raises(ConfigError, match="made for robot 'go2', not 'kibot'; use --robot go2"):
        prepare(None, "kibot", "nav_tour")


def test_a_navigate_scenario_needs_its_nav2_file_and_goals() -> None:
    with pytest.raises(ValueError, match="needs nav2_params"):
        replace(load_scenario("nav_tour"), goals="")


def test_the_world_map_marks_the_obstacles_grown_by_the_margin() -> None:
    node = world_map_node(load_scenario("nav_tour"), load_world("indoor_room"))
    assert node is not None
    grid = node.grid
    # wall_block_1, a cinder block at (2, 1.5), spans x 1.78..2.22 and y 1.40..1.60; the margin adds 0.15 m
    assert grid.value_at(2.0, 1.5) == 100
    assert grid.value_at(2.0, 1.72) == 100 and grid.value_at(2.35, 1.5) == 100  # within the margin
    assert grid.value_at(2.0, 1.82) == 0 and grid.value_at(2.45, 1.5) == 0  # beyond it
    assert grid.value_at(0.0, 0.0) == 0
    assert world_map_node(load_scenario("nav_kibot"), load_world("walled_room")) is None  # map: none
