"""Invariants of a CI case: ``NAME`` (a flag) or ``PATH OP NUMBER``, judged on the facts of a replay.

Facts (see ``facts.py``) by pipeline, as each declares them (``PipelineSpec.facts``):
- any: ``events.KIND`` (navigation events by kind, in the log and the replay: ``events.collision``),
  flag ``no_collision`` (no ``collision`` event);
- mapping: ``metrics.PATH`` into the metrics of ``navlog metrics`` (``metrics.trajectory.ate.translation_m.rmse``,
  ``metrics.map_2d.iou``; short forms ``metrics.ate.rmse`` and ``metrics.rpe.rmse``, translation in m);
- planner: ``plans.count``, ``plans.failures``, ``plans.length_m.max|min|mean``, ``plans.cost.max``,
  ``goals.total``, ``goals.reached``, ``min_clearance`` (m, from every /plan pose to the nearest
  occupied cell of the static map), flags ``all_goals_reached`` and ``no_plan_failures``;
- safety: ``safety.PATH`` into safety.json (``safety.collision_monitor.stopped_s``);
- navigation: ``navigation.PATH`` into navigation.json (``navigation.succeeded``, ``navigation.failed``),
  ``goals.*``, ``min_clearance`` and ``all_goals_reached`` as for the planner (goals: ``goal_succeeded``
  events), ``safety.PATH`` when its Nav2 file runs the safety filters.

Operators: ``<=``, ``<``, ``>=``, ``>``, ``==``, ``!=``. A name outside these is refused when the suite
is read, with a did-you-mean; a fact the replay cannot give is an ERROR of that check.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from navlog.analysis.ci.result import CheckResult, Status
from navlog.analysis.tables import figure
from navlog.errors import ConfigError
from navlog.replay.config import suggest

__all__ = ["FLAGS", "ROOTS", "Invariant", "evaluate", "parse_invariant"]

OPS: dict[str, Callable[[float, float], bool]] = {
    "<=": operator.le,
    ">=": operator.ge,
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    ">": operator.gt,
}
# the flags and the first parts of numeric facts' paths ``case_facts`` gives; which a pipeline's
# replays give is the pipeline's to say (``PipelineSpec.facts``)
FLAGS = ("no_collision", "all_goals_reached", "no_plan_failures")
ROOTS = ("events", "metrics", "plans", "goals", "min_clearance", "safety", "navigation")
_COMPARISON = re.compile(r"^\s*([A-Za-z_][\w.\[\]@-]*)\s*(<=|>=|==|!=|<|>)\s*(\S+)\s*$")


@dataclass(frozen=True)
class Invariant:
    text: str  # as written in the suite
    path: str  # the fact it reads
    op: str | None = None  # None: a flag
    value: float | None = None

    def roots(self) -> str:
        return self.path.split(".", 1)[0]


def parse_invariant(text: str, pipeline: str) -> Invariant:
    """One invariant of a case of ``pipeline``; unknown names raise ``ConfigError`` with a did-you-mean."""
    text = text.strip()
    found = _COMPARISON.match(text)
    if found is None:
        if text not in FLAGS:
            known = [*FLAGS, *(f"{r} <= N" for r in ROOTS)]
            raise ConfigError(
                f"unknown check '{text}'{suggest(text, list(FLAGS) + list(ROOTS))}; known: {', '.join(known)}"
            )
        _for_pipeline(text, pipeline, text)
        return Invariant(text, text)
    path, op, raw = found.groups()
    root = path.split(".", 1)[0]
    if root not in ROOTS:
        raise ConfigError(f"'{text}': unknown fact '{root}'{suggest(root, ROOTS)}; facts start with {', '.join(ROOTS)}")
    _for_pipeline(text, pipeline, root)
    try:
        value = float(raw)
    except ValueError:
        raise ConfigError(f"'{text}': '{raw}' is not a number") from None
    return Invariant(text, path, op, value)


def _for_pipeline(text: str, pipeline: str, name: str) -> None:
    """The fact or flag ``name`` is one that ``pipeline``'s replays give; else ConfigError naming those that do."""
    from navlog.replay.pipelines import pipeline_spec, pipeline_specs

    if name not in pipeline_spec(pipeline).facts:
        givers = [s.name for s in pipeline_specs() if name in s.facts]
        raise ConfigError(f"'{text}': {name} comes from a {' or '.join(givers)} case, not a {pipeline} case")


def evaluate(inv: Invariant, facts: Mapping[str, float | bool]) -> CheckResult:
    """PASS or FAIL with the value found; ERROR (naming the facts there are) when the fact is missing."""
    name = inv.text
    if inv.path not in facts:
        near = [k for k in facts if k.split(".", 1)[0] == inv.roots()] or list(facts)
        return CheckResult(
            name,
            "invariant",
            Status.ERROR,
            f"no fact '{inv.path}' in this replay{suggest(inv.path, near)}; there are: {', '.join(sorted(near)[:12])}",
        )
    got = facts[inv.path]
    if inv.op is None:
        ok = bool(got)
        return CheckResult(name, "invariant", Status.PASS if ok else Status.FAIL, f"{inv.path} is {ok}", {"value": ok})
    assert inv.value is not None
    value = float(got)
    ok = not math.isnan(value) and OPS[inv.op](value, inv.value)
    message = f"{inv.path} = {figure(value)}" + ("" if ok else f", expected {inv.op} {inv.value:g}")
    return CheckResult(
        name, "invariant", Status.PASS if ok else Status.FAIL, message, {"value": value, "limit": inv.value}
    )
