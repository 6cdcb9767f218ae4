"""slam_toolbox's parameter file read by the mapping pipeline (``navlog.replay.mapping.slam2d.toolbox``):
``navlog replay LOG --pipeline mapping --params mapper_params_online_async.yaml`` and ``navlog check-config``."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
import yaml

from navlog.cli import main
from navlog.errors import ConfigError
from navlog.replay.mapping.slam2d.params import SlamParams
from navlog.replay.mapping.slam2d.toolbox import NOT_USED
from navlog.replay.pipelines.mapping import slam_node
from navlog.replay.session import pipeline_params, run_replay

# slam_toolbox's mapper_params_online_async.yaml (Rolling), as a user's copy holds it
ONLINE_ASYNC_FILE = Path(__file__).parent / "data" / "mapper_params_online_async.yaml"
ONLINE_ASYNC = yaml.safe_load(ONLINE_ASYNC_FILE.read_text())["slam_toolbox"]["ros__parameters"]


def _file(tmp_path, params: dict, name: str = "mapper_params_online_async.yaml", beside: dict | None = None):
    path = tmp_path / name
    path.write_text(yaml.safe_dump({**(beside or {}), "slam_toolbox": {"ros__parameters": params}}, sort_keys=False))
    return path


def test_slam_toolbox_s_own_file_is_read_key_by_key_and_the_command_line_wins(tmp_path, capsys, caplog):
    mine = {**ONLINE_ASYNC, "resolution": 0.1, "max_laser_range": 12.0, "scan_topic": "/base_scan"}
    mine |= {"map_frame": "world", "odom_frame": "wheel_odom", "minimum_travel_distance": 0.3}
    path = _file(tmp_path, mine)
    caplog.set_level(logging.WARNING, logger="navlog")  # whatever level an earlier `navlog -q` left the root at
    p = pipeline_params("mapping", path, ["slam.minimum_travel_distance=0.4"])
    # slam_toolbox's finer correlation grid is taken; the SLAM warns of it when it runs, not before
    assert caplog.text == ""
    slam_node(p)
    assert "correlation_search_space_resolution 0.01 m: the SLAM's searches cover 6.2 times the cells" in caplog.text
    assert "--set slam.correlation_search_space_resolution=0.025 for navlog's" in caplog.text
    caplog.clear()
    slam_node(pipeline_params("mapping", path, ["slam.correlation_search_space_resolution=0.025"]))
    assert caplog.text == ""
    assert (p.slam.resolution, p.slam.max_laser_range, p.slam.odom_frame) == (0.1, 12.0, "wheel_odom")
    assert p.slam.correlation_search_space_resolution == 0.01  # slam_toolbox's own value, taken as it means the same
    assert p.slam.minimum_travel_distance == 0.4  # --set over the file
    assert (p.occupancy.scan_topic, p.occupancy.map_frame, p.occupancy.transform_timeout) == (
        "/base_scan",
        "world",
        0.2,
    )
    # measured otherwise by slam_toolbox: navlog's own default stays
    assert p.slam.loop_match_maximum_variance_coarse == SlamParams.loop_match_maximum_variance_coarse == 0.01
    # the rest of the pipeline's YAML is untouched
    assert p.pose_source == "auto" and p.occupancy.grid.hit_probability == 0.7

    assert main(["check-config", "--notes", str(path)]) == 0
    out = capsys.readouterr().out
    assert "0 error(s), 0 warning(s)" in out and "checked: slam_toolbox" in out
    noted = {
        line.split("slam_toolbox.ros__parameters.")[1].split(":")[0] for line in out.splitlines() if "note:" in line
    }
    assert noted == {k for k in ONLINE_ASYNC if k in NOT_USED} | {"correlation_search_space_resolution"}
    assert "correlation_search_space_resolution: taken: the SLAM's searches cover 6.2 times the cells" in out
    assert "loop_match_maximum_variance_coarse: read, not used: slam_toolbox measures this variance otherwise" in out


def test_a_slam_toolbox_block_beside_nav2_s_nodes_is_read_and_nav2_s_left_to_their_pipelines(tmp_path, caplog):
    beside = {"amcl": {"ros__parameters": {"max_particles": "many"}}}  # an error the mapping pipeline never reads
    path = _file(tmp_path, {"resolution": 0.1}, "nav2_params.yaml", beside=beside)
    caplog.set_level(logging.WARNING, logger="navlog")
    assert pipeline_params("mapping", path).slam.resolution == 0.1
    assert caplog.text == ""  # navlog's own correlation grid: nothing to warn of


def test_a_mapping_yaml_of_navlog_s_own_is_still_read_as_one(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text("pose_source: odom\nslam:\n  resolution: 0.1\n")
    p = pipeline_params("mapping", path)
    assert (p.pose_source, p.slam.resolution, p.occupancy.scan_topic) == ("odom", 0.1, "/scan")


def test_bad_keys_and_values_are_named_with_their_lines_and_nothing_runs(tmp_path, capsys):
    path = tmp_path / "mapper.yaml"
    path.write_text(
        "slam_toolbox:\n"
        "  ros__parameters:\n"
        "    mode: localization\n"
        "    resolution: fast\n"
        "    minimum_travel_distanc: 0.3\n"
        "    correlation_search_space_resolution: 0.001\n"
        "    scan_topic: [a, b]\n"
        "    map_frame: ' '\n"
        "    transform_timeout: -1\n"
    )
    assert main(["check-config", str(path)]) == 1
    out = capsys.readouterr().out
    assert f"{path}:3: error: slam_toolbox.ros__parameters.mode: mode 'localization': navlog's SLAM maps" in out
    assert "--pipeline localization" in out
    assert f"{path}:4: error: slam_toolbox.ros__parameters.resolution: expected a number, got 'fast'" in out
    assert "(did you mean 'minimum_travel_distance'?); slam_toolbox would ignore it silently" in out
    assert "spans 8000 cells of correlation_search_space_resolution (0.001 m): at most 800" in out
    assert f"{path}:7: error: slam_toolbox.ros__parameters.scan_topic" in out
    assert f"{path}:8: error: slam_toolbox.ros__parameters.map_frame: expected a name, got ' '" in out
    assert (
        f"{path}:9: error: slam_toolbox.ros__parameters.transform_timeout: -1.0 is out of range: must be >= 0.0" in out
    )
    assert "7 error(s)" in out
    with pytest.raises(ConfigError, match=r"7 error\(s\) in the slam_toolbox parameters \(run `navlog check-config"):
        pipeline_params("mapping", path)
    path.write_text("slam_toolbox:\n  ros__parameters:\n    correlation_search_space_resolution: fast\n")
    with pytest.raises(ConfigError, match="correlation_search_space_resolution: expected a number, got 'fast'"):
        pipeline_params("mapping", path)
    # a block that is not one is slam_toolbox's error, not Nav2's
    path.write_text("slam_toolbox:\n  ros_parameters:\n    resolution: 0.1\n")
    with pytest.raises(ConfigError, match="error\\(s\\) in the slam_toolbox parameters") as raised:
        pipeline_params("mapping", path)
    assert "'ros_parameters' should be 'ros__parameters' (two underscores)" in str(raised.value)
    path.write_text("slam_toolbox: 3\n")
    with pytest.raises(ConfigError, match="1 error\\(s\\) in the slam_toolbox parameters") as raised:
        pipeline_params("mapping", path)
    assert f"{path}:1: error: slam_toolbox: expected a mapping with 'ros__parameters', got 3" in str(raised.value)


@pytest.mark.slow
def test_a_replay_maps_with_the_file_s_parameters(teleop_log, tmp_path):
    path = _file(tmp_path, {**ONLINE_ASYNC, "resolution": 0.1, "correlation_search_space_resolution": 0.025})
    out = tmp_path / "out"
    sets = ["--set", "pose_source=slam", "--set", "lidar_mapper=off"]
    assert main(["replay", str(teleop_log), "--pipeline", "mapping", "--params", str(path), *sets, "-o", str(out)]) == 0
    assert yaml.safe_load((out / "map.yaml").read_text())["resolution"] == 0.1
    assert (out / "pose_graph.json").is_file()  # the SLAM ran
    params = pipeline_params("mapping", path, ["pose_source=slam", "lidar_mapper=off", "slam.resolution=0.05"])
    run_replay(teleop_log, "mapping", tmp_path / "out2", params=params, progress=False)
    assert yaml.safe_load((tmp_path / "out2" / "map.yaml").read_text())["resolution"] == 0.05
