"""NAVLOG_CONFIG_PATH: a user's own worlds, robots and scenarios, beside and before the built-in ones."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.recorder.record import prepare
from navlog.recorder.robot import load_robot
from navlog.recorder.scenarios import load_scenario
from navlog.recorder.world import load_world
from navlog.replay.config import CONFIG_PATH_ENV, builtin_config_dir, config_dirs, named_config

ONE_BOX = "name: {name}\nobjects:\n  - {{name: box_1, shape: box, size: [0.5, 0.5, 0.5], pose: [2.0, 0.0, 0.0]}}\n"
DRIVE = "name: my_drive\nkind: teleop\nstart: [0.0, 0.0, 0.0]\ncommands:\n  - {duration: 1.0, cmd: [0.1, 0.0, 0.0]}\n"


@pytest.fixture
def user_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A user's config folder with a new world, a world named like a built-in one, a robot and a scenario."""
    for kind in ("worlds", "robots", "scenarios"):
        (tmp_path / kind).mkdir()
    (tmp_path / "worlds" / "my_room.yaml").write_text(ONE_BOX.format(name="my_room"))
    (tmp_path / "worlds" / "indoor_room.yaml").write_text(ONE_BOX.format(name="indoor_room"))
    go2 = (builtin_config_dir() / "robots" / "go2.yaml").read_text()
    assert "\nradius: 0.22\n" in go2
    (tmp_path / "robots" / "go2.yaml").write_text(go2.replace("\nradius: 0.22\n", "\nradius: 0.3\n"))
    (tmp_path / "scenarios" / "my_drive.yaml").write_text(DRIVE)
    monkeypatch.setenv(CONFIG_PATH_ENV, str(tmp_path))
    return tmp_path


def test_search_path_puts_the_users_folders_first(user_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert config_dirs() == [user_dir, builtin_config_dir()]
    monkeypatch.setenv(CONFIG_PATH_ENV, f"{user_dir / 'a'}{os.pathsep}{user_dir / 'b'}")
    assert config_dirs() == [user_dir / "a", user_dir / "b", builtin_config_dir()]


def test_a_user_world_is_found_by_name(user_dir: Path) -> None:
    world = load_world("my_room")
    assert world.name == "my_room" and world.path == user_dir / "worlds" / "my_room.yaml"
    assert load_world("walled_room").path == builtin_config_dir() / "worlds" / "walled_room.yaml"


def test_a_user_file_replaces_the_built_in_one_of_the_same_name(user_dir: Path) -> None:
    assert named_config("worlds", "indoor_room") == user_dir / "worlds" / "indoor_room.yaml"
    assert [o.name for o in load_world("indoor_room").spec.objects] == ["box_1"]
    assert load_robot("go2").radius == 0.3


def test_a_user_scenario_runs_with_user_and_built_in_files(user_dir: Path) -> None:
    assert load_scenario("my_drive").kind == "teleop"
    setup = prepare("my_room", "go2", "my_drive")
    assert (setup.world.name, setup.robot.radius, setup.scenario.name) == ("my_room", 0.3, "my_drive")


def test_an_unknown_name_lists_both_places(user_dir: Path) -> None:
    with pytest.raises(ConfigError) as err:
        load_world("my_rom")
    msg = str(err.value)
    assert "did you mean 'my_room'?" in msg
    assert str(user_dir / "worlds") in msg and str(builtin_config_dir() / "worlds") in msg
    assert "indoor_room" in msg and "walled_room" in msg and CONFIG_PATH_ENV in msg
