"""The ring transport with a real child: results by ticket, in request order, the same bytes through the
shared ring or the pipe; requests queued here while the child does not read; errors and death named."""

from __future__ import annotations

import os
import signal
import threading
from pathlib import Path

import pytest

from navlog.errors import NavlogError
from navlog.replay.workers import ring as ring_module
from navlog.replay.workers.ring import RingProcess, _Ring
from tests.replay.workers.ring_handler import FAIL, PRINT, expected, request

REPO = Path(__file__).resolve().parents[3]
HANDLER = "tests.replay.workers.ring_handler:make"
ENV = {"PYTHONPATH": str(REPO)}  # the child imports the handler from the tests


def start(ring_bytes: int = 1 << 20, setup: bytes = b"") -> RingProcess:
    return RingProcess("test child", HANDLER, setup, ring_bytes, run="test", env=ENV)


def test_the_ring_puts_results_in_order_and_never_over_one_not_taken() -> None:
    ring = _Ring(100)
    assert [ring.place(t, 30, 0) for t in range(3)] == [0, 30, 60]
    assert ring.place(3, 30, 0) is None  # 10 bytes left at the end, none at the start: nothing taken yet
    assert ring.place(3, 10, 0) == 90  # fits exactly at the end
    assert ring.place(4, 25, 1) == 0  # result 0 taken: its 30 bytes at the start are free again
    assert ring.place(5, 6, 1) is None  # 5 bytes before result 1 (at 30) is all there is
    assert ring.place(5, 35, 3) == 25  # 1 and 2 taken: room from 25 to the start of 3 (at 90)
    assert ring.place(6, 31, 6) == 0  # all taken: from the start again
    assert ring.place(7, 101, 7) is None  # larger than the ring


# 400 results of 20 kB and 400 of 3 kB, asked for by requests of 3 kB (400 of them are more than the
# request pipe's 1 MiB holds, one 4 KiB page each)
SIZES = [(20_000 if k % 2 == 0 else 3_000, k) for k in range(800)]


@pytest.mark.parametrize(
    ("ring_bytes", "shared", "piped"),
    [(10_000_000, True, (0, 0)), (8192, True, (400, 800)), (0, True, (800, 800)), (10_000_000, False, (800, 800))],
    ids=["ring", "small-ring", "no-ring", "no-shared-memory"],
)
def test_results_come_through_the_ring_or_the_pipe_with_the_same_bytes(ring_bytes, shared, piped, monkeypatch):
    """All in a ring that holds them all; in a ring of 8 kB the 3 kB ones at most (one goes through the pipe
    when the child ran 3 results ahead); everything through the pipe with no ring, or no shared memory at all
    (a file-size limit of 0 forbids it). The requests, made without waiting, are more than the request pipe
    holds and the piped results more than the result pipe holds, so the results must be taken while the
    queued requests are sent."""
    if not shared:
        monkeypatch.setattr(ring_module, "_shared_file", lambda size: None)
    child = start(ring_bytes)
    got: list[bytes] = []

    def run() -> None:
        tickets = [child.request(request(size, seed, pad=3000)) for size, seed in SIZES]
        got.extend(child.result(t) for t in tickets)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(timeout=120)
    stuck = thread.is_alive()
    child.close()  # also ends a stuck thread: its pipes close
    assert not stuck, "the child and this process wait on each other"
    assert got == [expected(size, seed) for size, seed in SIZES]
    assert all(type(g) is bytes for g in got)
    assert piped[0] <= child.piped <= piped[1]
    assert child.process.returncode == 0  # ended by its closed input, and waited for: no zombie


def test_requests_the_pipe_has_no_room_for_wait_in_this_process_while_the_child_is_stopped() -> None:
    """The child stopped (as if still importing its libraries): 400 requests of 3 kB are more than the
    request pipe holds (1 MiB, one 4 KiB page a request), yet every request returns at once, the rest
    queued here; resumed, the child answers them all, in order."""
    child = start()
    try:
        os.kill(child.process.pid, signal.SIGSTOP)
        try:
            tickets = [child.request(request(3000, k, pad=3000)) for k in range(400)]
            assert tickets == list(range(400))
            assert 400 - (1 << 20) // 4096 <= len(child._pipe.unsent) < 400  # the pipe took what it holds
            assert not child.ready(0)
        finally:
            os.kill(child.process.pid, signal.SIGCONT)
        assert child.result(399) == expected(3000, 399)  # waits for room for the last, taking the rest
        assert not child._pipe.unsent
        got = [child.result(t) for t in tickets[:-1]]
        with pytest.raises(ValueError, match="no result 0 is owed"):
            child.result(0)  # each result is given once
        with pytest.raises(ValueError, match="no result 400 is owed"):
            child.result(400)  # not asked for
    finally:
        child.close()
    assert got == [expected(3000, k) for k in range(399)]


