"""``SerialThread``: calls run in order in one thread, waits re-raise, the thread ends when idle and comes back."""

from __future__ import annotations

import threading
import time

import pytest

import navlog.replay.workers.background as background
from navlog.replay.workers.background import SerialThread


def test_calls_run_in_order_in_one_thread_and_errors_come_back(monkeypatch):
    monkeypatch.setattr(background, "IDLE_S", 0.05)
    runner = SerialThread()
    seen: list[tuple[int, int]] = []
    gate = threading.Event()
    waits = [runner(lambda i=i: (gate.wait(), seen.append((i, threading.get_ident())))) for i in range(5)]
    assert seen == []  # the caller went on: nothing ran in its place
    gate.set()
    for w in waits:
        w()
    assert [i for i, _ in seen] == [0, 1, 2, 3, 4]
    assert len({t for _, t in seen}) == 1 and seen[0][1] != threading.get_ident()

    def fail() -> None:
        raise ValueError("bad batch")

    wait = runner(fail)
    with pytest.raises(ValueError, match="bad batch"):
        wait()
    wait()  # raised once
    deadline = time.monotonic() + 5.0
    while runner._thread is not None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert runner._thread is None  # idle: the thread ended
    out: list[int] = []
    runner(lambda: out.append(7))()
    assert out == [7]  # and a new one runs the next call
