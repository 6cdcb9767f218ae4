"""model://, package:// and local URIs, and the folders searched."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.recorder.resources import resolve_uri


@pytest.fixture(scope="module")
def nav2_sim(shared_dir: Path) -> Path:
    return shared_dir / "external-data" / "nav2_sim"


def test_model_uri_along_the_given_folders_and_the_environment(nav2_sim, tmp_path, monkeypatch):
    models = nav2_sim / "nav2_minimal_tb3_sim" / "models"
    uri = "model://turtlebot3_world/meshes/wall.dae"
    assert resolve_uri(uri, tmp_path, [models]) == models / "turtlebot3_world/meshes/wall.dae"
    monkeypatch.setenv("GAZEBO_MODEL_PATH", f"{tmp_path}:{models}")
    assert resolve_uri(uri, tmp_path) == models / "turtlebot3_world/meshes/wall.dae"


def test_package_uri_along_ros_package_path(nav2_sim, tmp_path, monkeypatch):
    uri = "package://nav2_minimal_tb4_description/meshes/rplidar.dae"
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    with pytest.raises(ConfigError, match=r"cannot resolve package://nav2_minimal_tb4_description/.*no package"):
        resolve_uri(uri, tmp_path)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(nav2_sim))
    assert resolve_uri(uri, tmp_path) == nav2_sim / "nav2_minimal_tb4_description/meshes/rplidar.dae"
    prefix = tmp_path / "install"  # an ament prefix: PREFIX/share/PKG
    (prefix / "share" / "my_pkg" / "meshes").mkdir(parents=True)
    (prefix / "share" / "my_pkg" / "package.xml").write_text("<package><name>my_pkg</name></package>")
    (prefix / "share" / "my_pkg" / "meshes" / "m.stl").write_text("solid m\nendsolid m\n")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(prefix))
    assert resolve_uri("package://my_pkg/meshes/m.stl", tmp_path) == prefix / "share/my_pkg/meshes/m.stl"


def test_missing_model_names_every_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(tmp_path / "a"))
    monkeypatch.delenv("GAZEBO_MODEL_PATH", raising=False)
    with pytest.raises(ConfigError) as err:
        resolve_uri("model://nowhere/model.sdf", tmp_path / "w", [tmp_path / "given"])
    msg = str(err.value)
    assert msg.startswith("cannot resolve model://nowhere/model.sdf: no model 'nowhere'")
    for folder in ("given", "a"):
        assert str(tmp_path / folder) in msg
    assert resolve_uri("file://" + str(tmp_path), Path("/")) == tmp_path


def test_packages_are_found_up_to_three_levels_down_but_not_in_hidden_folders(tmp_path):
    from navlog.recorder.resources import find_package

    def package(folder: Path, name: str) -> Path:
        folder.mkdir(parents=True)
        (folder / "package.xml").write_text(f"<package><name>{name}</name></package>")
        return folder

    deep = package(tmp_path / "src" / "group" / "robot_pkg", "robot_pkg")
    package(tmp_path / ".venv" / "lib" / "hidden_pkg", "hidden_pkg")
    package(tmp_path / "a" / "b" / "c" / "too_deep", "too_deep")
    assert find_package("robot_pkg", [tmp_path]) == deep
    assert find_package("hidden_pkg", [tmp_path]) is None
    assert find_package("too_deep", [tmp_path]) is None
