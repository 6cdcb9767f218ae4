"""A seeded subset of the fuzz campaign (``fuzz/campaign.py``), and one regression test per defect it found.

The campaign's promise: bad input gives a ``NavlogError`` or a counted skip, never a traceback or a hang.
"""

from __future__ import annotations

import importlib.util
import io
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer

from navlog.errors import ConfigError, LogError, NavlogError

REPO = Path(__file__).resolve().parents[1]


def load_campaign():
    spec = importlib.util.spec_from_file_location("fuzz_campaign", REPO / "fuzz" / "campaign.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the file executes
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def campaign_and_seeds(tmp_path_factory, shared_dir):
    """The campaign module, its seeds (the external data's bags and Nav2 files among them) and its folder."""
    campaign = load_campaign()
    folder = tmp_path_factory.mktemp("fuzz")
    return campaign, campaign.load_seeds(folder / "seeds", shared_dir), folder


EVERY_KIND_SEED = 116  # its first ``EVERY_KIND_CASES`` cases draw every kind of ``KINDS``
EVERY_KIND_CASES = 250


@pytest.mark.slow
def test_seeded_subset_has_no_traceback_and_no_hang(campaign_and_seeds, shared_dir: Path) -> None:
    campaign, _, folder = campaign_and_seeds
    result = campaign.run_campaign(
        EVERY_KIND_CASES, EVERY_KIND_SEED, folder, shared=shared_dir, workers=2, timeout=20.0
    )
    totals = result.totals
    assert totals["TRACEBACK"] == 0 and totals["HANG"] == 0 and totals["CRASH"] == 0, result.failures
    assert sum(totals.values()) == result.cases == EVERY_KIND_CASES
    # the oracle tells outcomes apart: mutated inputs are refused cleanly, corrupt messages are counted
    assert totals["CLEAN_ERROR"] > 50 and totals["OK"] > 50 and totals["COUNTED_SKIP"] > 0
    assert set(result.by_kind) == set(campaign.KINDS)  # every kind drawn, record and replay runs too
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["cases"] == summary["drawn"] == EVERY_KIND_CASES and summary["outcomes"] == dict(
        sorted(totals.items())
    )


def test_a_case_that_kills_its_worker_is_a_crash_and_the_campaign_goes_on(
    campaign_and_seeds, monkeypatch, shared_dir: Path
) -> None:
    # case 2 dies of a signal inside its call (as a segfault in C code does): the campaign records a CRASH with
    # a reproducer, starts another worker and runs the other cases
    import os
    import signal

    campaign, _, folder = campaign_and_seeds
    run_case = campaign.run_case

    def dying(case, seeds, timeout):
        if case.index == 2:
            os.kill(os.getpid(), signal.SIGSEGV)
        return run_case(case, seeds, timeout)

    monkeypatch.setattr(campaign, "run_case", dying)  # the workers are forked after this
    out = folder / "crash"
    result = campaign.run_campaign(6, EVERY_KIND_SEED, out, shared=shared_dir, workers=2, timeout=20.0)
    assert result.cases == 6 and result.totals["CRASH"] == 1
    assert [(f["index"], f["outcome"]) for f in result.failures] == [(2, "CRASH")]
    assert "exit code -11" in result.failures[0]["error"]
    assert [p.name.split("-")[0] for p in (out / "repro").iterdir()] == ["000002"]


def text(case) -> str:
    """A recipe as JSON text (NaN compares equal to NaN there)."""
    return json.dumps(case.recipe)


@pytest.mark.slow
def test_case_i_depends_only_on_the_seed_and_i(campaign_and_seeds, shared_dir: Path) -> None:
    campaign, seeds, _ = campaign_and_seeds
    drawn: list = []
    assert campaign.generate(3, 120, seeds, drawn.append) == 120
    again: list = []
    campaign.generate(3, 15, seeds, again.append, start=103)  # another count, another start
    assert [(c.index, text(c)) for c in again] == [(c.index, text(c)) for c in drawn[103:118]]
    assert text(campaign.case_at(3, 57, seeds)) == text(drawn[57])
    # nor on what the process ran before: a fresh one that has imported no navlog module draws the same
    script = (
        "import json, sys; sys.path.insert(0, sys.argv[1]); import campaign; from pathlib import Path; "
        "print(json.dumps(campaign.case_at(3, 57, campaign.load_seeds(Path(sys.argv[2]), Path(sys.argv[3]))).recipe))"
    )
    fresh = subprocess.run(
        [sys.executable, "-c", script, str(REPO / "fuzz"), str(seeds.folder), str(shared_dir)],
        capture_output=True,
        text=True,
    )
    assert fresh.returncode == 0, fresh.stderr
    assert fresh.stdout.strip() == text(drawn[57])
    other: list = []
    campaign.generate(4, 20, seeds, other.append)
    assert [text(c) for c in other] != [text(c) for c in drawn[:20]]
    assert len({text(c) for c in drawn}) > 100  # few repeats (each block starts simple)


def test_a_recipe_applies_to_the_same_bytes_every_time(campaign_and_seeds) -> None:
    campaign, seeds, _ = campaign_and_seeds
    drawn = collect(campaign, seeds, EVERY_KIND_CASES)  # every kind among them
    for kind in campaign.KINDS:
        case = next(c for c in drawn if c.kind == kind)
        a, b = campaign.build(case, seeds), campaign.build(case, seeds)
        assert (a.mutation, a.call, a.args, a.files) == (b.mutation, b.call, b.args, b.files)


def collect(campaign, seeds, count: int) -> list:
    drawn: list = []
    campaign.generate(EVERY_KIND_SEED, count, seeds, drawn.append)
    return drawn


def test_reordered_records_inside_a_compressed_chunk_stay_a_valid_chunk(campaign_and_seeds) -> None:
    """The chunk mutation recompresses what it reorders: with its CRC fixed and no summary, a reader
    streams the chunk and finds every message of it, duplicated ones twice."""
    from mcap.reader import make_reader

    campaign, seeds, _ = campaign_and_seeds
    data = seeds.logs["seed_zstd"]
    recipe = {"chunk": 1, "op": "duplicate", "i": 5, "j": 0, "order": 0, "crc": "fixed", "summary": "none"}
    name, mutated = campaign.mutate_chunk(recipe, data, seeds.records["seed_zstd"])
    assert name == "chunk-duplicate-crc-fixed-summary-none"
    before = sum(1 for _ in make_reader(io.BytesIO(data)).iter_messages())
    reader = make_reader(io.BytesIO(mutated), validate_crcs=True)
    assert reader.get_summary() is None
    assert sum(1 for _ in reader.iter_messages()) == before + 1  # record 5 of chunk 1 is a message: twice


def test_a_saved_reproducer_reruns_from_its_case_json(campaign_and_seeds, tmp_path: Path) -> None:
    campaign, seeds, _ = campaign_and_seeds
    case = campaign.Case(0, "mcap-bytes", {"log": "seed_zstd", "op": "truncate@random", "at": 2**31, "call": "read"})
    outcome, trace, built = campaign.run_case(case, seeds, 20.0)
    assert (outcome, trace) == ("CLEAN_ERROR", "")  # a truncated log without --recover: TruncatedLogError
    folder = campaign.save_repro(case, built, "TRACEBACK", "made up", tmp_path, 5)
    meta = json.loads((folder / "case.json").read_text())
    assert meta["recipe"] == case.recipe and meta["mutation"] == "seed_zstd:truncate@random"
    assert (folder / "log.mcap").stat().st_size == len(seeds.logs["seed_zstd"]) // 2


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


@pytest.mark.parametrize(
    ("metadata", "message"),
    [
        (b"\xff\xfe binary", "not a YAML text file"),
        (b"- a\n- b\n", "expected a 'rosbag2_bagfile_information' mapping"),
    ],
)
def test_broken_rosbag2_metadata_is_a_log_error(bags_dir: Path, tmp_path: Path, metadata: bytes, message: str) -> None:
    from navlog.replay.io.formats import open_log

    bag = tmp_path / "bag"
    shutil.copytree(bags_dir / "rosbag2_talker_mcap", bag)
    (bag / "metadata.yaml").write_bytes(metadata)
    with pytest.raises(LogError, match=message):
        open_log(bag)


def test_rosbag2_metadata_with_a_numeric_topic_name_is_a_log_error(bags_dir: Path, tmp_path: Path) -> None:
    from navlog.replay.io.formats import open_log

    bag = tmp_path / "bag"
    shutil.copytree(bags_dir / "neato_drive_square", bag)  # sqlite3 storage: topics come from metadata.yaml
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
    with pytest.raises(ConfigError) as info:
        params.require_valid()
    for key, got in (("goal_checker_plugins", r"\[\['general_goal_checker'\]\]"), ("progress_checker_plugins", "1.5")):
        assert re.search(f"{key}: expected a list of strings, got {got}", str(info.value)), key


def test_replay_into_an_output_that_is_a_file_is_refused(tmp_path: Path) -> None:
    from navlog.replay.session import run_replay

    out = tmp_path / "taken.mcap"
    out.write_bytes(b"someone's file")
    with pytest.raises(NavlogError, match="taken.mcap: output is a file, not a folder"):
        run_replay(tmp_path / "missing.mcap", "mapping", out, force=True, progress=False)
    assert out.read_bytes() == b"someone's file"


# cases of the campaign (seed 1) that raised: a /odom/ground_truth pose at -1.6e202 m grew the map grid
# to an impossible size; an infinite /scan angle field made every beam NaN; a suite tolerance key that
# YAML reads as a number could not be sorted with the others.
MAPPING_CASES = {
    "pose far off": {
        "channel": 2,
        "first": 2,
        "leaves": [
            {"leaf": 1897, "float": -1.633315426981561e202, "int": 0, "array": "half", "text": ""},
            {"leaf": 708, "float": 5.752544829890466e16, "int": 0, "array": "half", "text": ""},
        ],
        "special": None,
        "call": "replay-mapping",
    },
    "infinite angle": {
        "channel": 6,
        "first": None,
        "leaves": [
            {"leaf": 3875, "float": -math.inf, "int": 3875, "array": "half", "text": ""},
            {"leaf": 8056, "float": -math.inf, "int": 0, "array": "nan", "text": ""},
        ],
        "special": "stamp-past",
        "call": "replay-mapping",
    },
}


def replay_mapping(campaign, seeds, recipe: dict, folder: Path) -> int:
    campaign.materialize(campaign.build(campaign.Case(0, "mcap-message", recipe), seeds), folder)
    from navlog.cli import main

    return main(["-q", "replay", str(folder / "log.mcap"), "--pipeline", "mapping", "-o", str(folder / "out")])


def test_a_scan_whose_pose_is_far_off_is_a_counted_skip(campaign_and_seeds, tmp_path: Path) -> None:
    campaign, seeds, _ = campaign_and_seeds
    assert replay_mapping(campaign, seeds, MAPPING_CASES["pose far off"], tmp_path) == 0
    skipped = json.loads((tmp_path / "out" / "manifest.json").read_text())["skipped"]
    # the ground-truth pose 1.6e202 m away is left out of the TF tree (farther than any frame), so the scan at its
    # stamp has no pose
    far = "transform __pose_origin__ -> base_link not finite, farther than 1e+08 m or with a zero rotation (ignored)"
    assert skipped[f"/odom/ground_truth: {far}"] == 2
    assert skipped["/scan: no pose or transform at the scan's stamp"] == 1


ODOM_NAN_ORIENTATION = {  # case 9648 of seed 1: /odom with a NaN quaternion component made SciPy raise
    "channel": 3,
    "first": None,
    "leaves": [
        {"leaf": 2556, "float": -0.0, "int": 0, "array": "empty", "text": ""},
        {"leaf": 1824, "float": -5.842226606658513e16, "int": 4294967295, "array": "double", "text": ""},
        {"leaf": 40320, "float": -1e308, "int": 1, "array": "inf", "text": "/"},
        {"leaf": 100000, "float": math.nan, "int": 776385, "array": "nan", "text": ""},
    ],
    "special": "stamp-future",
    "call": "replay-mapping",
}


def test_odometry_with_a_nan_orientation_is_a_counted_skip(campaign_and_seeds, tmp_path: Path) -> None:
    campaign, seeds, _ = campaign_and_seeds
    assert replay_mapping(campaign, seeds, ODOM_NAN_ORIENTATION, tmp_path) == 0
    skipped = json.loads((tmp_path / "out" / "manifest.json").read_text())["skipped"]
    assert skipped["lidar_mapper: odom_not_finite"] == 51  # every /odom message of the seed log


ODOM_LONG_QUATERNION = {  # case 1265 of seed 13: a quaternion whose norm overflows normalised to no rotation at all
    "channel": 3,
    "first": None,
    "leaves": [
        {"leaf": 347, "float": 4.06895965601743e304, "int": 0, "array": "inf", "text": "\u00a4["},
        {"leaf": 220, "float": math.inf, "int": 2147483647, "array": "inf", "text": ";"},
        {"leaf": 323, "float": 3.4e38, "int": 36746, "array": "half", "text": "?\b\u00de\u00bf"},
        {"leaf": 99520, "float": -2.96193785483411e166, "int": 251, "array": "half", "text": "map"},
    ],
    "special": None,
    "call": "replay-mapping",
}


@pytest.mark.parametrize(
    ("recipe", "reason"),
    [
        (ODOM_LONG_QUATERNION, "odom_orientation_invalid"),
        # the odometry's x (leaf 6 of an Odometry message) 4e304 m out: interpolating between two such poses overflows
        (
            {**ODOM_LONG_QUATERNION, "leaves": [{"leaf": 6, "float": 4e304, "int": 0, "array": "inf", "text": ""}]},
            "odom_far",
        ),
    ],
)
def test_odometry_no_robot_could_report_is_a_counted_skip(campaign_and_seeds, tmp_path: Path, recipe, reason) -> None:
    campaign, seeds, _ = campaign_and_seeds
    assert replay_mapping(campaign, seeds, recipe, tmp_path) == 0
    skipped = json.loads((tmp_path / "out" / "manifest.json").read_text())["skipped"]
    assert skipped[f"lidar_mapper: {reason}"] == 51  # every /odom message of the seed log


def test_transforms_whose_rotation_overflows_are_a_counted_skip(campaign_and_seeds, tmp_path: Path, capsys) -> None:
    campaign, seeds, _ = campaign_and_seeds
    # leaf 11 of a TFMessage: the first transform's rotation x, on every /tf message (channel 4)
    recipe = {**ODOM_LONG_QUATERNION, "channel": 4, "leaves": [{**ODOM_LONG_QUATERNION["leaves"][3], "leaf": 11}]}
    assert replay_mapping(campaign, seeds, recipe, tmp_path) == 0
    capsys.readouterr()
    skipped = json.loads((tmp_path / "out" / "manifest.json").read_text())["skipped"]
    # its norm squares past the float range: once taken as no rotation at all, now left out and counted
    reason = "/tf: transform map -> odom not finite, farther than 1e+08 m or with a zero rotation (ignored)"
    assert skipped[reason] == 51
    # the view leaves the same samples out of its drawing: map -> odom had no other, so no edge is drawn
    from navlog.cli import main
    from tests.analysis.view.rrd import read_rrd

    rrd = tmp_path / "v.rrd"
    assert main(["-q", "view", str(tmp_path / "log.mcap"), "--save", str(rrd), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["skipped"][reason] == 51
    drawn = read_rrd(rrd)
    assert "/tf/odom" not in drawn and "/tf/base_footprint" in drawn


@pytest.mark.parametrize(("message", "code"), [(0, 2), (300, 0)])
def test_log_times_past_a_signed_64_bit_count_are_not_drawn_and_are_counted(
    campaign_and_seeds, tmp_path: Path, capsys, message: int, code: int
) -> None:
    # case 1118 of seed 15: every log time from message ``message`` on moved past 2^63 ns (the year 2262), which
    # the view's int64 times could not hold (OverflowError). From the first message: nothing to draw, and why.
    # From a later one, the log reader drops them as a jump (more than an hour past the message before).
    campaign, seeds, _ = campaign_and_seeds
    recipe = {"kind": "mcap-times", "form": "jump-run", "message": message, "bit": 63, "call": "cli-view"}
    campaign.materialize(campaign.build(campaign.Case(0, "mcap-times", recipe), seeds), tmp_path)
    from navlog.cli import main

    assert main(["-q", "view", str(tmp_path / "log.mcap"), "--save", str(tmp_path / "v.rrd"), "--json"]) == code
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    reason = "/imu/data: log time past the year 2262 or 292 years from the first message (not drawn)"
    if code:
        assert "nothing to draw" in err and f"{reason} x201" in err  # every /imu/data message
    else:
        summary = json.loads(out)
        jumped = "messages whose log time jumps more than an hour past the message before (corrupt log time)"
        assert summary["skipped"] == {jumped: 150} and summary["messages"] == 238


def test_scans_with_infinite_angles_are_skipped_and_named(campaign_and_seeds, tmp_path: Path, capsys) -> None:
    campaign, seeds, _ = campaign_and_seeds
    assert replay_mapping(campaign, seeds, MAPPING_CASES["infinite angle"], tmp_path) == 2
    err = capsys.readouterr().err
    assert "produced nothing: no map" in err and "/scan: NaN or infinite angle/range fields x11" in err
    assert "Traceback" not in err


def test_the_grid_refuses_to_grow_to_reach_a_pose_far_off() -> None:
    from navlog.replay.mapping.occupancy import GridTooLarge, OccupancyGrid2D, OccupancyParams

    grid = OccupancyGrid2D(OccupancyParams(resolution=0.05))
    pose = np.eye(4)
    angles, ranges = np.linspace(-1.0, 1.0, 5), np.full(5, 2.0)
    grid.insert_scan(pose, angles, ranges, 0.1, 10.0)
    assert grid.logodds.shape == (200, 100)  # 5 m x 10 m blocks at 5 cm
    pose[0, 3] = -1.6e202
    with pytest.raises(GridTooLarge, match="the grid would span"):
        grid.insert_scan(pose, angles, ranges, 0.1, 10.0)
    assert grid.logodds.shape == (200, 100)  # nothing changed
    pose[0, 3] = 1000.0  # 1 km along x: the grid grows to reach it
    grid.insert_scan(pose, angles, ranges, 0.1, 10.0)
    assert grid.logodds.shape == (200, 20_100)


def test_suite_tolerance_keys_that_yaml_reads_as_numbers_are_reported(tmp_path: Path) -> None:
    from navlog.analysis.ci.suite import load_suite

    suite = tmp_path / "s.yaml"
    suite.write_text(
        "name: s\ncases:\n  - name: c\n    log: x.mcap\n    pipeline: mapping\n"
        "    checks:\n      - diff: {tolerances: {grid.changed_share: 0.1, 7: 1}}\n"
    )
    with pytest.raises(ConfigError, match=r"tolerances.*7"):
        load_suite(suite)
