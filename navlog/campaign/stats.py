"""A campaign's statistics: per variant rates and means with intervals, and paired comparisons.

- success rate with a 95 % Wilson score interval (``scipy.stats.binomtest(...).proportion_ci``);
- means with 95 % percentile-bootstrap intervals (``scipy.stats.bootstrap``, a fixed seed: the same
  rows give the same intervals);
- two variants on the same worlds, robots, seeds and routes (pairs): exact McNemar on success (a
  two-sided binomial test on the discordant pairs, ``binomtest(c, b + c, 0.5)``) and Wilcoxon's
  signed-rank test on time and path length over the pairs both variants succeeded in. Verdict at
  level ``alpha``: REGRESSED when any test is significant in the worse direction (lower success,
  longer time or path), IMPROVED when at least one is significant in the better direction and none
  in the worse, else NO SIGNIFICANT CHANGE. Each test is at ``alpha`` (no correction for the three).

Infeasible routes are left out of every rate; ``failed`` runs (the run itself broke: a crash, a hang)
count as failures of the variant in its rate but drop their pair from the comparison.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

BOOTSTRAP_RESAMPLES = 2000
BOOTSTRAP_SEED = 0
IMPROVED, REGRESSED, NO_CHANGE = "IMPROVED", "REGRESSED", "NO SIGNIFICANT CHANGE"
INCONCLUSIVE = "INCONCLUSIVE"  # no pair to compare: every run of one side failed (broke) or none was paired


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float] | None:
    """The Wilson score interval of a proportion, or None for n = 0."""
    from scipy.stats import binomtest

    if n == 0:
        return None
    ci = binomtest(successes, n).proportion_ci(confidence_level=confidence, method="wilson")
    return float(ci.low), float(ci.high)


def mean_interval(values: list[Any], confidence: float = 0.95) -> dict[str, Any] | None:
    """Mean, 95 % percentile-bootstrap interval and count of the finite ``values`` (None when empty)."""
    from scipy.stats import bootstrap

    v = np.asarray([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if not len(v):
        return None
    out: dict[str, Any] = {"mean": round(float(v.mean()), 4), "n": len(v)}
    if len(v) > 1 and np.ptp(v) > 0:
        res = bootstrap(
            (v,),
            np.mean,
            confidence_level=confidence,
            n_resamples=BOOTSTRAP_RESAMPLES,
            method="percentile",
            rng=np.random.default_rng(BOOTSTRAP_SEED),
        )
        out["ci"] = [round(float(res.confidence_interval.low), 4), round(float(res.confidence_interval.high), 4)]
    else:
        out["ci"] = [out["mean"], out["mean"]]
    return out


def variant_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Counts by result, success rate (Wilson) and means (bootstrap) of one variant's rows."""
    counts = dict.fromkeys(("succeeded", "collision", "timeout", "aborted", "failed", "infeasible"), 0)
    for row in rows:
        counts[row["result"]] = counts.get(row["result"], 0) + 1
    runs = [r for r in rows if r["result"] != "infeasible"]
    ok = [r for r in runs if r["result"] == "succeeded"]
    n, k = len(runs), len(ok)
    ci = wilson_interval(k, n)
    return {
        "runs": n,
        **counts,
        "success_rate": round(k / n, 4) if n else None,
        "success_ci": [round(ci[0], 4), round(ci[1], 4)] if ci else None,
        "collision_rate": round(counts["collision"] / n, 4) if n else None,
        "barn_metric": mean_interval([r.get("barn_metric", 0.0) for r in runs]),
        "time_s": mean_interval([r["time_s"] for r in ok]),
        "path_length_m": mean_interval([r.get("path_length_m") for r in ok]),
        "min_clearance_m": mean_interval([r.get("min_clearance_m") for r in runs if "sim_s" in r]),
        "recoveries": mean_interval([r.get("recoveries") for r in runs if "sim_s" in r]),
        "speed_mean": mean_interval([r.get("speed_mean") for r in ok]),
        "jerk_max": mean_interval([r.get("jerk_max") for r in ok]),
    }


def _pair_key(row: dict[str, Any]) -> tuple[Any, ...]:
    return (row["world"], row["robot"], row["seed"], row["route"])


def _wilcoxon(diff: np.ndarray) -> float:
    """Two-sided p-value of Wilcoxon's signed-rank test on paired differences (1.0 when all are zero)."""
    from scipy.stats import wilcoxon

    if not len(diff) or not np.any(diff != 0):
        return 1.0
    return float(wilcoxon(diff).pvalue)


def compare(base: list[dict[str, Any]], other: list[dict[str, Any]], alpha: float = 0.05) -> dict[str, Any]:
    """The paired comparison of ``other`` against ``base`` (module docstring)."""
    from scipy.stats import binomtest

    by_key = {_pair_key(r): r for r in base if r["result"] not in ("infeasible", "failed")}
    pairs = [
        (by_key[_pair_key(r)], r)
        for r in other
        if _pair_key(r) in by_key and r["result"] not in ("infeasible", "failed")
    ]
    b = sum(a["result"] == "succeeded" and o["result"] != "succeeded" for a, o in pairs)  # lost successes
    c = sum(a["result"] != "succeeded" and o["result"] == "succeeded" for a, o in pairs)  # gained successes
    p_success = float(binomtest(c, b + c, 0.5).pvalue) if b + c else 1.0
    both = [(a, o) for a, o in pairs if a["result"] == o["result"] == "succeeded"]
    out: dict[str, Any] = {
        "pairs": len(pairs),
        "failed": {
            "baseline": sum(r["result"] == "failed" for r in base),
            "variant": sum(r["result"] == "failed" for r in other),
        },
        "success": {"lost": b, "gained": c, "p_value": round(p_success, 6), "test": "exact McNemar"},
    }
    worse: list[str] = []
    better: list[str] = []
    if b + c and p_success < alpha:
        (worse if b > c else better).append("success")
    for name in ("time_s", "path_length_m"):
        d = np.asarray(
            [o[name] - a[name] for a, o in both if a.get(name) is not None and o.get(name) is not None], dtype=float
        )
        p = _wilcoxon(d)
        median = float(np.median(d)) if len(d) else 0.0
        out[name] = {"pairs": len(d), "median_difference": round(median, 4), "p_value": round(p, 6), "test": "Wilcoxon"}
        if p < alpha and median != 0:
            (worse if median > 0 else better).append(name)
    out["worse"], out["better"] = worse, better
    out["verdict"] = INCONCLUSIVE if not pairs else REGRESSED if worse else IMPROVED if better else NO_CHANGE
    out["alpha"] = alpha
    return out


def summarize(rows: list[dict[str, Any]], spec: Any, worlds: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The campaign's summary: per variant, and each variant against the baseline."""
    variants = [v.name for v in spec.variants]
    by_variant = {v: [r for r in rows if r["variant"] == v] for v in variants}
    base = spec.baseline_variant
    return {
        "campaign": spec.name,
        "runs": len(rows),
        "baseline": base,
        "alpha": spec.alpha,
        "variants": {v: variant_summary(rs) for v, rs in by_variant.items() if rs},
        "comparisons": {
            v: compare(by_variant[base], by_variant[v], spec.alpha) for v in variants if v != base and by_variant[v]
        },
        "worlds": worlds,
    }
