"""Executors: the same results in this process and in a spawned pool; a worker killed with -9 loses
its one job, not the run; retries rerun lost jobs."""

from __future__ import annotations

import pytest

from navlog.analysis.fleet.executors import InProcess, Lost, ProcessPool, run_jobs
from navlog.errors import ConfigError
from tests.analysis.fleet import jobs


def test_in_process_and_pool_give_the_same_results_in_job_order():
    items = list(range(7))
    here = run_jobs(InProcess(), jobs.square, items)
    pool = run_jobs(ProcessPool(2), jobs.square, items)
    assert here == pool == [(n * n, 1) for n in items]


def test_a_worker_killed_with_signal_9_fails_its_job_and_the_others_complete():
    done: list[int] = []
    results = run_jobs(ProcessPool(2), jobs.die_on_minus_one, [3, -1, 4, 5, 6], on_done=lambda i, r, n: done.append(i))
    assert [r for r, _ in results] == [
        9,
        Lost("its worker process died (killed, out of memory or crashed)"),
        16,
        25,
        36,
    ]
    assert sorted(done) == [0, 1, 2, 3, 4]


def test_retries_rerun_a_lost_job(tmp_path):
    marker = tmp_path / "died"
    first = run_jobs(ProcessPool(2), jobs.die_once, [str(marker)], retries=0)
    assert isinstance(first[0][0], Lost) and marker.exists()
    marker.unlink()
    assert run_jobs(ProcessPool(2), jobs.die_once, [str(marker)], retries=1) == [("ok", 2)]


def test_a_pool_needs_a_worker():
    with pytest.raises(ConfigError, match=r"--workers 0: expected 1 or more"):
        ProcessPool(0)


def test_a_job_that_leaves_its_worker_spent_gets_its_result_handed_on_and_its_process_ended():
    """A campaign run that its wall-time limit stopped anywhere (in the middle of an import) left its worker's
    modules half made, and the runs after it there failed with numba's errors. Its process is not reused."""
    results = run_jobs(ProcessPool(1), jobs.pid_spent_on_zero, [1, 0, 2, 3])
    pids = [r for r, _ in results]
    assert all(isinstance(p, int) for p in pids)  # the Spent wrapper is taken off
    assert pids[0] == pids[1] != pids[2] == pids[3]  # a new process after the spent job, kept after it
    assert (
        run_jobs(InProcess(), jobs.pid_spent_on_zero, [0])[0][0]
        == run_jobs(InProcess(), jobs.pid_spent_on_zero, [1])[0][0]
    )
