"""Progress and summary tables on stderr/stdout for long work (recording, replay, conversion).

``Progress`` draws a ``rich`` progress bar (description, bar, percentage, rate, elapsed, time left) on
stderr when stderr is a terminal; elsewhere (CI logs, files) it prints one plain line per 10 %.
It reads the wall clock only for the rate and times it shows; nothing it does reaches node logic or
log content. ``format_table`` renders a summary table to a string (no colour codes).

``rich`` is imported inside the functions that need it, so importing this module stays cheap for the
command line's start-up.
"""

from __future__ import annotations

import io
import sys
from collections.abc import Sequence
from typing import IO, Any, Literal

Align = Literal["left", "center", "right"]


class Progress:
    """Progress of ``done`` out of ``total`` units; ``update(done)`` as work goes, ``close()`` at the end.

    Works as a context manager (closes on exit). ``update(done, total=...)`` may correct the total, e.g.
    when work that was estimated ends early. With ``enabled=False`` nothing is drawn or printed.
    """

    def __init__(
        self, total: float, label: str, unit: str = "s", enabled: bool = True, *, file: IO[str] | None = None
    ) -> None:
        self.total = max(float(total), 1e-9)
        self.label = label
        self.unit = unit
        self.enabled = enabled
        self.file = file if file is not None else sys.stderr
        self.tty = bool(getattr(self.file, "isatty", lambda: False)())
        self._last_decile = -1
        self._bar: Any = None
        self._task: Any = None
        self._closed = False
        if enabled and self.tty:
            self._start_bar()

    def _start_bar(self) -> None:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            TaskProgressColumn,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )
        from rich.progress import Progress as RichProgress

        unit = self.unit
        self._bar = RichProgress(
            TextColumn("[progress.description]{task.description}"),
            BarColumn(),
            TaskProgressColumn(),
            TextColumn("{task.completed:.1f}/{task.total:.1f} " + unit.replace("[", r"\[")),
            TextColumn("{task.fields[rate]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            console=Console(file=self.file),
            transient=False,
        )
        self._task = self._bar.add_task(self.label, total=self.total, rate="")
        self._bar.start()

    def update(self, done: float, total: float | None = None) -> None:
        if not self.enabled or self._closed:
            return
        if total is not None:
            self.total = max(float(total), 1e-9)
        frac = min(1.0, max(0.0, done / self.total))
        if self._bar is not None:
            task = self._bar.tasks[0]
            elapsed = task.elapsed or 0.0
            rate = f"{done / elapsed:.1f} {self.unit}/s" if elapsed > 0 else ""
            self._bar.update(self._task, completed=min(done, self.total), total=self.total, rate=rate)
            return
        decile = int(frac * 10)
        if decile > self._last_decile:
            # every decile reached since the last line, so a jump (e.g. a corrected total) skips none
            for d in range(self._last_decile + 1, decile + 1):
                self.file.write(f"{self.label}: {d * 10}%\n")
            self._last_decile = decile
            self.file.flush()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self._bar is not None:
            self._bar.stop()
            self._bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def format_table(
    headers: Sequence[str],
    rows: Sequence[Sequence[object]],
    *,
    title: str | None = None,
    align: Sequence[Align] | None = None,
) -> str:
    """Render a table (``rows`` of cells, one per header) to text with ``rich``; no colour codes.

    ``align`` gives one of "left", "center", "right" per column (default: left).
    """
    from rich import box
    from rich.table import Table
    from rich.text import Text

    if align is not None and len(align) != len(headers):
        raise ValueError(f"align has {len(align)} entries for {len(headers)} columns")
    table = Table(
        title=Text(title) if title is not None else None, box=box.SIMPLE_HEAD, title_justify="left", show_edge=False
    )
    for i, h in enumerate(headers):
        table.add_column(Text(h), justify=align[i] if align is not None else "left", no_wrap=True)
    for row in rows:
        if len(row) != len(headers):
            raise ValueError(f"row {list(row)!r} has {len(row)} cells for {len(headers)} columns")
        table.add_row(*(Text(str(c)) for c in row))
    return render_plain(table).strip("\n")


def render_plain(*items: Any) -> str:
    """``rich`` renderables (tables, text: printed as they are, no markup or highlighting) one after the
    other as plain text: no colour, no trailing spaces, never wrapped or cut (the console is wider than
    any table), so it reads the same in a terminal, a file or a CI log."""
    from rich.console import Console

    buf = io.StringIO()
    console = Console(
        file=buf, width=10_000, color_system=None, force_terminal=False, markup=False, highlight=False, emoji=False
    )
    for item in items:
        console.print(item)
    return "\n".join(line.rstrip() for line in buf.getvalue().splitlines())
