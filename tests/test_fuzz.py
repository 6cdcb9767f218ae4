"""A seeded subset of the fuzz campaign (``fuzz/campaign.py``), and one regression test per defect it found.

The campaign's promise: bad input gives a ``NavlogError`` or a counted skip, never a traceback or a hang.
"""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import pytest
from mcap.writer import Writer

from navlog.errors import ConfigError, LogError, NavlogError

REPO = Path(__file__).resolve().parents[1]
BAGS = Path("/work/shared/external-data/bags")
TALKER = BAGS / "rosbag2_talker_mcap"
NEATO = BAGS / "neato_drive_square"  # sqlite3 storage: topics come from metadata.yaml


def load_campaign():
    spec = importlib.util.spec_from_file_location("fuzz_campaign", REPO / "fuzz" / "campaign.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the file executes
    spec.loader.exec_module(module)
    return module


def test_seeded_subset_has_no_traceback_and_no_hang(tmp_path: Path) -> None:
    campaign = load_campaign()
    result = campaign.run_campaign(200, 7, tmp_path, workers=2, timeout=20.0)
    totals = result.totals
    assert totals["TRACEBACK"] == 0 and totals["HANG"] == 0, result.failures
    assert sum(totals.values()) == 200
    # the oracle tells outcomes apart: mutated inputs are refused cleanly, corrupt messages are counted
    assert totals["CLEAN_ERROR"] > 50 and totals["OK"] > 20 and totals["COUNTED_SKIP"] > 0
    assert {"mcap-bytes", "mcap-semantic", "cli", "config-nav2"} <= set(result.by_kind)
    assert (tmp_path / "summary.json").is_file()


def test_cases_are_repeatable(tmp_path: Path) -> None:
    campaign = load_campaign()
    seeds = campaign.load_seeds(campaign.build_seed_log(tmp_path / "seeds"))
    a, b = campaign.make_case(3, 11, seeds), campaign.make_case(3, 11, seeds)
    assert (a.kind, a.mutation, a.call, a.args, a.files) == (b.kind, b.mutation, b.call, b.args, b.files)


# ------------------------------------------------------------------- regressions found by the campaign


def test_self_referencing_yaml_alias_is_a_config_error(tmp_path: Path) -> None:
    from navlog.recorder.world import load_world

    world = tmp_path / "w.yaml"
    world.write_text("a: &a [*a]\nname: w\n")
    with pytest.raises(ConfigError, match="alias refers to a node that contains it"):
        load_world(str(world))


def test_suggest_accepts_keys_that_yaml_read_as_numbers() -> None:
    from navlog.replay.config import suggest

    assert suggest(12, ["123", "abc"]) == " (did you mean '123'?)"


def test_override_with_malformed_yaml_value_is_a_config_error() -> None:
    from navlog.replay.config import apply_overrides

    with pytest.raises(ConfigError, match=r"override 'a=\[1'"):
        apply_overrides({"a": 1}, ["a=[1"])
    with pytest.raises(ConfigError, match="not a mapping"):
        apply_overrides([1, 2], ["a=1"])  # type: ignore[arg-type]


@pytest.mark.skipif(not TALKER.is_dir(), reason="external bag not available")
@pytest.mark.parametrize(
    ("metadata", "message"),
    [
        (b"\xff\xfe binary", "not a YAML text file"),
        (b"- a\n- b\n", "expected a 'rosbag2_bagfile_information' mapping"),
    ],
)
def test_broken_rosbag2_metadata_is_a_log_error(tmp_path: Path, metadata: bytes, message: str) -> None:
    from navlog.replay.io.formats import open_log

    bag = tmp_path / "bag"
    shutil.copytree(TALKER, bag)
    (bag / "metadata.yaml").write_bytes(metadata)
    with pytest.raises(LogError, match=message):
        open_log(bag)


@pytest.mark.skipif(not NEATO.is_dir(), reason="external bag not available")
def test_rosbag2_metadata_with_a_numeric_topic_name_is_a_log_error(tmp_path: Path) -> None:
    from navlog.replay.io.formats import open_log

    bag = tmp_path / "bag"
    shutil.copytree(NEATO, bag)
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace("name: /odom", "name: 1.5", 1))
    with pytest.raises(LogError, match="malformed rosbag2 metadata"):
        open_log(bag)


