"""Progress over a fleet: logs done out of all, how many failed, the time left.

On a terminal (stderr) a ``rich`` bar: ``fleet ━━━━━━ 5/8 logs  1 failed  0:00:12 • 0:00:07``. Elsewhere
(CI logs, files) one line per finished log: ``fleet: 5/8 done, 1 failed: run3 (the reason)``. It reads
the wall clock only for what it shows.
"""

from __future__ import annotations

import sys
from typing import IO, Any

__all__ = ["FleetProgress"]


class FleetProgress:
    """``done(name, ok, reason)`` as each log finishes, ``close()`` at the end (``contextlib.closing``)."""

    def __init__(self, total: int, *, enabled: bool = True, file: IO[str] | None = None) -> None:
        self.total = total
        self.finished = 0
        self.failed = 0
        self.enabled = enabled
        self.file = file if file is not None else sys.stderr
        self._bar: Any = None
        self._task: Any = None
        if enabled and bool(getattr(self.file, "isatty", lambda: False)()):
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self._bar = Progress(
                TextColumn("fleet"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("logs  {task.fields[failed]} failed"),
                TimeElapsedColumn(),
                TimeRemainingColumn(),
                console=Console(file=self.file),
            )
            self._task = self._bar.add_task("fleet", total=total, failed=0)
            self._bar.start()

    def done(self, name: str, ok: bool, reason: str = "") -> None:
        self.finished += 1
        self.failed += not ok
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.update(self._task, completed=self.finished, failed=self.failed)
            return
        line = f"fleet: {self.finished}/{self.total} done, {self.failed} failed"
        if not ok:
            line += f": {name} ({' '.join(reason.split())})"
        self.file.write(line + "\n")
        self.file.flush()

    def close(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None
