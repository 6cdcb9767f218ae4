"""How an algorithm lets part of its work run beside it, without holding threads or processes itself.

A ``Background`` takes a call (no arguments, no result) and returns its *wait*: the algorithm calls the
wait before it uses what the call changes, and the wait raises what the call raised. ``inline`` (the
default everywhere) runs the call at once; the execution layer (``navlog.replay.workers``) provides
runners that take it elsewhere. The algorithm's results do not depend on the runner: it waits for one
call before starting the next that touches the same state.
"""

from __future__ import annotations

from collections.abc import Callable

__all__ = ["Background", "inline"]

Background = Callable[[Callable[[], None]], Callable[[], None]]


def _done() -> None:
    return None


def inline(work: Callable[[], None]) -> Callable[[], None]:
    """Run ``work`` now; its wait has nothing to wait for."""
    work()
    return _done
