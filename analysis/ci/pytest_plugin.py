"""pytest plugin (entry point ``pytest11``): a CI suite's cases as tests.

When enabled — ``--navlog-suites`` on the command line, or ``navlog_suites = true`` in the pytest
ini options — pytest collects every ``*.navlog-suite.yaml`` file below its paths; the suites given
with ``--navlog-suite FILE`` are collected either way (a plain ``pytest`` run never reads a suite
file it was not asked for); each case is one test, whose failure lists every check (the sub-results)
with its status. The case's facts go to the JUnit report as properties. ``--navlog-update`` rewrites
the baselines (``--update``), ``--navlog-update-new`` writes the missing ones; ``--navlog-cache`` and
``--navlog-baselines`` choose the folders. Each test runs its case alone, so ``pytest -n auto``
(pytest-xdist) spreads cases over workers; the cache is safe to share between them.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from navlog.errors import NavlogError

SUFFIX = ".navlog-suite.yaml"


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("navlog", "navlog replay-and-diff suites")
    group.addoption("--navlog-suites", action="store_true", help="collect every *.navlog-suite.yaml file as tests")
    group.addoption("--navlog-suite", action="append", default=[], metavar="FILE", help="run this navlog CI suite")
    group.addoption("--navlog-update", action="store_true", help="rewrite the suites' baselines")
    group.addoption("--navlog-update-new", action="store_true", help="write the suites' missing baselines")
    group.addoption("--navlog-cache", metavar="DIR", help="the navlog CI cache folder")
    group.addoption("--navlog-baselines", metavar="DIR", help="the baselines folder")
    parser.addini("navlog_suites", "collect every *.navlog-suite.yaml file as tests", type="bool", default=False)


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    config = parent.config
    enabled = config.getoption("navlog_suites") or config.getini("navlog_suites")
    if enabled and file_path.name.endswith(SUFFIX):
        suite: pytest.Collector = SuiteFile.from_parent(parent, path=file_path)
        return suite
    return None


def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config, items: list[pytest.Item]) -> None:
    for name in config.getoption("navlog_suite"):
        path = Path(name).resolve()
        if not path.is_file():
            raise pytest.UsageError(f"--navlog-suite {name}: no such file")
        if any(isinstance(i, CaseItem) and i.path == path for i in items):
            continue
        items.extend(SuiteFile.from_parent(session, path=path).collect())


class CaseFailed(Exception):
    """A case did not pass; the message lists its checks."""


class SuiteFile(pytest.File):
    def collect(self) -> Iterator[pytest.Item]:
        from navlog.analysis.ci.suite import load_suite

        try:
            suite = load_suite(self.path)
        except NavlogError as exc:
            raise self.CollectError(str(exc)) from None
        for case in suite.cases:
            yield CaseItem.from_parent(self, name=case.name)


class CaseItem(pytest.Item):
    def runtest(self) -> None:
        from navlog.analysis.ci.runner import run_suite

        opt = self.config.getoption
        result = run_suite(
            self.path,
            update=bool(opt("navlog_update")),
            update_new=bool(opt("navlog_update_new")),
            cache_dir=opt("navlog_cache"),
            baseline_dir=opt("navlog_baselines"),
            cases=[self.name],
        )
        case = result.cases[0]
        self.user_properties += [("status", str(case.status)), *sorted(case.facts.items())]
        if case.status.failed:
            lines = [f"{case.status}: case {case.name} ({case.pipeline}, {case.source})"]
            lines += [f"  {c.status:<16} {c.kind} {c.name}: {c.message}" for c in case.checks]
            lines += [f"  note: {n}" for n in case.notes]
            raise CaseFailed("\n".join(lines))

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException], style: Any = None) -> str:
        if isinstance(excinfo.value, CaseFailed | NavlogError):
            return str(excinfo.value)
        return str(super().repr_failure(excinfo))

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"navlog case {self.name}"
