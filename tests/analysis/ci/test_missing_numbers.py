"""A number a report has no samples of (NaN or None) is said, never printed as "nan" or written as NaN."""

from __future__ import annotations

import json

from navlog.analysis.ci.invariants import evaluate, parse_invariant
from navlog.analysis.ci.reports import to_json, to_junit, to_markdown
from navlog.analysis.ci.result import CaseResult, CheckResult, Status, SuiteResult
from navlog.analysis.diff.metric_values import compare_metric_values
from navlog.analysis.tables import MISSING, figure


def test_figure_says_a_missing_number():
    assert figure(float("nan")) == figure(None) == MISSING == "n/a (no samples)"
    assert figure(0.123456789) == "0.123457" and figure(2.5, ".3g", "m") == "2.5 m"
    assert figure(float("inf")) == "inf"


def test_ci_reports_of_a_nan_fact_and_invariant():
    check = evaluate(parse_invariant("metrics.map_2d.iou > 0.5", "mapping"), {"metrics.map_2d.iou": float("nan")})
    assert check.status == Status.FAIL
    assert check.message == "metrics.map_2d.iou = n/a (no samples), expected > 0.5"
    case = CaseResult("c", "mapping", "log.mcap", (check, CheckResult("x", "diff", Status.PASS, "same bytes")))
    case = CaseResult(case.name, case.pipeline, case.source, case.checks, facts={"ate_m": float("nan"), "n": 3.0})
    result = SuiteResult("s", "s.yaml", "0.1.0", (case,))
    junit, markdown, text = to_junit(result), to_markdown(result), to_json(result)
    assert 'name="ate_m" value="n/a (no samples)"' in junit and 'name="n" value="3"' in junit
    for report in (junit, markdown):
        assert "nan" not in report.replace("n/a (no samples)", ""), report
    doc = json.loads(text)
    assert ": NaN" not in text and doc["non_finite_values"]["cases[0].facts.ate_m"] == "NaN, written as null"


def test_a_diff_of_a_metric_without_samples_says_so():
    from navlog.analysis.diff.tolerances import MetricTolerance

    [check] = compare_metric_values("metrics.json", {"ate_m": float("nan")}, {"ate_m": 0.25}, MetricTolerance())
    assert check.detail == "n/a (no samples) -> 0.25"
