"""Pure work started now and waited for later, in a thread beside the caller's.

``in_thread(work)`` starts ``work`` (a call without arguments that returns nothing) in a daemon thread
and returns its *wait*: a call that returns once ``work`` has ended and raises, once, what it raised.
``SerialThread()`` is the same for work given often (MPPI's noise, every control cycle): one thread
runs the calls in the order given, started on first use and ending after a second with nothing to do,
so a call costs a queue put, not a thread start (about 1 ms each on a loaded machine).
It fits where an algorithm takes a ``Background`` (``navlog.replay.mapping.background``): the
algorithm decides what runs and when it must have ended; this module only decides where. Work run so
must hold the GIL little (NumPy sorts and copies release it), or it gains nothing.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable

__all__ = ["SerialThread", "in_thread"]

IDLE_S = 1.0  # a SerialThread's thread ends after this long without work


def _caught(work: Callable[[], None], error: list[BaseException]) -> Callable[[], None]:
    """``work`` with any error it raises kept in ``error`` (to be re-raised by the wait, in the caller's thread)."""

    def run() -> None:
        try:
            work()
        except BaseException as exc:
            error.append(exc)

    return run


def in_thread(work: Callable[[], None]) -> Callable[[], None]:
    """Start ``work`` in a thread of its own; the returned call waits for it and re-raises its error."""
    error: list[BaseException] = []
    thread = threading.Thread(target=_caught(work, error), name="navlog-background", daemon=True)
    thread.start()

    def wait() -> None:
        thread.join()
        if error:
            raise error.pop()

    return wait


class SerialThread:
    """A ``Background`` running the calls given in one thread of its own, in order (see the module docstring)."""

    def __init__(self) -> None:
        self._jobs: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    def __call__(self, work: Callable[[], None]) -> Callable[[], None]:
        done = threading.Event()
        error: list[BaseException] = []
        run = _caught(work, error)

        def job() -> None:
            run()
            done.set()

        with self._lock:
            self._jobs.put(job)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="navlog-serial", daemon=True)
                self._thread.start()

        def wait() -> None:
            done.wait()
            if error:
                raise error.pop()

        return wait

    def _run(self) -> None:
        while True:
            try:
                job = self._jobs.get(timeout=IDLE_S)
            except queue.Empty:
                with self._lock:
                    if self._jobs.empty():
                        self._thread = None
                        return
                continue
            job()
