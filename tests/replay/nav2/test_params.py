"""Nav2 parameter files: real files load unchanged; typos, types, ranges and renames are reported."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2 import load_nav2_params, parse_nav2_text
from navlog.replay.nav2.costmap import InflationLayerParams, ObstacleLayerParams, StaticLayerParams
from navlog.replay.nav2.planners import NavfnParams

DATA = Path(__file__).resolve().parent / "data"
JAZZY_ARTICLE = Path(__file__).resolve().parents[3] / "config" / "nav2" / "simple_robot_jazzy.yaml"  # seed 001's file
EXTERNAL = ("nav2_bringup_jazzy_nav2_params.yaml", "turtlebot3_humble_waffle_nav2.yaml", "turtlebot4_humble_nav2.yaml")


def _messages(params, severity="error"):
    return {p.path: p.message for p in params.problems if p.severity == severity}


@pytest.mark.parametrize("name", EXTERNAL)
def test_external_parameter_files_load_without_errors(params_dir, name):
    params = load_nav2_params(params_dir / name)
    assert params.errors == []
    gc = params.global_costmap
    assert gc is not None and gc.global_frame == "map"
    assert isinstance(gc.layers["inflation_layer"], InflationLayerParams)
    assert isinstance(params.planner_server.planners["GridBased"], NavfnParams)
    assert "amcl" in params.not_implemented or "bt_navigator" in params.not_implemented


def test_jazzy_bringup_values(params_dir):
    p = load_nav2_params(params_dir / EXTERNAL[0])
    gc, lc = p.global_costmap, p.local_costmap
    assert gc.robot_radius == 0.22 and gc.resolution == 0.05 and gc.track_unknown_space is True
    assert gc.layers["inflation_layer"].inflation_radius == 0.7
    assert gc.layers["inflation_layer"].cost_scaling_factor == 3.0
    scan = gc.layers["obstacle_layer"].sources["scan"]
    assert (scan.data_type, scan.raytrace_max_range, scan.obstacle_max_range) == ("LaserScan", 3.0, 2.5)
    assert lc.rolling_window and (lc.width, lc.height) == (3, 3)
    assert lc.layers["voxel_layer"].is_voxel
    assert p.controller_server.controllers["FollowPath"].batch_size == 2000
    assert p.velocity_smoother.max_velocity == (0.5, 0.0, 2.0)
    assert p.collision_monitor.polygon_params["FootprintApproach"].time_before_collision == 1.2
    # the local costmap's static_layer section is not in its plugins: Nav2 ignores it
    assert "local_costmap.local_costmap.ros__parameters.static_layer" in _messages(p, "warning")


def test_turtlebot_humble_slash_plugin_names(params_dir):
    p = load_nav2_params(params_dir / "turtlebot4_humble_nav2.yaml")
    assert p.planner_server.planners["GridBased"].plugin == "nav2_navfn_planner::NavfnPlanner"
    assert p.global_costmap.resolution == 0.06 and p.global_costmap.robot_radius == 0.175


def test_jazzy_article_file_loads():
    p = load_nav2_params(JAZZY_ARTICLE)
    assert p.errors == []
    assert p.global_costmap.robot_base_frame == "simple_robot/base_link"
    assert p.global_costmap.layers["obstacle_layer"].sources["scan"].topic == "/lidar"
    assert p.local_costmap.global_frame == "simple_robot/odom"
    assert p.collision_monitor.source_params["scan"].topic == "lidar"
    assert isinstance(p.global_costmap.layers["static_layer"], StaticLayerParams)


def test_kibot_typos_are_reported_with_suggestions():
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    errors = _messages(p)
    base = "global_costmap.global_costmap.ros__parameters.obstacle_layer"
    # the misspelled plugin type is named once; its section's keys are not checked as a guessed plugin
    assert "did you mean 'nav2_costmap_2d::ObstacleLayer'?" in errors[base + ".plugin"]
    assert "its 2 other key(s) are not checked until the type is fixed" in errors[base + ".plugin"]
    assert [q for q in p.problems if q.path.startswith(base + ".")] == [
        q for q in p.problems if q.path == base + ".plugin"
    ]
    # the rest of the file is read as written
    assert p.planner_server.planners["GridBased"].tolerance == 0.10
    assert p.velocity_smoother.min_velocity == (-0.20, 0.0, -1.2)
    assert p.collision_monitor.source_params["scan"].min_height == 0.15
    with pytest.raises(ConfigError, match="ObstcaleLayer"):
        p.require_valid()
    # with the type fixed, the section's own typos come out, all at once, with line numbers
    text = (DATA / "kibot_nav2_fragments.yaml").read_text().replace("ObstcaleLayer", "ObstacleLayer")
    p = parse_nav2_text(text)
    errors = _messages(p)
    assert base + ".plugin" not in errors
    assert "did you mean 'data_type'?" in errors[base + ".scan.date_type"]
    # the missing data_type leaves Nav2's default, which it refuses
    assert "PointCloud" in errors[base + ".scan.data_type"]
    # and the per-source height trap is pointed out
    assert "0.0" in _messages(p, "warning")[base + ".scan.max_obstacle_height"]
    assert {q.path: q.line for q in p.errors}[base + ".scan.date_type"] == 19


def test_a_misspelled_plugin_type_does_not_cascade_into_its_keys():
    text = """
