"""Replay pipelines: one module per pipeline, each with ``Params`` and ``build(params, log_topics)``.

``pipeline_names()`` lists them without importing any (the command line's help stays instant);
``navlog.replay.session`` loads one by name and runs it over a log.
"""

from __future__ import annotations

import pkgutil

__all__ = ["pipeline_names"]


def pipeline_names() -> list[str]:
    """The names of the pipeline modules in this package, sorted."""
    return sorted(m.name for m in pkgutil.iter_modules(__path__))
