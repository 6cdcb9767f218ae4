"""navlog diff on real replays and logs: a 17 s teleop recording of go2 in indoor_room (seed 3),
replayed through the 2D mapping pipeline twice with the same parameters and once at another
resolution; the same scenario recorded with another seed; bad input."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from navlog.analysis.diff import DiffTolerances, Verdict, diff, parse_tolerances, to_json, to_markdown
from navlog.cli import main
from navlog.errors import NavlogError

pytestmark = pytest.mark.slow

MAPPING_2D = ["lidar_mapper=off"]


@pytest.fixture(scope="module")
def replays(teleop_log: Path, tmp_path_factory) -> dict[str, Path]:
    from navlog.replay.session import run_replay

    root = tmp_path_factory.mktemp("diff-replays")
    runs = {
        "a": MAPPING_2D,
        "a_again": MAPPING_2D,
        "coarse": [*MAPPING_2D, "occupancy.grid.resolution=0.1"],
    }
    for name, overrides in runs.items():
        run_replay(teleop_log, "mapping", root / name, overrides=overrides, progress=False)
    return {name: root / name for name in runs}


def test_two_replays_with_the_same_parameters_are_equal(replays, capsys):
    report = diff(replays["a"], replays["a_again"])
    assert report.kind == "replay" and report.passed
    assert {c.name for c in report.checks} == {"map.yaml", "replay.mcap", "trajectory.tum"}
    assert all(c.verdict is Verdict.EQUAL and c.kind == "bytes" for c in report.checks)
    assert report.first_divergence is None and report.notes == ()
    assert main(["diff", str(replays["a"]), str(replays["a_again"])]) == 0
    assert capsys.readouterr().out.startswith("PASS:")


def test_another_map_resolution_changes_the_map_and_nothing_else(replays):
    report = diff(replays["a"], replays["coarse"])
    assert not report.passed and report.exit_code == 1
    grid = report.check("map.yaml")
    assert grid.verdict is Verdict.CHANGED and grid.kind == "grid"
    # measured: 1678 of 160,000 cells (1.05 %) change class between the 0.05 m and 0.1 m maps
    assert 0.005 < grid.values["changed_share"] < 0.02
    assert grid.values["resolution_a"] == 0.05 and grid.values["resolution_b"] == 0.1
    assert 0.3 < grid.values["iou"] < 0.8
    assert grid.values["hausdorff_m"] == pytest.approx(0.1, abs=0.051)
    topic = report.check("/map")
    assert topic.verdict is Verdict.CHANGED and topic.values["messages_a"] == topic.values["messages_b"] == 10
    assert report.check("trajectory.tum").verdict is Verdict.EQUAL  # same poses, same scans inserted
    div = report.first_divergence
    assert div is not None and div.topic == "/map" and div.index == 0 and div.field == "info.resolution"
    assert float(div.old) == pytest.approx(0.05) and float(div.new) == pytest.approx(0.1)
    assert report.notes == ("parameter occupancy.grid.resolution: 0.05 -> 0.1",)
    # a tolerance wide enough passes it, and --ignore drops what it names
    loose = parse_tolerances(["grid.changed_share=0.05", "grid.hausdorff_m=0.2"])
    assert diff(replays["a"], replays["coarse"], tolerances=loose).passed
    ignored = diff(replays["a"], replays["coarse"], ignore=["map.yaml", "/map"])
    assert ignored.passed and set(ignored.ignored) == {"/map", "map.yaml"}


def test_reports_are_deterministic_and_regressions_come_first(replays, tmp_path, capsys):
    out1, out2, md = tmp_path / "1.json", tmp_path / "2.json", tmp_path / "d.md"
    args = ["diff", str(replays["a"]), str(replays["coarse"])]
    assert main([*args, "--json", str(out1), "--markdown", str(md)]) == 1
    assert main([*args, "--json", str(out2)]) == 1
    assert out1.read_bytes() == out2.read_bytes()
    # existing report files need --force (one rule for every command); without it nothing is written
    for option, path in (("--json", out2), ("--markdown", md), ("--rrd", out1)):
        before = path.read_bytes()
        assert main([*args, option, str(path)]) == 2
        assert f"{path}: already exists; choose another name or pass --force" in capsys.readouterr().err
        assert path.read_bytes() == before
    assert main([*args, "--json", str(out2), "--markdown", str(md), "--force"]) == 1
    assert out1.read_bytes() == out2.read_bytes()
    data = json.loads(out1.read_text())
    assert data["passed"] is False and data["first_divergence"]["topic"] == "/map"
    assert data["counts"] == {"CHANGED": 2, "EQUAL": 1, "IMPROVED": 0, "REGRESSED": 0, "WITHIN": 0}
    text = md.read_text()
    assert text.startswith("### navlog diff: FAIL")
    assert text.index("| CHANGED | `map.yaml`") < text.index("1 equal (same bytes")
    out = capsys.readouterr().out
    assert "first divergence: /map[0]" in out and "CHANGED   map.yaml" in out


def test_metrics_json_beside_the_outputs_is_judged_by_direction(replays, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    shutil.copytree(replays["a"], a)
    shutil.copytree(replays["a"], b)
    base = {"trajectory": {"ate": {"translation_m": {"rmse": 0.02}}}, "map_2d": {"f1": 0.95, "iou": 0.6}}
    (a / "metrics.json").write_text(json.dumps(base))
    better = json.loads(json.dumps(base))
    better["trajectory"]["ate"]["translation_m"]["rmse"] = 0.015
    (b / "metrics.json").write_text(json.dumps(better))
    report = diff(a, b)
    assert report.passed and report.check("metrics.json:trajectory.ate.translation_m.rmse").verdict is Verdict.IMPROVED
    worse = json.loads(json.dumps(better))
    worse["map_2d"]["f1"] = 0.9
    (b / "metrics.json").write_text(json.dumps(worse))
    report = diff(a, b)
    assert not report.passed and report.check("metrics.json:map_2d.f1").verdict is Verdict.REGRESSED


def test_two_logs_of_other_seeds_differ_in_the_noisy_sensors_only(teleop_log, tmp_path):
    from navlog.recorder.record import prepare, record

    other = tmp_path / "seed4.mcap"
    record(prepare("indoor_room", "go2", "teleop", seed=4), other, progress=False)
    same = diff(teleop_log, teleop_log)
    assert same.kind == "log" and same.passed and all(c.verdict is Verdict.EQUAL for c in same.checks)
    report = diff(teleop_log, other)
    verdicts = {c.name: c.verdict for c in report.checks}
    # the commands and the true motion do not depend on the seed; the noise does
    assert verdicts["/cmd_vel"] is Verdict.EQUAL and verdicts["/odom/ground_truth"] is Verdict.EQUAL
    assert verdicts["/scan"] is Verdict.CHANGED and verdicts["/imu/data"] is Verdict.CHANGED
    odom = report.check("/odom")
    assert odom.kind == "trajectory" and 0.0 < odom.values["ate_m"] < 0.05  # measured 0.0096 m
    assert report.first_divergence is not None and report.first_divergence.index == 0
    # the IMU is the first noisy topic at the first instant; ignoring it moves the divergence on
    assert report.first_divergence.topic == "/imu/data"
    later = diff(teleop_log, other, ignore=["/imu/data"])
    assert later.first_divergence is not None and later.first_divergence.topic != "/imu/data"
    strict = diff(teleop_log, other, tolerances=DiffTolerances(), ignore=["/imu/data", "/livox/lidar", "/scan", "/tf"])
    assert {c.name for c in strict.checks if c.verdict.failed} == set()  # /odom within its 0.01 m ATE


def test_bad_input_is_one_line_naming_the_path(replays, teleop_log, tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    no_manifest = tmp_path / "no_manifest"
    shutil.copytree(replays["a"], no_manifest)
    (no_manifest / "manifest.json").unlink()
    broken = tmp_path / "broken"
    shutil.copytree(replays["a"], broken)
    (broken / "manifest.json").write_text("{not json")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    cases = [
        (empty, "neither a replay output folder"),
        (no_manifest, "without manifest.json"),
        (broken, "not valid JSON"),
        (tmp_path / "missing", "no such file or folder"),
        (teleop_log, "cannot compare"),
        (junk, "junk.mcap"),
    ]
    for path, words in cases:
        with pytest.raises(NavlogError, match=words):
            diff(replays["a"], path)
        assert main(["diff", str(replays["a"]), str(path)]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and str(path) in err and "Traceback" not in err
    assert main(["diff", str(replays["a"]), str(replays["a"]), "--tol", "grid.hausdorf_m=1"]) == 2
    assert "did you mean 'grid.hausdorff_m'" in capsys.readouterr().err


def test_json_writes_nan_and_infinity_as_null_and_names_them():
    from navlog.analysis.diff import Check, DiffReport

    report = DiffReport(
        "a", "b", "file", (Check("x", "grid", Verdict.CHANGED, {"h": float("inf"), "i": float("nan")}),)
    )
    text = to_json(report)
    doc = json.loads(text)
    assert doc["checks"][0]["values"] == {"h": None, "i": None}, doc
    assert doc["non_finite_values"] == {
        "checks[0].values.h": "+inf, written as null",
        "checks[0].values.i": "NaN, written as null",
    }
    assert ": NaN" not in text and "Infinity" not in text and to_markdown(report).startswith("### navlog diff: FAIL")


def test_another_planner_moves_the_plans_but_not_the_costmap(teleop_log, tmp_path):
    from navlog.replay.session import run_replay

    room = tmp_path / "room.yaml"
    assert main(["-q", "world-map", "indoor_room", "--margin", "0.15", "-o", str(room)]) == 0
    base = ["goals=indoor_room_waypoints", f"map={room}"]
    run_replay(teleop_log, "planner", tmp_path / "navfn", overrides=base, progress=False)
    run_replay(teleop_log, "planner", tmp_path / "smac", overrides=[*base, "planner=smac2d"], progress=False)
    report = diff(tmp_path / "navfn", tmp_path / "smac")
    assert report.check("/global_costmap/costmap").verdict is Verdict.EQUAL
    plans = report.check("plans.json")
    assert plans.verdict is Verdict.CHANGED and plans.values["success_changed"] == 0
    assert plans.values["plans_a"] == plans.values["plans_b"] == 18  # a plan a second over the 17 s log
    assert plans.values["max_endpoint_m"] == 0.0  # same goals
    # measured: lengths differ by up to 0.18 m, costs by 6 %; the paths lie up to 0.53 m apart
    assert 0.05 < plans.values["max_length_change_m"] < 0.5
    topic = report.check("/plan")
    assert topic.verdict is Verdict.CHANGED and 0.2 < topic.values["max_hausdorff_m"] < 1.0
    assert report.first_divergence is not None and report.first_divergence.topic == "/plan"
    assert report.first_divergence.field == "poses.length"


def test_the_overlay_draws_both_maps_and_the_changed_cells(replays, teleop_log, tmp_path):
    from navlog.analysis.diff import save_overlay
    from tests.analysis.view.rrd import read_rrd, verify

    report = diff(replays["a"], replays["coarse"])
    out = save_overlay(report, tmp_path / "diff.rrd")
    assert verify(out).returncode == 0
    data = read_rrd(out)
    assert {"/a/map", "/b/map", "/diff/map_changed", "/a/trajectory", "/b/trajectory", "/diff/report"} <= set(data)
    (batch,) = data["/diff/map_changed"]["static"]
    assert len(batch.column("Points3D:positions").to_pylist()[0]) == report.check("map.yaml").values["changed_cells"]
    with pytest.raises(NavlogError, match="navlog view"):
        save_overlay(diff(teleop_log, teleop_log), tmp_path / "log.rrd")
    with pytest.raises(NavlogError, match=r"must end in \.rrd"):
        save_overlay(report, tmp_path / "diff.png")


def test_a_truncated_log_is_named_with_the_repair_diff_can_take(teleop_log, tmp_path, capsys):
    """The reader's message says to use --recover, which diff has not; diff names the repair instead."""
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(teleop_log.read_bytes()[: teleop_log.stat().st_size // 2])
    assert main(["diff", str(teleop_log), str(cut)]) == 2
    err = capsys.readouterr().err
    assert f"repair it with `navlog recover {cut} -o FIXED.mcap` and diff that" in err and "--recover" not in err
