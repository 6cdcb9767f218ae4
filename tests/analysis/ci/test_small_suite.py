"""``navlog ci run`` on a small suite of synthetic logs (fast): paths relative to the suite, what a changed
log or a --set says, hash-only outputs as information, grouped report lines, existing reports and --force."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from navlog.analysis.ci import CheckResult, Status, compare_to_baseline, format_result, run_suite, write_baseline
from navlog.analysis.ci.reports import grouped, to_markdown
from navlog.analysis.ci.result import CaseResult, SuiteResult
from navlog.analysis.diff.tolerances import DEFAULT_TOLERANCES
from navlog.cli import main
from navlog.errors import ConfigError
from tests.replay.pipelines.test_mapping_replay import wall_log
from tests.replay.pipelines.test_safety_pipeline import teleop_log

CASE = "  - name: stop\n    pipeline: safety\n    log: {log}\n    remap: {{/cmd_vel_nav: /cmd_vel}}\n"


@pytest.fixture
def suite(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """tmp/suites/small.yaml reading tmp/suites/logs/teleop.mcap (KiBot's filters before a wall); the working
    folder is tmp/elsewhere."""
    folder = tmp_path / "suites"
    (folder / "logs").mkdir(parents=True)
    teleop_log(folder / "logs" / "teleop.mcap")
    path = folder / "small.yaml"
    path.write_text("cases:\n" + CASE.format(log="logs/teleop.mcap"))
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.chdir(tmp_path / "elsewhere")
    return path


def test_baselines_are_found_beside_the_suite_as_its_logs_are(suite, tmp_path):
    cache = tmp_path / "cache"
    r = run_suite(suite, cache_dir=cache, update_new=True)
    assert r.exit_code == 0 and r.case("stop").baseline_written
    assert (suite.parent / "data" / "baselines" / "small" / "stop" / "baseline.json").is_file()
    assert not (tmp_path / "elsewhere" / "data").exists()  # not in the working folder
    assert run_suite(suite, cache_dir=cache).exit_code == 0  # and read from there again


def test_a_changed_log_is_named_as_a_changed_parameter_is(suite, tmp_path):
    cache = tmp_path / "cache"
    run_suite(suite, cache_dir=cache, update_new=True)
    before = run_suite(suite, cache_dir=cache).case("stop")
    assert before.status is Status.PASS and not any("log differs" in n for n in before.notes)
    (suite.parent / "logs" / "teleop.mcap").unlink()
    teleop_log(suite.parent / "logs" / "teleop.mcap", vx=0.3)  # the same file name, other content
    r = run_suite(suite, cache_dir=cache).case("stop")
    assert any(n.startswith("the log differs from the baseline's (sha256 ") for n in r.notes), r.notes
    r = run_suite(suite, cache_dir=cache, overrides=["velocity_smoother=off"]).case("stop")
    assert any("log differs" in n for n in r.notes) and any("parameters differ" in n for n in r.notes)


def test_set_names_the_cases_it_was_not_applied_to_and_a_chosen_case_must_take_it(suite, tmp_path):
    wall_log(suite.parent / "logs" / "wall.mcap")
    suite.write_text(
        "cases:\n"
        + CASE.format(log="logs/teleop.mcap")
        + "  - {name: wall, pipeline: mapping, log: logs/wall.mcap, checks: []}\n"
    )
    cache = tmp_path / "cache"
    with pytest.raises(ConfigError, match="has the parameter"):
        run_suite(suite, cache_dir=cache, overrides=["occupancy.grid.resolutio=0.1"])
    # a case asked for by name that lacks the key is an error naming both
    with pytest.raises(
        ConfigError,
        match=r"--set 'occupancy.grid.resolution=0.1': case 'stop' \(pipeline safety\) has no parameter "
        r"'occupancy.grid.resolution'",
    ):
        run_suite(suite, cache_dir=cache, overrides=["occupancy.grid.resolution=0.1"], cases=["wall", "stop"])
    assert main(["ci", "run", str(suite), "--case", "stop", "--set", "occupancy.grid.resolution=0.1"]) == 2
    # over the whole suite, the report names the cases it was not applied to
    r = run_suite(suite, cache_dir=cache, overrides=["occupancy.grid.resolution=0.1"], update_new=True)
    assert r.notes == (
        "--set occupancy.grid.resolution=0.1: applied to wall; NOT applied to stop (safety): their pipelines "
        "have no parameter 'occupancy.grid.resolution'",
    )
    text = format_result(r)
    assert text.splitlines()[1].startswith("note: --set occupancy.grid.resolution=0.1: applied to wall; NOT applied")
    assert "NOT applied to stop (safety)" in to_markdown(r)


def test_an_output_kept_by_hash_only_is_information_not_a_failure(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    for folder, extra in ((a, b"one"), (b, b"two")):
        folder.mkdir()
        (folder / "plans.json").write_text('{"failures": [], "plans": []}\n')
        (folder / "replay.mcap").write_bytes(b"\x89MCAP0\r\n" + extra)
    write_baseline(tmp_path / "base", {n: a / n for n in ("plans.json", "replay.mcap")}, {}, label="x")
    from navlog.analysis.ci import read_baseline

    base = read_baseline(tmp_path / "base")
    found = {
        c.name: c
        for c in compare_to_baseline(base, {n: b / n for n in ("plans.json", "replay.mcap")}, DEFAULT_TOLERANCES)
    }
    assert found["plans.json"].status is Status.PASS
    mcap = found["replay.mcap"]
    assert mcap.status is Status.PASS and mcap.values["hash_only"] is True
    assert mcap.message.startswith("bytes differ (sha256 ") and "not judged" in mcap.message


def test_one_cause_is_one_line_with_its_count():
    checks = [CheckResult("map.yaml", "diff", Status.FAIL, "CHANGED: 1668/160000 cells changed class")]
    checks.append(CheckResult("map.pgm", "diff", Status.FAIL, "CHANGED (judged with map.yaml): 1668 cells"))
    checks += [
        CheckResult(f"metrics.json:map_2d.counts.c{i}", "diff", Status.FAIL, f"CHANGED (metric): {i} -> {i + 1}")
        for i in range(13)
    ]
    checks += [CheckResult("metrics.json:map_2d.iou", "diff", Status.IMPROVED, "IMPROVED (metric): 0.2 -> 0.4")]
    checks += [CheckResult("trajectory.tum", "diff", Status.PASS, "same bytes")]
    rows = grouped(checks)
    assert [(s, name, n) for s, name, _, n in rows] == [
        (Status.FAIL, "map.yaml (2 checks)", 2),
        (Status.FAIL, "metrics.json (13 metrics)", 13),
        (Status.IMPROVED, "metrics.json:map_2d.iou", 1),
    ]
    assert rows[1][2].startswith("map_2d.counts.c0: CHANGED (metric): 0 -> 1; also map_2d.counts.c1, ")
    assert rows[1][2].endswith("map_2d.counts.c6 and 6 more")
    case = CaseResult("m", "mapping", "log", tuple(checks))
    text = format_result(SuiteResult("s", "s.yaml", "0", (case,)))
    assert sum("metrics.json" in line for line in text.splitlines()) == 2  # 14 checks, 2 lines
    assert sum("map.pgm" in line for line in text.splitlines()) == 1


def test_existing_reports_need_force(suite, tmp_path, capsys):
    args = ["ci", "run", str(suite), "--cache", str(tmp_path / "cache"), "--update-new"]
    report = tmp_path / "ci.json"
    report.write_text("mine")
    for option in ("--json", "--junit", "--markdown"):
        assert main([*args, option, str(report)]) == 2
        assert "ci.json: already exists; choose another name or pass --force" in capsys.readouterr().err
        assert report.read_text() == "mine"
    assert not (suite.parent / "data").exists()  # refused before anything ran
    assert main([*args, "--json", str(report), "--force"]) == 0
    assert json.loads(report.read_text())["status"] == "PASS"