global_costmap:
  global_costmap:
    ros__parameters:
      plugins: ["voxel_layer"]
      voxel_layer:
        plugin: "nav2_costmap_2d::VoxelLayr"
        z_voxels: 16
        publish_voxel_map: true
        observation_sources: scan
"""
    p = parse_nav2_text(text)
    assert [(q.path, q.severity) for q in p.problems if "voxel_layer" in q.path] == [
        ("global_costmap.global_costmap.ros__parameters.voxel_layer.plugin", "error")
    ]
    (err,) = p.errors
    assert "unknown costmap layer plugin 'nav2_costmap_2d::VoxelLayr'" in err.message
    assert "did you mean 'nav2_costmap_2d::VoxelLayer'?" in err.message
    assert "its 3 other key(s) are not checked" in err.message


def test_kibot_fixed_has_no_errors():
    p = load_nav2_params(DATA / "kibot_nav2_fixed.yaml")
    assert p.errors == []
    gc = p.global_costmap
    assert gc.rolling_window and gc.width == 20 and gc.track_unknown_space is False
    assert isinstance(gc.layers["obstacle_layer"], ObstacleLayerParams)


TEMPLATE = """\
global_costmap:
  global_costmap:
    ros__parameters:
      robot_radius: 0.3
      footprint_padding: 0.0
      plugins: ["obstacle_layer", "inflation_layer"]
      obstacle_layer:
        plugin: nav2_costmap_2d::ObstacleLayer
        observation_sources: scan
        scan:
          topic: /scan
          data_type: LaserScan
          max_obstacle_height: 2.0
          {scan_extra}
      inflation_layer:
        plugin: nav2_costmap_2d::InflationLayer
        inflation_radius: {radius}
velocity_smoother:
  ros__parameters:
    max_decel: {decel}
