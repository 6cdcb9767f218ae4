"""The replay-and-diff CI gate: suites of golden logs replayed through the pipelines and judged against
committed baselines and invariants (``navlog ci run``, and a pytest plugin).

- ``load_suite(path)`` -> ``Suite`` of ``Case``s (a log or a ``Recipe``, a pipeline with parameters,
  overrides and remaps, a ``DiffCheck`` and invariants), checked once with did-you-mean;
- ``run_suite(path, *, update=False, update_new=False, determinism=False, overrides=(), workers=1,
  cache_dir=None, baseline_dir=None)`` -> ``SuiteResult`` of ``CaseResult``s of ``CheckResult``s with a
  ``Status`` each (PASS, IMPROVED, NEW, FAIL, NONDETERMINISTIC, INVALID_INPUT, ERROR) and an exit code;
- baselines: ``read_baseline``, ``write_baseline``, ``compare_to_baseline``;
- reports: ``format_result`` (text), ``to_json`` (deterministic), ``to_junit``, ``to_markdown``,
  ``write_reports``;
- invariants: ``parse_invariant``, ``evaluate``, ``case_facts``.

Names are imported on first use: importing the package loads no numpy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.analysis.ci.baselines import Baseline, compare_to_baseline, read_baseline, write_baseline
    from navlog.analysis.ci.facts import case_facts
    from navlog.analysis.ci.invariants import Invariant, evaluate, parse_invariant
    from navlog.analysis.ci.reports import format_result, to_json, to_junit, to_markdown, write_reports
    from navlog.analysis.ci.result import CaseResult, CheckResult, Status, SuiteResult
    from navlog.analysis.ci.runner import run_suite
    from navlog.analysis.ci.suite import Case, DiffCheck, Recipe, Suite, WorldMap, load_suite

__all__ = [
    "Baseline",
    "Case",
    "CaseResult",
    "CheckResult",
    "DiffCheck",
    "Invariant",
    "Recipe",
    "Status",
    "Suite",
    "SuiteResult",
    "WorldMap",
    "case_facts",
    "compare_to_baseline",
    "evaluate",
    "format_result",
    "load_suite",
    "parse_invariant",
    "read_baseline",
    "run_suite",
    "to_json",
    "to_junit",
    "to_markdown",
    "write_baseline",
    "write_reports",
]

# public name -> the module of this package that defines it
_MODULES = {
    "Baseline": "baselines",
    "compare_to_baseline": "baselines",
    "read_baseline": "baselines",
    "write_baseline": "baselines",
    "case_facts": "facts",
    "Invariant": "invariants",
    "evaluate": "invariants",
    "parse_invariant": "invariants",
    "format_result": "reports",
    "to_json": "reports",
    "to_junit": "reports",
    "to_markdown": "reports",
    "write_reports": "reports",
    "CaseResult": "result",
    "CheckResult": "result",
    "Status": "result",
    "SuiteResult": "result",
    "run_suite": "runner",
    "Case": "suite",
    "DiffCheck": "suite",
    "Recipe": "suite",
    "Suite": "suite",
    "WorldMap": "suite",
    "load_suite": "suite",
}

__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
