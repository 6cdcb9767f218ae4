"""Campaign statistics with known answers: Wilson intervals, the BARN metric, McNemar and Wilcoxon verdicts."""

from __future__ import annotations

import pytest

from navlog.campaign.runner import barn_metric
from navlog.campaign.stats import IMPROVED, NO_CHANGE, REGRESSED, compare, mean_interval, wilson_interval


def rows(results, times, variant="v"):
    return [
        {
            "world": f"w{i}",
            "robot": "r",
            "seed": 0,
            "route": 0,
            "variant": variant,
            "result": res,
            "time_s": t,
            "path_length_m": 5.0 + 0.01 * i,
        }
        for i, (res, t) in enumerate(zip(results, times))
    ]


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(8, 10)
    assert (lo, hi) == pytest.approx((0.4902, 0.9433), abs=1e-4)  # z = 1.96: (p + z2/2n -+ ...) / (1 + z2/n)
    assert wilson_interval(10, 10) == pytest.approx((0.7225, 1.0), abs=1e-4)
    assert wilson_interval(0, 0) is None


def test_barn_metric_clips_between_4_and_8_optimal_times():
    assert barn_metric(True, 30.0, 10.0) == 0.25  # faster than 4 x optimal counts as 4 x
    assert barn_metric(True, 60.0, 10.0) == pytest.approx(10 / 60)
    assert barn_metric(True, 100.0, 10.0) == 0.125  # slower than 8 x optimal counts as 8 x
    assert barn_metric(False, 30.0, 10.0) == 0.0


def test_bootstrap_interval_is_seeded_and_brackets_the_mean():
    a = mean_interval([1.0, 2.0, 3.0, 4.0, 10.0])
    assert a == mean_interval([1.0, 2.0, 3.0, 4.0, 10.0])
    assert a["mean"] == 4.0 and a["ci"][0] < 4.0 < a["ci"][1]
    assert mean_interval([2.0, 2.0])["ci"] == [2.0, 2.0]
    assert mean_interval([None, float("nan")]) is None


def test_slower_on_every_pair_is_regressed_on_time():
    base = rows(["succeeded"] * 6, [10, 11, 12, 13, 14, 15])
    slow = rows(["succeeded"] * 6, [20, 23, 21, 25, 22, 30])
    c = compare(base, slow, 0.05)
    assert c["time_s"]["p_value"] == pytest.approx(2 / 2**6)  # exact: all 6 signs the same way
    assert c["time_s"]["median_difference"] > 0
    assert c["verdict"] == REGRESSED and c["worse"] == ["time_s"]
    assert compare(slow, base, 0.05)["verdict"] == IMPROVED


def test_same_variant_twice_is_no_significant_change():
    base = rows(["succeeded", "timeout", "succeeded", "collision"], [10, 60, 12, 5])
    c = compare(base, [dict(r) for r in base], 0.05)
    assert c["verdict"] == NO_CHANGE
    assert c["success"]["p_value"] == 1.0 and c["time_s"]["p_value"] == 1.0


def test_exact_mcnemar_on_discordant_pairs():
    base = rows(["succeeded"] * 6 + ["timeout"] * 2, [10] * 8)
    worse = rows(["timeout"] * 6 + ["timeout"] * 2, [10] * 8)
    c = compare(base, worse, 0.05)
    assert (c["success"]["lost"], c["success"]["gained"]) == (6, 0)
    assert c["success"]["p_value"] == pytest.approx(0.03125)  # binomial(6, 0.5): 2 x 0.5^6
    assert c["verdict"] == REGRESSED
    five = compare(base[:5] + base[6:], worse[:5] + worse[6:], 0.05)  # 5 discordant pairs: p = 0.0625
    assert five["success"]["p_value"] == pytest.approx(0.0625) and five["verdict"] == NO_CHANGE


def test_infeasible_and_failed_runs_leave_the_pairs():
    base = rows(["succeeded", "infeasible", "failed"], [10, 0, 0])
    other = rows(["timeout", "infeasible", "succeeded"], [60, 0, 9])
    assert compare(base, other)["pairs"] == 1


def test_a_variant_whose_every_run_broke_is_inconclusive_and_fails_not_regressed():
    """Every run of the variant failed (crashed or hung): no pair is left, and the comparison said NO SIGNIFICANT
    CHANGE with p = 1, so `not REGRESSED vs baseline` passed. It is INCONCLUSIVE, its failures counted, and the
    check fails naming the variant."""
    from navlog.analysis.ci.campaign_case import evaluate_campaign, parse_campaign_check
    from navlog.campaign.stats import INCONCLUSIVE

    base = rows(["succeeded"] * 8, [10.0] * 8, "baseline")
    broke = rows(["failed"] * 8, [None] * 8)
    c = compare(base, broke)
    assert c["pairs"] == 0 and c["verdict"] == INCONCLUSIVE and c["failed"] == {"baseline": 0, "variant": 8}
    summary = {"baseline": "baseline", "variants": {"baseline": {}, "v": {}}, "comparisons": {"v": c}}
    result = evaluate_campaign(parse_campaign_check("not REGRESSED vs baseline"), summary)
    assert result.status.failed and "v has no pair with baseline (8 of its runs failed)" in result.message
