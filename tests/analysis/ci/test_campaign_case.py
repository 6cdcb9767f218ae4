"""CI cases of kind campaign: thresholds on a campaign's summary, named with the measured value when missed."""

from __future__ import annotations

import json
import xml.etree.ElementTree as ET
from types import SimpleNamespace

import pytest

from navlog.analysis.ci.reports import write_reports
from navlog.analysis.ci.result import Status
from navlog.analysis.ci.runner import run_suite
from navlog.analysis.ci.suite import load_suite
from navlog.campaign.stats import summarize
from navlog.errors import ConfigError
from tests.campaign.campaign_files import BASE

SUITE = """name: s
cases:
  - name: camp
    kind: campaign
    campaign: c.yaml
    checks:
      - success_rate >= 0.9
      - collisions == 0
      - not REGRESSED vs baseline
"""


def _rows(variant, results, times):
    return [
        {"run_id": f"w{i}-{variant}", "world": f"w{i}", "robot": "go2", "seed": 0, "route": 0, "variant": variant,
         "result": r, "time_s": t, "path_length_m": 5.0, "barn_metric": 0.2 if r == "succeeded" else 0.0,
         "sim_s": t, "min_clearance_m": 0.3, "recoveries": 0}
        for i, (r, t) in enumerate(zip(results, times))
    ]  # fmt: skip


def _summary():
    """Variant a: 10 of 10 succeeded; b: 8 of 10 (one collision, one timeout), 2 s slower on every pair."""
    a = _rows("a", ["succeeded"] * 10, [20.0 + i for i in range(10)])
    b = _rows("b", ["succeeded"] * 8 + ["collision", "timeout"], [22.0 + i for i in range(10)])
    spec = SimpleNamespace(name="t", variants=[SimpleNamespace(name="a"), SimpleNamespace(name="b")],
                           baseline_variant="a", alpha=0.05)  # fmt: skip
    return summarize(a + b, spec, {})


def _suite(tmp_path, text=SUITE):
    (tmp_path / "c.yaml").write_text(BASE)
    (tmp_path / "s.yaml").write_text(text)
    return tmp_path / "s.yaml"


def fake_runner(campaign, out):
    return _summary()


def test_a_campaign_case_loads_with_its_thresholds(tmp_path):
    case = load_suite(_suite(tmp_path)).case("camp")
    assert case.kind == "campaign" and case.campaign == tmp_path / "c.yaml" and case.diff is None
    assert [(c.fact, c.op, c.value) for c in case.campaign_checks] == [
        ("success_rate", ">=", 0.9),
        ("collisions", "==", 0.0),
        ("", "", pytest.approx(float("nan"), nan_ok=True)),
    ]


@pytest.mark.parametrize(
    "check, message",
    [
        ("succes_rate >= 0.9", r"case 'camp': checks\[0\]: .*unknown campaign fact 'succes_rate'.*did you mean"),
        ("success_rate >= lots", r"'lots' is not a number"),
        ("REGRESSED", r"expected FACT\[.VARIANT\] OP NUMBER"),
    ],
)
def test_bad_campaign_checks_name_the_suite_case_and_check(tmp_path, check, message):
    text = SUITE.replace("      - success_rate >= 0.9\n", f"      - {check}\n")
    with pytest.raises(ConfigError, match=message):
        load_suite(_suite(tmp_path, text))


def test_bad_campaign_case_keys(tmp_path):
    with pytest.raises(ConfigError, match=r"kind: unknown case kind 'campain'.*did you mean 'campaign'"):
        load_suite(_suite(tmp_path, SUITE.replace("kind: campaign", "kind: campain")))
    with pytest.raises(ConfigError, match=r"campaign: .*nope.yaml: no such campaign file"):
        load_suite(_suite(tmp_path, SUITE.replace("campaign: c.yaml", "campaign: nope.yaml")))
    with pytest.raises(ConfigError, match=r"pipeline: unknown key"):
        load_suite(
            _suite(tmp_path, SUITE.replace("    kind: campaign\n", "    kind: campaign\n    pipeline: mapping\n"))
        )