def test_schema_text_that_is_not_utf8_makes_a_counted_skip(tmp_path: Path) -> None:
    from navlog.replay.io.formats import open_log

    path = tmp_path / "bad_schema.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="test")
        sid = w.register_schema("my_msgs/msg/Thing", "ros2msg", b"\xff\xfe string data")
        cid = w.register_channel("/chatter", "cdr", sid)
        w.add_message(cid, 1, b"\x00\x01\x00\x00\x02\x00\x00\x00a\x00", 1)
        w.finish()
    with open_log(path) as reader:
        assert list(reader.messages()) == []
        assert reader.report.skipped == {"unknown type my_msgs/msg/Thing on /chatter": 1}


def test_output_that_is_a_folder_is_refused(tmp_path: Path) -> None:
    from navlog.replay.io.logwriter import check_output

    with pytest.raises(NavlogError, match="is a folder"):
        check_output(tmp_path, force=True)


def test_plan_refuses_non_finite_poses(capsys: pytest.CaptureFixture[str]) -> None:
    from navlog.cli import main

    assert main(["plan", "--map", "missing.yaml", "--start=inf,0,0", "--goal=1,1,0"]) == 2
    assert "--start 'inf,0,0': expected x,y[,yaw]" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"waypoints": [[1e308, 0.0], [1.0, 1.0]]}, "within 100 km"),
        ({"kind": "teleop", "commands": [{"duration": 1e4, "cmd": [0.1, 0.0, 0.0]}]}, "durations must be"),
    ],
)
def test_scenario_with_absurd_numbers_is_a_config_error(tmp_path: Path, change: dict, message: str) -> None:
    import yaml

    from navlog.recorder.scenarios import load_scenario

    spec = {"name": "s", "kind": "tour", "start": [0.0, 0.0, 0.0], "waypoints": [[1.0, 0.0]], **change}
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(spec))
    with pytest.raises(ConfigError, match=message):
        load_scenario(str(path))


def test_world_with_infinite_yaw_is_a_config_error(tmp_path: Path) -> None:
    import yaml

    from navlog.recorder.world import load_world

    spec = yaml.safe_load((REPO / "config/worlds/indoor_room.yaml").read_text())
    spec["objects"][0]["pose"][2] = float("inf")
    path = tmp_path / "w.yaml"
    path.write_text(yaml.safe_dump(spec))
    with pytest.raises(ConfigError, match="finite"):
        load_world(str(path))


def test_world_map_refuses_a_grid_too_large_to_allocate() -> None:
    from navlog.recorder.world import load_world, occupancy

    with pytest.raises(ConfigError, match="too large"):
        occupancy(load_world("indoor_room"), resolution=1e-6)
    with pytest.raises(ConfigError, match="resolution must be positive"):
        occupancy(load_world("indoor_room"), resolution=float("nan"))


NAV2_BAD_NAMES = """\
controller_server:
  ros__parameters:
    controller_plugins: ["FollowPath"]
    goal_checker_plugins: [[general_goal_checker]]
    progress_checker_plugins: 1.5
    FollowPath:
      plugin: "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
collision_monitor:
  ros__parameters:
    polygons: [[FootprintApproach]]
    observation_sources: [scan, 3]
    scan:
      type: scan
      topic: /scan
"""


def test_nav2_plugin_names_that_are_not_strings_are_reported(tmp_path: Path) -> None:
    from navlog.replay.nav2.params import load_nav2_params

    path = tmp_path / "nav2.yaml"
    path.write_text(NAV2_BAD_NAMES)
    params = load_nav2_params(path)
    with pytest.raises(ConfigError, match="goal checker names must be strings"):
        params.require_valid()
