"""Nav2's getting-started simulation from Nav2's own files: the shipped scenarios find them along the package
path, Nav2's current nav2_params.yaml loads unchanged (what navlog does not run is named), the Waffle
navigates the sandbox on AMCL, and a SLAM map of the sandbox agrees with Nav2's map of it."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from navlog.cli import main
from navlog.errors import ConfigError
from navlog.recorder.record import prepare, record
from navlog.recorder.resources import package_folder, resolve_uri
from navlog.recorder.scenarios import load_scenario, resolve_files
from navlog.replay.nav2 import load_nav2_params


@pytest.fixture(scope="module")
def data(shared_dir: Path) -> Path:
    return shared_dir / "external-data"


@pytest.fixture(autouse=True)
def _no_package_path_env(monkeypatch):
    for name in ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH"):
        monkeypatch.delenv(name, raising=False)


def test_scenario_files_found_along_the_package_path(data, monkeypatch):
    s = load_scenario("nav2_tb3_sandbox")
    with pytest.raises(
        ConfigError, match=r"cannot resolve package://nav2_minimal_tb3_sim/.*no package.*--package-path"
    ):
        resolve_files(s, None)
    found = resolve_files(s, None, [data])
    assert found.world == str(data / "nav2_sim/nav2_minimal_tb3_sim/worlds/tb3_sandbox.sdf.xacro")
    assert found.robot == str(data / "nav2_sim/nav2_minimal_tb3_sim/urdf/gz_waffle.sdf.xacro")
    # nav2_bringup's files without their package.xml: the folder of that name on the path is the package
    assert found.nav2_params == str(data / "nav2_bringup/params/nav2_params.yaml")
    assert found.map == str(data / "nav2_bringup/maps/tb3_sandbox.yaml")
    assert found.goals == "tb3_sandbox_pillars"  # a name in config/goals stays a name
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(data))
    assert resolve_files(s, None) == found
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    monkeypatch.chdir(data.parent)  # a relative --package-path is the working folder's, not the scenario's
    assert resolve_files(s, None, [data.name]) == found


def test_find_package_names_every_folder_searched(tmp_path):
    with pytest.raises(ConfigError) as err:
        package_folder("nowhere_pkg", [tmp_path / "given"], near=tmp_path / "pkg" / "urdf")
    msg = str(err.value)
    assert msg.startswith("package 'nowhere_pkg' not found (searched ")
    for folder in (tmp_path / "given", tmp_path / "pkg" / "urdf", tmp_path / "pkg"):
        assert str(folder) in msg
    own = tmp_path / "my_robot"
    (own / "urdf").mkdir(parents=True)
    (own / "package.xml").write_text("<package><name>my_robot</name></package>")
    (own / "meshes").mkdir()
    (own / "meshes" / "m.stl").write_text("solid m\nendsolid m\n")
    # a file inside a package finds its own package without any setting
    assert resolve_uri("package://my_robot/meshes/m.stl", own / "urdf") == own / "meshes" / "m.stl"


def test_nav2_params_unchanged_load_with_what_navlog_does_not_run_named(data, capsys):
    path = data / "nav2_bringup" / "params" / "nav2_params.yaml"
    params = load_nav2_params(path)
    mppi = params.require_valid(["controller_server"]).controller_server.controllers["FollowPath"]
    assert mppi.motion_model == "DiffDrive" and mppi.batch_size == 2000 and mppi.vx_max == 0.5  # type: ignore[union-attr]
    assert params.amcl is not None and params.amcl.max_particles == 2000
    assert main(["check-config", str(path), "--notes"]) == 0
    out = capsys.readouterr().out
    assert "0 error(s)" in out
    for named in ("model_delay_vx", "TrajectoryValidator", "FeasiblePathHandler", "path_length_tolerance"):
        line = next(x for x in out.splitlines() if named in x)
        assert "not implemented by navlog" in line
    # parameters Nav2 declares since Jazzy are read, not called unknown
    assert "unknown parameter" not in out
    for named in (
        "random_seed",
        "bt_search_directories",
        "allow_partial_planning",
        "collision_monitor.ros__parameters.enabled",
    ):
        line = next(x for x in out.splitlines() if named in x)
        assert "not implemented by navlog" in line, line


@pytest.mark.slow
def test_waffle_navigates_the_sandbox_on_amcl(data, tmp_path, caplog):
    caplog.set_level(logging.ERROR)
    setup = prepare(None, None, "nav2_tb3_sandbox", localization="amcl", package_paths=[data])
    res = record(setup, tmp_path / "nav.mcap", progress=False)
    assert res.navigation is not None and res.failed is None, res.failed
    goals = res.navigation["goals"]
    assert len(goals) == 5 and all(g["status"] == "succeeded" for g in goals)
    assert res.collisions == 0
    loc = res.localization
    assert loc is not None and loc["poses"] > 200  # one per scan AMCL took (5 Hz, after each 0.25 m or 0.2 rad)
    assert loc["mean_m"] < 0.10 and loc["max_m"] < 0.35 and loc["final_m"] < 0.10, loc


@pytest.mark.slow
def test_turtlebot4_navigates_the_depot_map_as_a_world(data, tmp_path, caplog):
    caplog.set_level(logging.ERROR)
    setup = prepare(None, None, "nav2_tb4_depot", localization="amcl", package_paths=[data])
    assert setup.robot.model is not None and setup.world.name == "depot"
    res = record(setup, tmp_path / "nav.mcap", progress=False)
    assert res.navigation is not None and res.failed is None, res.failed
    assert len(res.navigation["goals"]) == 5 and res.collisions == 0
    loc = res.localization
    assert loc is not None and loc["mean_m"] < 0.25 and loc["final_m"] < 0.15, loc


@pytest.mark.slow
def test_slam_map_of_the_sandbox_agrees_with_nav2s_map(data, tmp_path, capsys):
    log = tmp_path / "map.mcap"
    args = ["record", "--scenario", "tb3_sandbox_mapping", "--package-path", str(data), "--localization", "none"]
    assert main([*args, "-o", str(log)]) == 0
    assert (
        main(["replay", str(log), "--pipeline", "mapping", "--set", "pose_source=slam", "-o", str(tmp_path / "out")])
        == 0
    )
    capsys.readouterr()
    reference = data / "nav2_bringup" / "maps" / "tb3_sandbox.yaml"
    assert main(["metrics", str(log), "--replay", str(tmp_path / "out"), "--reference-map", str(reference)]) == 0
    out = capsys.readouterr().out
    f1 = float(next(x for x in out.splitlines() if x.strip().startswith("F1 ")).split()[1])
    assert f1 >= 0.9, out


def test_navigation_commands_go_to_the_topic_the_robots_drive_plugin_names(data):
    s = resolve_files(load_scenario("nav2_tb3_sandbox"), None, [data])
    from navlog.recorder.description import load_robot
    from navlog.recorder.navigation import navigation_pipeline

    robot = load_robot(s.robot, {"namespace": "/tb3"}, [data])
    assert robot.cmd_topic == "/tb3/cmd_vel"
    nav = navigation_pipeline(s, 0, command_topic=robot.cmd_topic)
    monitor = next(n for n in nav.nodes if type(n).__name__ == "CollisionMonitorNode")
    assert monitor.output_topic == "/tb3/cmd_vel"  # type: ignore[attr-defined]
    default = navigation_pipeline(s, 0)
    assert next(n for n in default.nodes if type(n).__name__ == "CollisionMonitorNode").output_topic == "/cmd_vel"  # type: ignore[attr-defined]


def test_params_given_to_record_are_amcls_too(data, tmp_path, capsys):
    """`navlog record --params FILE` replaces a navigate scenario's Nav2 file for the whole run: AMCL reads its
    amcl block as the navigation reads the rest. Before, AMCL read the scenario's own file, and an amcl block
    Nav2 refuses in the given file went unread."""
    params = (data / "nav2_bringup/params/nav2_params.yaml").read_text()
    assert params.count("max_particles: 2000") == 1
    bad = tmp_path / "nav2_params.yaml"
    bad.write_text(params.replace("max_particles: 2000", "max_particles: 100000000"))
    argv = ["-q", "record", "--scenario", "nav2_tb3_sandbox", "--package-path", str(data), "--localization", "amcl"]
    assert main([*argv, "--params", str(bad), "-o", str(tmp_path / "nav.mcap")]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "max_particles" in err, err
    assert not (tmp_path / "nav.mcap").exists()


def test_a_robot_without_a_laser_is_refused_for_amcl_and_said_in_the_summary(data):
    """The Waffle's plain URDF declares no laser (its Gazebo file does): AMCL on it would estimate nothing for
    the whole run, so it is refused, naming the file; without AMCL the recording's notes say there is no scan."""
    urdf = data / "nav2_sim/nav2_minimal_tb3_sim/urdf/turtlebot3_waffle.urdf"
    args = dict(package_paths=[data], drive="diff_drive")
    with pytest.raises(ConfigError, match=rf"robot 'turtlebot3_waffle' \({urdf}\) has no 2D laser, and AMCL"):
        prepare(None, str(urdf), "nav2_tb3_sandbox", localization="amcl", **args)
    setup = prepare(None, str(urdf), "nav2_tb3_sandbox", **args)
    assert setup.robot.scan is None and any(n.startswith("no 2D laser") for n in setup.notes())
    with_laser = prepare(None, None, "nav2_tb3_sandbox", localization="amcl", package_paths=[data])
    assert with_laser.robot.scan is not None and not any(n.startswith("no 2D laser") for n in with_laser.notes())
    # the Waffle's 30 Hz odometry and joint states go out every 35 ms, the nearest multiple of the 5 ms step
    assert (
        "rates published at the nearest multiple of the 5 ms physics step: odometry 30 -> 28.57 Hz, "
        "joint states 30 -> 28.57 Hz"
    ) in with_laser.notes()