"""


def _text(scan_extra="marking: true", radius="0.55", decel="[-2.5, 0.0, -3.2]"):
    return TEMPLATE.format(scan_extra=scan_extra, radius=radius, decel=decel)


def test_renamed_parameter():
    p = parse_nav2_text(_text(scan_extra="raytrace_range: 3.0"))
    msg = _messages(p)["global_costmap.global_costmap.ros__parameters.obstacle_layer.scan.raytrace_range"]
    assert "renamed to 'raytrace_max_range'" in msg


def test_wrong_type_and_ranges():
    p = parse_nav2_text(_text(scan_extra="clearing: 'yes'", radius="0.2", decel="[2.5, 0.0, -3.2]"))
    errors = _messages(p)
    assert (
        "expected true or false" in errors["global_costmap.global_costmap.ros__parameters.obstacle_layer.scan.clearing"]
    )
    # inscribed radius of the 16-gon of radius 0.3 is 0.3 * cos(pi/16) = 0.2942
    msg = errors["global_costmap.global_costmap.ros__parameters.inflation_layer.inflation_radius"]
    assert "below the inscribed radius 0.294" in msg
    assert "must be <= 0" in errors["velocity_smoother.ros__parameters.max_decel"]
    neg = parse_nav2_text(_text(radius="-1.0"))
    assert (
        "must be >= 0.0"
        in _messages(neg)["global_costmap.global_costmap.ros__parameters.inflation_layer.inflation_radius"]
    )


def test_misspelled_node_and_ros_parameters():
    p = parse_nav2_text(
        "planer_server:\n  ros__parameters:\n    x: 1\ncontroller_server:\n  ros_parameters:\n    a: 1\n"
    )
    errors = _messages(p)
    assert "did you mean 'planner_server'?" in errors["planer_server"]
    assert "two underscores" in errors["controller_server.ros_parameters"]


def test_malformed_yaml_names_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("planner_server:\n  ros__parameters:\n    planner_plugins: [GridBased\n    x: 1\n")
    with pytest.raises(ConfigError, match=r"bad.yaml: line \d+"):
        load_nav2_params(bad)


def test_default_checkers_without_sections_are_nav2s_simple_checkers() -> None:
    # Nav2 declares goal_checker.plugin / progress_checker.plugin with the simple checkers as defaults
    p = parse_nav2_text(
        "controller_server:\n  ros__parameters:\n    FollowPath:\n"
        "      plugin: nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController\n"
    )
    assert not p.errors
    cs = p.controller_server
    assert cs.goal_checkers["goal_checker"].plugin == "nav2_controller::SimpleGoalChecker"
    assert cs.goal_checkers["goal_checker"].xy_goal_tolerance == 0.25
    assert cs.progress_checkers["progress_checker"].plugin == "nav2_controller::SimpleProgressChecker"
    named = parse_nav2_text(
        "controller_server:\n  ros__parameters:\n    goal_checker_plugins: [precise]\n    FollowPath:\n"
        "      plugin: nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController\n"
    )
    assert any("'precise' is listed but has no 'precise:' section" in e.message for e in named.errors)


MAP_YAML = "image: map.pgm\nmode: trinary\nresolution: 0.05\norigin: [-10.0, -10.0, 0.0]\nnegate: 0\n"


def test_a_map_file_is_named_as_not_a_nav2_file(tmp_path, capsys):
    from navlog.cli import main

    f = tmp_path / "map.yaml"
    f.write_text(MAP_YAML + "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    assert main(["check-config", str(f)]) == 2
    captured = capsys.readouterr()
    assert f"{f}: not a Nav2 parameter file: it is a map_server map file (image, mode, resolution" in captured.err
    assert "warning" not in captured.out
    other = tmp_path / "robot.yaml"
    other.write_text("name: kibot\nwheels: {radius: 0.05}\n")
    with pytest.raises(ConfigError, match="not a Nav2 parameter file: no 'ros__parameters' anywhere"):
        load_nav2_params(other)


def test_a_section_the_stack_needs_is_an_error_when_missing(tmp_path, capsys):
    import yaml

    from navlog.cli import main

    nav = Path(__file__).resolve().parents[3] / "config" / "nav2" / "nav_kibot.yaml"
    doc = yaml.safe_load(nav.read_text())
    del doc["global_costmap"]
    f = tmp_path / "nav.yaml"
    f.write_text(yaml.safe_dump(doc))
    assert main(["check-config", str(f)]) == 1
    out = capsys.readouterr().out
    assert "error: global_costmap: missing section 'global_costmap': 'planner_server' needs it" in out
    assert "1 error(s)" in out
    del doc["local_costmap"], doc["planner_server"]
    f.write_text(yaml.safe_dump(doc))
    missing = {p.path for p in load_nav2_params(f).errors}
    assert missing == {"global_costmap", "local_costmap", "planner_server"}
    # a planner-only file and an AMCL-only file need nothing more
    for name in ("kibot_safety.yaml", "amcl_go2.yaml"):
        assert load_nav2_params(nav.with_name(name)).errors == []


@pytest.mark.parametrize("name", EXTERNAL[1:])
def test_a_humble_file_checked_as_humble_gets_no_jazzy_warnings(params_dir, name, capsys):
    from navlog.cli import main

    key = "controller_server.ros__parameters.progress_checker_plugin"
    jazzy = _messages(load_nav2_params(params_dir / name), "warning")
    assert "Humble name; Jazzy reads 'progress_checker_plugins'" in jazzy[key] and "--distro humble" in jazzy[key]
    humble = _messages(load_nav2_params(params_dir / name, distro="humble"), "warning")
    assert key not in humble and set(humble) == set(jazzy) - {key}
    assert main(["check-config", "--distro", "humble", str(params_dir / name)]) == 0
    assert "progress_checker_plugin" not in capsys.readouterr().out


def test_a_jazzy_file_checked_as_humble_gets_humbles_warning_and_not_the_reverse(params_dir):
    key = "controller_server.ros__parameters.progress_checker_plugins"
    jazzy_file = params_dir / EXTERNAL[0]
    assert key not in _messages(load_nav2_params(jazzy_file), "warning")
    humble = _messages(load_nav2_params(jazzy_file, distro="humble"), "warning")
    assert "the Jazzy name; Humble reads 'progress_checker_plugin'" in humble[key]


def test_humble_max_points_is_not_called_deprecated():
    text = """
collision_monitor:
  ros__parameters:
    polygons: ["FootprintApproach"]
    FootprintApproach:
      type: "polygon"
      action_type: "approach"
      footprint_topic: "/local_costmap/published_footprint"
      max_points: 3
      min_points: 4
