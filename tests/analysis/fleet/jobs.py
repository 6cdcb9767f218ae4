"""Jobs for the executor tests: module-level, so spawned workers and Ray tasks can import them."""

from __future__ import annotations

import os
import signal
from pathlib import Path


def square(n: int) -> int:
    return n * n


def die_on_minus_one(n: int) -> int:
    """Kills its own process (as ``kill -9`` or the OOM killer would) when ``n`` is -1."""
    if n == -1:
        os.kill(os.getpid(), signal.SIGKILL)
    return n * n


def die_once(marker: str) -> str:
    """Kills its process the first time (when ``marker`` does not exist yet), succeeds afterwards."""
    path = Path(marker)
    if not path.exists():
        path.write_text("died once\n")
        os.kill(os.getpid(), signal.SIGKILL)
    return "ok"


def pid_spent_on_zero(n: int):
    """This process's id; for ``n`` 0 wrapped as ``Spent`` (the job left its process unsound)."""
    from navlog.analysis.fleet.executors import Spent

    return Spent(os.getpid()) if n == 0 else os.getpid()
