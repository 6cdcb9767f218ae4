"""The suite file: read once, every bad key named with the file, the case and a did-you-mean; invariants."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.analysis.ci.invariants import evaluate, parse_invariant
from navlog.analysis.ci.result import Status, exit_code
from navlog.analysis.ci.suite import Recipe, load_suite
from navlog.errors import ConfigError

REPO = Path(__file__).resolve().parents[3]
SHIPPED = REPO / "config" / "suites" / "navlog.yaml"


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "s.navlog-suite.yaml"
    path.write_text(text)
    return path


def test_shipped_suite_reads():
    suite = load_suite(SHIPPED)
    assert suite.name == "navlog"
    assert [c.name for c in suite.cases] == [
        "mapping_teleop_2d",
        "planner_teleop",
        "safety_teleop_wall",
        "navigation_tour",
    ]
    nav = suite.case("navigation_tour")
    assert nav.recipe == Recipe("indoor_room", "go2", "nav_tour", 0, True) and nav.pipeline == "navigation"
    assert [i.text for i in nav.invariants] == ["all_goals_reached", "no_collision"]
    planner = suite.case("planner_teleop")
    assert planner.recipe == Recipe("indoor_room", "go2", "teleop", 0, True)
    assert planner.params == SHIPPED.parent / "navlog_planner_nav2.yaml"
    assert planner.diff is not None and planner.diff.tolerances.path.cost_rtol == 0.01
    assert [i.text for i in planner.invariants] == ["plans.failures <= 1", "plans.count >= 10", "min_clearance >= 0.1"]
    assert suite.baselines == SHIPPED.parent / "../../data/baselines"
    assert dict(suite.case("safety_teleop_wall").remap) == {"/cmd_vel_nav": "/cmd_vel"}


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        (
            "cases:\n  - {name: a, pipline: mapping, log: x.mcap}\n",
            "case 'a': pipline: unknown key (did you mean 'pipeline'?)",
        ),
        (
            "cases:\n  - {name: a, pipeline: maping, log: x.mcap}\n",
            "unknown pipeline 'maping' (did you mean 'mapping'?)",
        ),
        ("cases:\n  - {name: a, pipeline: mapping}\n", "case 'a': log: give exactly one of log"),
        (
            "cases:\n  - {name: a, pipeline: mapping, recipe: {world: w, robot: r, scenario: s, sed: 1}}\n",
            "case 'a': recipe.sed: unknown key (did you mean 'seed'?)",
        ),
        (
            "cases:\n  - {name: a, pipeline: planner, log: x.mcap, checks: [all_goal_reached]}\n",
            "case 'a': checks[0]: unknown check 'all_goal_reached' (did you mean 'all_goals_reached'?)",
        ),
        (
            "cases:\n  - {name: a, pipeline: mapping, log: x.mcap, checks: [plans.count >= 3]}\n",
            "plans comes from a planner case, not a mapping case",
        ),
        (
            "cases:\n  - {name: a, pipeline: mapping, log: x.mcap, checks: [{diff: {tolerances: {grid.changed_shar: 0.1}}}]}\n",
            "checks[0].diff.tolerances: 'grid.changed_shar=0.1': unknown tolerance 'grid.changed_shar' (did you mean 'grid.changed_share'?)",
        ),
        (
            "cases:\n  - {name: a, pipeline: mapping, log: x.mcap, world_map: {world: indoor_room, margin: 60}}\n",
            "case 'a': world_map.margin: expected a number >= 0 and <= 50, got 60",
        ),
        ("caes: []\n", "suite: caes: unknown key (did you mean 'cases'?)"),
        (
            "cases:\n  - {name: a, pipeline: mapping, log: x.mcap}\n  - {name: a, pipeline: mapping, log: x.mcap}\n",
            "'a' is used by two cases",
        ),
    ],
)
def test_bad_suites_are_named(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError) as err:
        load_suite(path)
    assert str(path) in str(err.value)
    assert expected in str(err.value)


def test_missing_suite_file(tmp_path):
    with pytest.raises(ConfigError, match="no such suite file"):
        load_suite(tmp_path / "nope.yaml")


def test_invariants_judge_facts():
    facts = {"metrics.ate.rmse": 0.04, "no_collision": False, "plans.count": 18.0}
    assert evaluate(parse_invariant("metrics.ate.rmse <= 0.05", "mapping"), facts).status is Status.PASS
    failed = evaluate(parse_invariant("metrics.ate.rmse < 0.03", "mapping"), facts)
    assert failed.status is Status.FAIL and failed.message == "metrics.ate.rmse = 0.04, expected < 0.03"
    assert evaluate(parse_invariant("no_collision", "safety"), facts).status is Status.FAIL
    assert evaluate(parse_invariant("plans.count == 18", "planner"), facts).status is Status.PASS
    missing = evaluate(parse_invariant("plans.cont >= 1", "planner"), facts)
    assert missing.status is Status.ERROR and "did you mean 'plans.count'" in missing.message


def test_exit_codes_rank_bad_input_then_nondeterminism_then_regressions():
    assert exit_code([Status.PASS, Status.IMPROVED]) == 0
    assert exit_code([Status.PASS, Status.NEW]) == 1
    assert exit_code([Status.FAIL, Status.NONDETERMINISTIC]) == 3
    assert exit_code([Status.NONDETERMINISTIC, Status.INVALID_INPUT]) == 2
    assert exit_code([Status.ERROR]) == 2


def test_a_baseline_file_that_is_no_gzip_is_named_with_the_fix(tmp_path):
    """A corrupt stored copy said only 'BadGzipFile: Not a gzipped file (b'ga')'."""
    from navlog.analysis.ci.baselines import Baseline
    from navlog.errors import NavlogError

    (tmp_path / "map").mkdir()
    (tmp_path / "map" / "map.pgm.gz").write_bytes(b"garbage")
    base = Baseline(tmp_path, {"outputs": {"map.pgm": {"stored": "map/map.pgm.gz"}}})
    with pytest.raises(NavlogError, match=r"map/map.pgm.gz: cannot be read \(.*\); rewrite the baseline with --update"):
        base.stored("map.pgm", tmp_path)


def test_baselines_given_as_a_file_are_refused_before_anything_runs(tmp_path):
    """--baselines FILE --update-new ended in a NotADirectoryError traceback after the cases ran."""
    from navlog.analysis.ci import run_suite
    from navlog.errors import ConfigError

    suite = tmp_path / "s.navlog-suite.yaml"
    suite.write_text(f"cases:\n  - {{name: gone, pipeline: mapping, log: {tmp_path / 'nope.mcap'}}}\n")
    (tmp_path / "afile").write_text("x\n")
    with pytest.raises(ConfigError, match=r"afile: the baselines' place is a file, not a folder"):
        run_suite(suite, cache_dir=tmp_path / "cache", baseline_dir=tmp_path / "afile", update_new=True)
