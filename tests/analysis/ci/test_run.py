"""``navlog ci run`` on the shipped suite: it passes against the committed baselines; a deliberate change
fails naming exactly the outputs that moved; reports, baselines, workers, bad input, exit codes.

The golden logs are recorded once per session into a shared cache (the replays are cached too)."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from navlog.analysis.ci import (
    Status,
    format_result,
    read_baseline,
    run_suite,
    to_json,
    to_junit,
    to_markdown,
    write_reports,
)
from navlog.cli import main

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[3]
SHIPPED = REPO / "config" / "suites" / "navlog.yaml"
BASELINES = REPO / "data" / "baselines"
INFLATION = "global_costmap.inflation_layer.inflation_radius=0.35"
RESOLUTION = "occupancy.grid.resolution=0.1"


@pytest.fixture(scope="module")
def cache(ci_cache: Path) -> Path:
    return ci_cache


@pytest.fixture(scope="module")
def baseline_run(cache: Path):
    return run_suite(SHIPPED, cache_dir=cache)


def failed_names(case) -> set[str]:
    return {c.name for c in case.checks if c.status.failed}


def hash_only(case, name: str = "replay.mcap") -> bool:
    """Whether ``name``, kept by hash only in the baseline, has other bytes: information, never a failure."""
    check = case.check(name)
    return check.status is Status.PASS and bool(check.values.get("hash_only"))


def test_shipped_suite_passes_against_its_baselines(baseline_run):
    r = baseline_run
    assert r.exit_code == 0, to_markdown(r)
    assert [c.status for c in r.cases] == [Status.PASS] * 4
    assert r.unused_baselines == ()
    mapping = r.case("mapping_teleop_2d")
    # the recipe recorded the baseline's log: its bytes, or on a machine that rounds otherwise its layout
    assert mapping.check("recipe").status is Status.PASS
    # (on a machine that rounds otherwise, metrics.json is checked metric by metric: "metrics.json:...")
    assert {c.name.split(":")[0] for c in mapping.checks if c.kind == "diff"} == {
        "map.yaml",
        "map.pgm",
        "trajectory.tum",
        "replay.mcap",
        "metrics.json",
    }
    # ground-truth poses: the mapper's trajectory is the truth to float rounding
    assert mapping.facts["metrics.ate.rmse"] < 1e-6
    planner = r.case("planner_teleop")
    # 17 plans and one failure: at 14 s the robot cell and its ring are inscribed, where Nav2's NavFn finds no path
    assert planner.facts["plans.count"] == 17
    assert planner.facts["plans.failures"] == 1
    assert 0.1 <= planner.facts["min_clearance"] < 0.5
    safety = r.case("safety_teleop_wall")
    assert safety.facts["safety.commands_in"] == 301
    assert safety.facts["safety.collision_monitor.stopped_s"] == pytest.approx(8.65)
    nav = r.case("navigation_tour")
    # the replayed navigator reached the five goals of the tour, as the live run did; no contact
    assert nav.facts["goals.reached"] == 5 and nav.facts["goals.total"] == 5
    assert nav.check("all_goals_reached").status is Status.PASS and nav.check("no_collision").status is Status.PASS
    assert {c.name for c in nav.checks if c.kind == "diff"} >= {"replay.mcap", "navigation.json", "safety.json"}


def test_inflation_change_fails_the_planner_case_only(cache, baseline_run):
    r = run_suite(SHIPPED, cache_dir=cache, overrides=[INFLATION])
    assert r.exit_code == 1
    planner = r.case("planner_teleop")
    assert planner.status is Status.FAIL
    # the plans moved beyond tolerance; replay.mcap (kept by hash only) moved too: information, not a failure
    assert failed_names(planner) == {"plans.json"}
    assert "beyond tolerance" in planner.check("plans.json").message
    assert hash_only(planner)
    assert any("parameters differ from the baseline's" in n for n in planner.notes)
    # the navigation pipeline takes the key too (Nav2's global costmap): its plans move, its goals are
    # still reached within the tolerances, so it passes with replay.mcap's other bytes as information
    nav = r.case("navigation_tour")
    assert nav.status is Status.PASS and hash_only(nav)
    assert any("parameters differ from the baseline's" in n for n in nav.notes)
    # the others have no such key: untouched, and the report says so
    assert r.case("mapping_teleop_2d").status is Status.PASS
    assert r.case("safety_teleop_wall").status is Status.PASS
    assert r.notes == (
        f"--set {INFLATION}: applied to planner_teleop, navigation_tour; NOT applied to mapping_teleop_2d "
        "(mapping), safety_teleop_wall (safety): their pipelines have no parameter "
        "'global_costmap.inflation_layer.inflation_radius'",
    )


def test_map_resolution_change_fails_the_map_outputs_only(cache, baseline_run):
    r = run_suite(SHIPPED, cache_dir=cache, overrides=[RESOLUTION])
    mapping = r.case("mapping_teleop_2d")
    assert mapping.status is Status.FAIL
    moved = failed_names(mapping)
    assert {"map.yaml", "map.pgm"} <= moved
    # besides the map files, only map metrics moved: the trajectory is the same
    metrics = moved - {"map.yaml", "map.pgm"}
    assert len(metrics) >= 10 and all(n.startswith("metrics.json:map_2d.") for n in metrics)
    assert mapping.check("trajectory.tum").status is Status.PASS
    assert "1.042 %" in mapping.check("map.yaml").message  # 1668 of 160000 cells changed class
    # the text report: one line per cause with its count, not one per moved metric
    lines = format_result(r).splitlines()
    assert sum(f"metrics.json ({len(metrics)} metrics)" in line and "FAIL" in line for line in lines) == 1
    assert sum("metrics.json" in line for line in lines) <= 2  # the failed ones, the improved ones
    assert sum("map.pgm" in line for line in lines) == 1  # judged with map.yaml: on its line
    assert r.case("planner_teleop").status is Status.PASS
    # and without the change it passes again
    assert run_suite(SHIPPED, cache_dir=cache).exit_code == 0


def test_workers_give_the_serial_results(cache, baseline_run):
    parallel = run_suite(SHIPPED, cache_dir=cache, workers=2)
    assert to_json(parallel) == to_json(baseline_run)


def test_reports(tmp_path, cache, baseline_run):
    r = run_suite(SHIPPED, cache_dir=cache, overrides=[INFLATION])
    summary = tmp_path / "summary.md"
    summary.write_text("earlier step\n")
    written = write_reports(
        r,
        json_path=tmp_path / "r.json",
        junit_path=tmp_path / "r.xml",
        markdown_path=tmp_path / "r.md",
        environ={"GITHUB_STEP_SUMMARY": str(summary)},
    )
    assert [p.name for p in written] == ["r.json", "r.xml", "r.md", "summary.md"]
    data = json.loads((tmp_path / "r.json").read_text())
    assert data["schema"] == "navlog-ci/1" and data["exit_code"] == 1
    assert to_json(r) == to_json(run_suite(SHIPPED, cache_dir=cache, overrides=[INFLATION]))  # same bytes
    junit = ET.parse(tmp_path / "r.xml").getroot()
    suites = {s.get("name"): s for s in junit.iter("testsuite")}
    planner = suites["navlog.planner_teleop"]
    assert planner.get("failures") == "1"
    failures = [t.get("name") for t in planner.iter("testcase") if t.find("failure") is not None]
    assert failures == ["diff plans.json"]
    props = {p.get("name"): p.get("value") for p in planner.iter("property")}
    assert props["plans.count"] == "17" and props["pipeline"] == "planner"
    md = (tmp_path / "r.md").read_text()
    assert md.index("FAIL | `planner_teleop`") < md.index("PASS | `mapping_teleop_2d`")  # regressions first
    assert len(md) < 65_536
    assert summary.read_text().startswith("earlier step\n### ")


def test_baselines_new_update_unused_and_version(tmp_path, cache, baseline_run):
    base = tmp_path / "baselines"
    r = run_suite(SHIPPED, cache_dir=cache, baseline_dir=base)
    assert [c.status for c in r.cases] == [Status.NEW] * 4 and r.exit_code == 1
    r = run_suite(SHIPPED, cache_dir=cache, baseline_dir=base, update_new=True)
    assert r.exit_code == 0 and all(c.baseline_written for c in r.cases)
    # the committed baselines' files; their bytes where this machine recorded the very logs they were
    # written from (a machine that rounds otherwise records logs of the same layout, other bytes)
    for case in ("mapping_teleop_2d", "planner_teleop", "safety_teleop_wall", "navigation_tour"):
        committed, fresh = BASELINES / "navlog" / case, base / "navlog" / case
        assert sorted(f.name for f in fresh.iterdir()) == sorted(f.name for f in committed.iterdir())
        want, got = read_baseline(committed).provenance["log"], read_baseline(fresh).provenance["log"]
        assert got["layout"] == want["layout"] and got["recipe"] == want["recipe"]
        if got["sha256"] == want["sha256"]:
            for f in sorted(committed.iterdir()):
                assert (fresh / f.name).read_bytes() == f.read_bytes(), f
    # a baseline nobody uses is reported; one from another navlog version is NEW (compared, then a failure)
    shutil.copytree(base / "navlog" / "planner_teleop", base / "navlog" / "old_case")
    doc_path = base / "navlog" / "safety_teleop_wall" / "baseline.json"
    doc = json.loads(doc_path.read_text())
    doc["provenance"]["navlog_version"] = "0.0.1"
    doc_path.write_text(json.dumps(doc))
    r = run_suite(SHIPPED, cache_dir=cache, baseline_dir=base)
    assert r.unused_baselines == ("old_case",)
    safety = r.case("safety_teleop_wall")
    assert safety.status is Status.NEW and r.exit_code == 1
    assert "written by navlog 0.0.1" in safety.check("baseline").message
    assert safety.check("safety.json").status is Status.PASS
    r = run_suite(SHIPPED, cache_dir=cache, baseline_dir=base, update_new=True)
    assert r.case("safety_teleop_wall").baseline_written and not r.case("planner_teleop").baseline_written
    assert read_baseline(base / "navlog" / "safety_teleop_wall").navlog_version != "0.0.1"
    # --update with a change rewrites and says what moved against the old baseline
    r = run_suite(SHIPPED, cache_dir=cache, baseline_dir=base, update=True, overrides=[INFLATION])
    assert r.exit_code == 0
    assert "moved against the old one: plans.json;" in " ".join(r.case("planner_teleop").notes) + ";"


def test_bad_input_error_and_determinism(tmp_path, cache, baseline_run):
    logs = sorted((cache / "logs").glob("indoor_room-go2-teleop-*.mcap"))
    suite = tmp_path / "bad.navlog-suite.yaml"
    suite.write_text(
        f"cases:\n"
        f"  - {{name: no_commands, pipeline: safety, log: {logs[0]}}}\n"  # no /cmd_vel_nav without a remap
        f"  - {{name: missing, pipeline: mapping, log: {tmp_path / 'nope.mcap'}}}\n"
        f"  - name: wall\n    pipeline: safety\n    recipe: {{world: walled_room, robot: kibot, scenario: teleop_wall}}\n"
        f"    remap: {{/cmd_vel_nav: /cmd_vel}}\n    checks: [no_collision, events.collision >= 1]\n"
    )
    r = run_suite(suite, cache_dir=cache, baseline_dir=tmp_path / "b", determinism=True)
    invalid = r.case("no_commands")
    assert invalid.status is Status.INVALID_INPUT
    assert "/cmd_vel_nav" in invalid.check("input").message
    assert r.case("missing").status is Status.ERROR
    assert "nope.mcap: no such file" in r.case("missing").checks[0].message
    wall = r.case("wall")
    # the recorded run drove into the wall: the invariant says so with the count
    assert wall.check("no_collision").status is Status.FAIL
    assert wall.check("events.collision >= 1").status is Status.PASS
    assert wall.check("determinism").status is Status.PASS
    assert r.exit_code == 2
    junit = ET.fromstring(to_junit(r))
    skipped = [t for t in junit.iter("testcase") if t.find("skipped") is not None]
    assert [t.get("classname") for t in skipped] == ["bad.no_commands"]


def test_command_line(tmp_path, cache, baseline_run, capsys):
    args = ["ci", "run", str(SHIPPED), "--cache", str(cache)]
    assert main(args) == 0
    assert main([*args, "--set", INFLATION, "--json", str(tmp_path / "r.json")]) == 1
    assert main([*args, "--set", INFLATION, "--json", str(tmp_path / "r.json")]) == 2  # exists: --force
    assert "r.json: already exists" in capsys.readouterr().err
    assert json.loads((tmp_path / "r.json").read_text())["status"] == "FAIL"
    assert main([*args, "--set", "inflation_radus=0.3"]) == 2
    assert (
        "no case's pipeline (mapping, navigation, planner, safety) has the parameter 'inflation_radus'"
        in capsys.readouterr().err
    )
    bad = tmp_path / "bad.yaml"
    bad.write_text("cases:\n  - {name: a, pipeline: mapping, log: x.mcap, chceks: []}\n")
    assert main(["ci", "run", str(bad)]) == 2
    assert "chceks: unknown key (did you mean 'checks'?)" in capsys.readouterr().err


def test_a_mapping_case_on_a_real_bag_without_ground_truth_runs_its_diff_and_notes_the_metrics(tmp_path, bags_dir):
    """A real robot's bag has no ground truth and no reference map: the case ended in ERROR ('no metric could be
    computed') and wrote no baseline. Its diff runs; the missing metrics are a note; a metric invariant fails."""
    suite = tmp_path / "real.navlog-suite.yaml"
    log = bags_dir / "neato_drive_square"
    suite.write_text(
        f"cases:\n  - {{name: neato, pipeline: mapping, log: {log}, checks: [{{diff: {{}}}}]}}\n"
        f"  - {{name: scored, pipeline: mapping, log: {log}, checks: ['metrics.trajectory.ate.rmse < 0.1']}}\n"
    )
    r = run_suite(suite, cache_dir=tmp_path / "cache", baseline_dir=tmp_path / "b", update_new=True)
    neato = r.case("neato")
    assert neato.status is Status.PASS and neato.baseline_written and any((tmp_path / "b").rglob("*.json"))
    assert any(n.startswith("no metrics: ATE, RPE") and "/odom/ground_truth" in n for n in neato.notes)
    assert r.case("scored").status is not Status.PASS