@pytest.mark.parametrize("shared", [True, False], ids=["ring", "no-shared-memory"])
def test_the_handler_is_told_when_the_caller_only_waits_for_the_rest(shared, monkeypatch) -> None:
    if not shared:
        monkeypatch.setattr(ring_module, "_shared_file", lambda size: None)
    child = start()
    try:
        before = [child.result(child.request(request(10, k))) for k in range(3)]
        child.ending()
        after = [child.result(child.request(request(10, k))) for k in range(3, 6)]
    finally:
        child.close()
    child.ending()  # after close: nothing
    assert before == [expected(10, k) for k in range(3)]
    assert after == [expected(10, k, ending=shared) for k in range(3, 6)]  # without shared memory: never told


def test_what_the_child_prints_does_not_reach_the_results() -> None:
    child = start()
    try:
        tickets = [child.request(request(50, 1)), child.request(request(PRINT, 2)), child.request(request(50, 3))]
        assert [child.result(t) for t in tickets] == [expected(50, 1), expected(100, 2), expected(50, 3)]
    finally:
        child.close()


def test_an_error_in_the_handler_is_raised_with_its_traceback_naming_the_child() -> None:
    child = start()
    first = child.request(request(10, 1))
    failing = child.request(request(FAIL, 7))
    assert child.result(first) == expected(10, 1)
    with pytest.raises(NavlogError, match=r"test child \(pid \d+\) failed:") as info:
        child.result(failing)
    assert "Traceback" in str(info.value) and "ValueError: request 7 fails" in str(info.value)
    assert child.process.returncode == 0  # it sent its error and left; closed and waited for
    with pytest.raises(NavlogError, match=r"test child \(pid \d+\) ended unexpectedly \(exit code 0\)"):
        child.request(request(10, 2))  # closed: named, not a broken pipe


def test_an_error_building_the_handler_is_raised_with_its_traceback() -> None:
    child = start(setup=b"fail")
    with pytest.raises(NavlogError, match=r"test child \(pid \d+\) failed:") as info:
        child.result(child.request(request(10, 1)))
    assert "ValueError: no handler for this setup" in str(info.value)


def test_requests_after_the_child_failed_raise_its_error_not_a_broken_pipe() -> None:
    child = start()
    child.request(request(FAIL, 3))  # the child fails on it and ends
    child.process.wait(timeout=60)
    with pytest.raises(NavlogError, match=r"test child \(pid \d+\) failed:") as info:
        for k in range(400):  # its pipe is broken: a write fails (or the pipe fills, then a result is awaited)
            child.request(request(10, k, pad=3000))
        child.result(0)
    assert "ValueError: request 3 fails" in str(info.value)
    assert child.process.returncode == 0


def test_a_child_killed_is_an_error_naming_it_with_its_exit_code() -> None:
    child = start()
    assert child.result(child.request(request(10, 1))) == expected(10, 1)
    ticket = child.request(request(10, 2))
    child.result(ticket)
    os.kill(child.process.pid, signal.SIGKILL)
    child.process.wait(timeout=60)
    with pytest.raises(
        NavlogError, match=r"test child \(pid \d+\) ended unexpectedly \(exit code -9\); the test stops"
    ):
        child.result(child.request(request(10, 3)))
    assert child.process.returncode == -9


def test_the_child_has_a_process_group_of_its_own_and_ignores_sigint() -> None:
    """A Ctrl-C in the terminal reaches the caller's process group only; sent to the child it is ignored."""
    child = start()
    try:
        assert child.result(child.request(request(10, 1))) == expected(10, 1)  # started: SIGINT ignored by now
        assert os.getpgid(child.process.pid) == child.process.pid != os.getpgid(0)
        os.kill(child.process.pid, signal.SIGINT)
        assert child.result(child.request(request(10, 2))) == expected(10, 2)  # it answers as before
    finally:
        child.close()
    assert child.process.returncode == 0
