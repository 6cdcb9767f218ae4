"""Pure work started now and waited for later, in a thread beside the caller's.

``in_thread(work)`` starts ``work`` (a call without arguments that returns nothing) in a daemon thread
and returns its *wait*: a call that returns once ``work`` has ended and raises, once, what it raised.
It fits where an algorithm takes a ``Background`` (``navlog.replay.mapping.background``): the
algorithm decides what runs and when it must have ended; this module only decides where. Work run so
must hold the GIL little (NumPy sorts and copies release it), or it gains nothing.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

__all__ = ["in_thread"]


def in_thread(work: Callable[[], None]) -> Callable[[], None]:
    """Start ``work`` in a thread of its own; the returned call waits for it and re-raises its error."""
    error: list[BaseException] = []

    def run() -> None:
        try:
            work()
        except BaseException as exc:  # re-raised by the wait, in the caller's thread
            error.append(exc)

    thread = threading.Thread(target=run, name="navlog-background", daemon=True)
    thread.start()

    def wait() -> None:
        thread.join()
        if error:
            raise error.pop()

    return wait