def test_missed_thresholds_fail_the_case_naming_variant_and_value(tmp_path):
    res = run_suite(_suite(tmp_path), cache_dir=tmp_path / "cache", campaign_runner=fake_runner)
    case = res.case("camp")
    assert case.status is Status.FAIL and res.exit_code == 1
    rate, coll, verdict = case.checks
    assert rate.status is Status.FAIL
    assert rate.message == "success_rate.b = 0.8, expected >= 0.9"
    assert coll.status is Status.FAIL and coll.message == "collisions.b = 1, expected == 0"
    # b is slower on all 10 pairs: Wilcoxon's exact p = 2 / 2^10 < 0.05, REGRESSED on time
    assert verdict.status is Status.FAIL and verdict.message == "b REGRESSED vs a on time_s"
    assert case.facts["success_rate.a"] == 1.0 and case.facts["timeouts.b"] == 1.0
    paths = write_reports(
        res, json_path=tmp_path / "r.json", junit_path=tmp_path / "r.xml", markdown_path=tmp_path / "r.md"
    )
    assert len(paths) == 3
    doc = json.loads((tmp_path / "r.json").read_text())
    assert doc["cases"][0]["status"] == "FAIL" and doc["cases"][0]["pipeline"] == "campaign"
    failures = [tc for tc in ET.parse(tmp_path / "r.xml").iter("testcase") if tc.find("failure") is not None]
    assert len(failures) == 3
    assert "success_rate.b = 0.8" in (tmp_path / "r.md").read_text()


def test_thresholds_met_pass_and_one_variant_can_be_named(tmp_path):
    text = SUITE.replace("success_rate >= 0.9", "success_rate.a >= 0.95").replace(
        "      - collisions == 0\n      - not REGRESSED vs baseline\n", "      - collisions.a == 0\n"
    )
    case = run_suite(_suite(tmp_path, text), cache_dir=tmp_path / "cache", campaign_runner=fake_runner).case("camp")
    assert case.status is Status.PASS
    assert [c.message for c in case.checks] == ["success_rate.a = 1", "collisions.a = 0"]
    text = SUITE.replace("success_rate >= 0.9", "success_rate.c >= 0.95")
    case = run_suite(_suite(tmp_path, text), cache_dir=tmp_path / "cache", campaign_runner=fake_runner).case("camp")
    assert case.checks[0].status is Status.ERROR and "no variant 'c'" in case.checks[0].message


def test_without_the_campaign_runner_the_case_is_an_error_saying_so(tmp_path):
    case = run_suite(_suite(tmp_path), cache_dir=tmp_path / "cache").case("camp")
    assert case.status is Status.ERROR and "needs the campaign runner" in case.checks[0].message


@pytest.mark.slow
def test_navlog_ci_run_runs_a_campaign_case(tmp_path, capsys):
    """End to end through the command: one corridor run of the Go2 (6 m, no doors) succeeds."""
    from navlog.cli import main

    text = BASE + "routes: {kind: fixed, start: [-2.0, 0, 0], goal: [2.0, 0, 0]}\nmax_duration: 60\n"
    (tmp_path / "c.yaml").write_text(text)
    (tmp_path / "s.yaml").write_text(SUITE.replace("success_rate >= 0.9", "success_rate >= 1.1"))
    code = main(["ci", "run", str(tmp_path / "s.yaml"), "--cache", str(tmp_path / "cache"),
                 "--json", str(tmp_path / "r.json")])  # fmt: skip
    assert code == 1
    case = json.loads((tmp_path / "r.json").read_text())["cases"][0]
    assert case["checks"][0]["message"] == "success_rate.a = 1, expected >= 1.1"
    assert [c["status"] for c in case["checks"]] == ["FAIL", "PASS", "PASS"]
