"""A CI case of kind ``campaign``: a campaign file run, its summary judged by thresholds.

```yaml
  - name: barn_smoke
    kind: campaign
    campaign: ../../examples/campaigns/small.yaml    # relative to the suite file
    checks:
      - success_rate >= 0.9           # every variant's success rate (infeasible routes left out)
      - success_rate.baseline >= 0.95 # one variant's
      - collisions == 0               # runs that touched the world, per variant
      - not REGRESSED vs baseline     # no variant's verdict against the baseline is REGRESSED
```

Facts per variant (``FACTS``): ``success_rate``, ``collisions``, ``timeouts``, ``aborted``, ``failed``,
``infeasible``, ``runs``, ``barn_metric`` and ``time_s`` (means). A threshold without a variant must
hold for every variant; a failing one names the variant and the measured value. The campaign itself
runs above this layer (``navlog.campaign``): ``run_suite`` is handed the function that runs it
(``campaign_runner``; ``navlog ci run`` hands ``navlog.campaign.run_campaign_case``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from navlog.analysis.ci.invariants import OPS
from navlog.analysis.ci.result import CheckResult, Status
from navlog.errors import ConfigError
from navlog.replay.config import suggest

__all__ = ["FACTS", "CampaignCheck", "CampaignRunner", "campaign_facts", "evaluate_campaign", "parse_campaign_check"]

# the campaign's summary for a campaign file run into an output folder
CampaignRunner = Callable[[Path, Path], Mapping[str, Any]]
FACTS = ("success_rate", "collisions", "timeouts", "aborted", "failed", "infeasible", "runs", "barn_metric", "time_s")
_COMPARISON = re.compile(r"^\s*([A-Za-z_]\w*)(?:\.([A-Za-z0-9_-]+))?\s*(<=|>=|==|!=|<|>)\s*(\S+)\s*$")
_NOT_REGRESSED = re.compile(r"^\s*not\s+REGRESSED\s+vs\s+baseline\s*$")


@dataclass(frozen=True)
class CampaignCheck:
    text: str  # as written in the suite
    fact: str = ""  # one of FACTS; "" for the verdict check
    variant: str = ""  # "": every variant
    op: str = ""
    value: float = math.nan


def parse_campaign_check(text: str) -> CampaignCheck:
    """``FACT[.VARIANT] OP NUMBER`` or ``not REGRESSED vs baseline``; anything else is a ConfigError."""
    if _NOT_REGRESSED.match(text):
        return CampaignCheck(text.strip())
    found = _COMPARISON.match(text)
    if found is None:
        raise ConfigError(
            f"unknown campaign check '{text}': expected FACT[.VARIANT] OP NUMBER (e.g. success_rate >= 0.9) "
            "or 'not REGRESSED vs baseline'"
        )
    fact, variant, op, raw = found.groups()
    if fact not in FACTS:
        raise ConfigError(f"'{text}': unknown campaign fact '{fact}'{suggest(fact, FACTS)}; known: {', '.join(FACTS)}")
    try:
        value = float(raw)
    except ValueError:
        raise ConfigError(f"'{text}': '{raw}' is not a number") from None
    return CampaignCheck(text.strip(), fact, variant or "", op, value)


def campaign_facts(summary: Mapping[str, Any]) -> dict[str, float]:
    """``FACT.VARIANT`` -> value of every variant of a campaign summary (``navlog.campaign.stats.summarize``)."""
    out: dict[str, float] = {}
    for name, v in summary["variants"].items():
        rate = v.get("success_rate")
        values = {
            "success_rate": math.nan if rate is None else rate,
            "collisions": v.get("collision", 0),
            "timeouts": v.get("timeout", 0),
            "aborted": v.get("aborted", 0),
            "failed": v.get("failed", 0),
            "infeasible": v.get("infeasible", 0),
            "runs": v.get("runs", 0),
            "barn_metric": (v.get("barn_metric") or {}).get("mean", math.nan),
            "time_s": (v.get("time_s") or {}).get("mean", math.nan),
        }
        out.update({f"{fact}.{name}": float(x) for fact, x in values.items()})
    return out


def evaluate_campaign(check: CampaignCheck, summary: Mapping[str, Any]) -> CheckResult:
    """PASS or FAIL naming each variant that misses and its measured value; ERROR for an unknown variant."""
    variants = list(summary["variants"])
    if not check.fact:
        base = summary.get("baseline", "")
        worse = {n: c for n, c in summary.get("comparisons", {}).items() if c.get("verdict") == "REGRESSED"}
        unknown = {n: c for n, c in summary.get("comparisons", {}).items() if c.get("verdict") == "INCONCLUSIVE"}
        if unknown:  # nothing to compare is no evidence against a regression
            what = "; ".join(
                f"{n} has no pair with {base} ({c.get('failed', {}).get('variant', 0)} of its runs failed)"
                for n, c in unknown.items()
            )
            return CheckResult(check.text, "invariant", Status.FAIL, what, {"inconclusive": sorted(unknown)})
        if not worse:
            return CheckResult(
                check.text, "invariant", Status.PASS, f"no variant REGRESSED against '{base}'", {"regressed": []}
            )
        what = "; ".join(f"{n} REGRESSED vs {base} on {', '.join(c.get('worse', []))}" for n, c in worse.items())
        return CheckResult(check.text, "invariant", Status.FAIL, what, {"regressed": sorted(worse)})
    if check.variant and check.variant not in variants:
        return CheckResult(
            check.text,
            "invariant",
            Status.ERROR,
            f"no variant '{check.variant}' in the campaign{suggest(check.variant, variants)}; "
            f"variants: {', '.join(variants)}",
        )
    facts = campaign_facts(summary)
    names = [check.variant] if check.variant else variants
    got = {n: facts[f"{check.fact}.{n}"] for n in names}
    missed = {n: x for n, x in got.items() if math.isnan(x) or not OPS[check.op](x, check.value)}
    shown = ", ".join(f"{check.fact}.{n} = {x:.6g}" for n, x in got.items())
    if missed:
        bad = ", ".join(f"{check.fact}.{n} = {x:.6g}" for n, x in missed.items())
        return CheckResult(
            check.text,
            "invariant",
            Status.FAIL,
            f"{bad}, expected {check.op} {check.value:g}",
            {"values": got, "limit": check.value},
        )
    return CheckResult(check.text, "invariant", Status.PASS, shown, {"values": got, "limit": check.value})
