"""Is a log fit to replay? The input checks of ``navlog check`` (and of a CI case's INVALID_INPUT).

``check_log(log, *, require=(), rates=None, frames=(), pipeline=None, options=None) -> LogCheck`` reads
a log once, as a stream, and checks: file integrity (a truncated MCAP with its readable span), message
types, required topics (did-you-mean on a misspelled one), rates against the expected or the median
rate, gaps beyond k x the median period, log times and header stamps only going forward, NaN/inf in
scans, and TF coverage of frame chains (``map`` -> ``base_link``). Each ``Check`` has a name, a
``Status`` (PASS, WARN, FAIL), its numbers and a one-line message naming the topic and a fix; the
``LogCheck`` holds them with each topic's ``TopicFigures``, as plain data (``to_dict``, ``to_json``)
and as text (``format_check``). ``CheckOptions`` holds the tolerances; ``parse_frames`` and
``parse_rates`` read ``map:base_link`` and ``/scan=10``; ``pipeline_inputs`` names the topics a replay
pipeline needs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.analysis.check.checks import CheckOptions
    from navlog.analysis.check.log_check import check_log, parse_frames, parse_rates, pipeline_inputs
    from navlog.analysis.check.result import Check, LogCheck, Status, TopicFigures, format_check

__all__ = [
    "Check",
    "CheckOptions",
    "LogCheck",
    "Status",
    "TopicFigures",
    "check_log",
    "format_check",
    "parse_frames",
    "parse_rates",
    "pipeline_inputs",
]

# the module, below this package, that defines each public name
_MODULES = {
    "check_log": "log_check",
    "parse_frames": "log_check",
    "parse_rates": "log_check",
    "pipeline_inputs": "log_check",
    "CheckOptions": "checks",
    "Check": "result",
    "LogCheck": "result",
    "Status": "result",
    "TopicFigures": "result",
    "format_check": "result",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