"""
    key = "collision_monitor.ros__parameters.FootprintApproach.max_points"
    assert "deprecated max_points 3" in _messages(parse_nav2_text(text), "warning")[key]
    from navlog.replay.config import parse_yaml
    from navlog.replay.nav2.params import parse_nav2_params

    humble = parse_nav2_params(parse_yaml(text, "<t>"), distro="humble")
    assert key not in _messages(humble, "warning")
    assert "acts on more than 3 points" in _messages(humble, "note")[key]
    with pytest.raises(ConfigError, match="distro 'iron': choose one of jazzy, humble"):
        parse_nav2_params({}, distro="iron")


def test_a_file_read_again_gives_its_own_document_and_an_edited_file_its_new_values(tmp_path):
    path = tmp_path / "nav2.yaml"
    path.write_text(JAZZY_ARTICLE.read_text())
    first = load_nav2_params(path)
    radius = first.global_costmap.robot_radius
    first.raw["global_costmap"]["global_costmap"]["ros__parameters"]["robot_radius"] = 9.0  # a caller's change
    again = load_nav2_params(path)
    assert again.raw is not first.raw and again.global_costmap.robot_radius == radius
    assert again.raw["global_costmap"]["global_costmap"]["ros__parameters"]["robot_radius"] == radius
    path.write_text(path.read_text().replace(f"robot_radius: {radius}", "robot_radius: 0.4"))
    assert load_nav2_params(path).global_costmap.robot_radius == 0.4


def test_a_path_handler_list_holding_a_mapping_is_read_without_failing():
    # a mapping where a plugin name belongs (a fuzzed file): no name to look up, nothing noted for it
    p = parse_nav2_text(
        "controller_server:\n  ros__parameters:\n    path_handler_plugins: [{a: 1}, 'PathHandler']\n"
        "    PathHandler:\n      plugin: 'nav2_controller::FeasiblePathHandler'\n"
    )
    notes = _messages(p, "note")
    assert any("path handler 'nav2_controller::FeasiblePathHandler'" in m for m in notes.values())


def test_a_footprint_reaching_beyond_the_bound_is_an_error_naming_its_key(params_dir):
    """robot_radius 1e300 (or a footprint_padding of 1e9) passed the checks, and a recording then grew to 24 GB
    rasterising the footprint's outline: the padded footprint's reach is bounded (50 m) and named by its key."""
    text = (params_dir.parent / "nav2_bringup" / "params" / "nav2_params.yaml").read_text()
    assert text.count("robot_radius: 0.22") == 2
    local = "local_costmap.local_costmap.ros__parameters.robot_radius"
    errors = _messages(parse_nav2_text(text.replace("robot_radius: 0.22", "robot_radius: 1.0e+300", 1)))
    assert list(errors) == [local] and "reaches 1e+300 m" in errors[local] and "bound is 50 m" in errors[local]
    padded = text.replace("robot_radius: 0.22", "robot_radius: 0.22\n      footprint_padding: 40.0", 1)
    errors = _messages(parse_nav2_text(padded))
    assert list(errors) == [local] and "reaches 56.7885 m" in errors[local]  # 0.22 + 40 sqrt(2)
    square = text.replace("robot_radius: 0.22", "footprint: '[[40.0, 40.0], [40.0, -40.0], [-40.0, -40.0]]'", 1)
    errors = _messages(parse_nav2_text(square))
    assert "reaches 56.5827 m" in errors["local_costmap.local_costmap.ros__parameters.footprint"]
    assert local not in _messages(parse_nav2_text(text.replace("robot_radius: 0.22", "robot_radius: 49.9", 1)))
    nan = text.replace("robot_radius: 0.22", "footprint: '[[0.3, 0.2], [.nan, -0.2], [-0.3, -0.2]]'", 1)
    assert "reaches nan m" in _messages(parse_nav2_text(nan))["local_costmap.local_costmap.ros__parameters.footprint"]


def test_values_navlog_does_not_act_on_are_warnings_when_set_away_from_their_defaults(params_dir):
    """collision_monitor enabled: false and planner_server allow_partial_planning: true (Nav2 after Jazzy) change
    what Nav2 does; navlog reads them without acting on them, so it says so as warnings (their defaults stay
    notes)."""
    text = (params_dir.parent / "nav2_bringup" / "params" / "nav2_params.yaml").read_text()
    assert "collision_monitor:\n  ros__parameters:\n    enabled: true\n" in text
    assert text.count("allow_partial_planning: false") == 1
    warnings = _messages(parse_nav2_text(text), "warning")
    assert "collision_monitor.ros__parameters.enabled" not in warnings
    changed = text.replace("allow_partial_planning: false", "allow_partial_planning: true")
    changed = changed.replace(
        "collision_monitor:\n  ros__parameters:\n    enabled: true\n",
        "collision_monitor:\n  ros__parameters:\n    enabled: false\n",
    )
    warnings = _messages(parse_nav2_text(changed), "warning")
    assert "--set collision_monitor=off" in warnings["collision_monitor.ros__parameters.enabled"]
    assert "fail such a goal" in warnings["planner_server.ros__parameters.allow_partial_planning"]
