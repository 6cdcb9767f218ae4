"""What moved between two replays or two logs: ``diff(a, b)`` and its comparators, for ``navlog diff``
and the CI gate built on it.

- ``diff(a, b, *, tolerances=DiffTolerances(), ignore=())`` -> ``DiffReport``: two replay output
  folders (through their manifests), two logs (topic by topic), or two map/PCD/TUM/JSON files;
- tolerances: ``DiffTolerances`` with one section per comparator (``GridTolerance``,
  ``PointsTolerance``, ``PathTolerance``, ``TwistTolerance``, ``TrajectoryTolerance``,
  ``MetricTolerance``, ``FieldTolerance``), ``parse_tolerances`` for ``SECTION.FIELD=VALUE`` text;
- results as plain data: ``DiffReport``, ``Check``, ``Verdict``, ``Divergence``;
- comparators, each returning a ``Check``: ``compare_grids``, ``compare_points``, ``compare_plans``,
  ``compare_twists``, ``compare_trajectories``, ``compare_metric_values`` (a list), and
  ``field_differences`` for any message; ``compare_logs`` for two logs;
- reports: ``format_report`` (text table), ``to_json`` (deterministic bytes), ``to_markdown``;
  ``save_overlay`` draws A and B overlaid in a Rerun ``.rrd`` (Rerun loads when it is called).

Names are imported on first use, so importing the package loads neither numpy nor scipy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.analysis.diff.core import DiffInputError, diff
    from navlog.analysis.diff.fields import FieldDifference, field_differences
    from navlog.analysis.diff.grids import compare_grids
    from navlog.analysis.diff.logs import compare_logs
    from navlog.analysis.diff.metric_values import compare_metric_values
    from navlog.analysis.diff.overlay import save_overlay
    from navlog.analysis.diff.paths import compare_plans
    from navlog.analysis.diff.points import compare_points
    from navlog.analysis.diff.report import format_report, to_json, to_markdown
    from navlog.analysis.diff.result import Check, DiffReport, Divergence, Verdict
    from navlog.analysis.diff.tolerances import (
        DiffTolerances,
        FieldTolerance,
        GridTolerance,
        MetricTolerance,
        PathTolerance,
        PointsTolerance,
        TrajectoryTolerance,
        TwistTolerance,
        parse_tolerances,
    )
    from navlog.analysis.diff.trajectories import compare_trajectories
    from navlog.analysis.diff.twists import compare_twists

__all__ = [
    "Check",
    "DiffInputError",
    "DiffReport",
    "DiffTolerances",
    "Divergence",
    "FieldDifference",
    "FieldTolerance",
    "GridTolerance",
    "MetricTolerance",
    "PathTolerance",
    "PointsTolerance",
    "TrajectoryTolerance",
    "TwistTolerance",
    "Verdict",
    "compare_grids",
    "compare_logs",
    "compare_metric_values",
    "compare_plans",
    "compare_points",
    "compare_trajectories",
    "compare_twists",
    "diff",
    "field_differences",
    "format_report",
    "parse_tolerances",
    "save_overlay",
    "to_json",
    "to_markdown",
]

# public name -> the module of this package that defines it
_MODULES = {
    "DiffInputError": "core",
    "diff": "core",
    "FieldDifference": "fields",
    "field_differences": "fields",
    "compare_grids": "grids",
    "compare_logs": "logs",
    "compare_metric_values": "metric_values",
    "save_overlay": "overlay",
    "compare_plans": "paths",
    "compare_points": "points",
    "format_report": "report",
    "to_json": "report",
    "to_markdown": "report",
    "Check": "result",
    "DiffReport": "result",
    "Divergence": "result",
    "Verdict": "result",
    "DiffTolerances": "tolerances",
    "FieldTolerance": "tolerances",
    "GridTolerance": "tolerances",
    "MetricTolerance": "tolerances",
    "PathTolerance": "tolerances",
    "PointsTolerance": "tolerances",
    "TrajectoryTolerance": "tolerances",
    "TwistTolerance": "tolerances",
    "parse_tolerances": "tolerances",
    "compare_trajectories": "trajectories",
    "compare_twists": "twists",
}

__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
