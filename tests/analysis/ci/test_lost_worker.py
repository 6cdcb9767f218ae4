"""Cases run on the fleet's executors: a case whose worker process dies is one ERROR naming it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from navlog.analysis.ci import Status, run_suite, runner
from navlog.analysis.fleet.executors import ProcessPool


def test_a_case_whose_worker_dies_is_an_error_and_the_others_report(
    teleop_log: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = runner._run_case

    def dies_in_its_replay(job: runner.CaseJob, timings: dict[str, float]) -> object:
        if job.case.name == "dies":
            os._exit(3)  # as a crash in native code or the OOM killer would end the worker
        return real(job, timings)

    # forked workers (created on the first case) inherit the patched runner
    monkeypatch.setattr(runner, "_run_case", dies_in_its_replay)
    suite = tmp_path / "three.navlog-suite.yaml"
    suite.write_text(
        "cases:\n"
        + "".join(
            f"  - {{name: {name}, pipeline: mapping, log: {teleop_log}, overrides: [lidar_mapper=off], "
            "checks: [no_collision]}\n"
            for name in ("first", "dies", "last")
        )
    )
    result = run_suite(
        suite,
        cache_dir=tmp_path / "cache",
        baseline_dir=tmp_path / "b",
        workers=2,
        executor=lambda workers, jobs: ProcessPool(workers, context="fork"),
    )
    assert [c.name for c in result.cases] == ["first", "dies", "last"]
    dead = result.case("dies")
    assert dead.status is Status.ERROR and len(dead.checks) == 1
    assert dead.checks[0].message == "case 'dies': its worker process died (killed, out of memory or crashed)"
    for name in ("first", "last"):
        case = result.case(name)
        assert case.check("no_collision").status is Status.PASS
        assert case.status is not Status.ERROR
