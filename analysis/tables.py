"""Text tables for people: ``rich`` tables rendered to a plain string.

The string has no colour and no trailing spaces, and is never wrapped or cut (the console is wider
than any table), so it reads the same in a terminal, a file or a CI log. ``rich`` is imported when a
table is made, not when this module is.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING, Any

from navlog.replay.runtime.progress import render_plain

if TYPE_CHECKING:
    from rich.table import Table

__all__ = ["MISSING", "figure", "grid", "indented", "render", "table"]

MISSING = "n/a (no samples)"  # what every report prints where a number is missing (None or NaN)


def figure(value: Any, spec: str = ".6g", unit: str = "") -> str:
    """``value`` formatted with ``spec`` (and `` unit``) for a report, or ``MISSING`` when it is None or
    NaN: no report prints "nan" for a number it has no samples of."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return MISSING
    return f"{value:{spec}}{' ' + unit if unit else ''}"


def table(headers: Sequence[str], rows: Iterable[Sequence[str]], *, right: Iterable[int] = ()) -> Table:
    """Columns under a ruled header; ``right``: indices of right-aligned (numeric) columns."""
    from rich import box
    from rich.table import Table

    out = Table(box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False)
    right = set(right)
    for i, h in enumerate(headers):
        out.add_column(h, justify="right" if i in right else "left")
    for row in rows:
        out.add_row(*row)
    return out


def grid(rows: Iterable[Sequence[str]]) -> Table:
    """Aligned columns without a header or rules (two spaces between columns)."""
    from rich.table import Table

    out = Table.grid(padding=(0, 2))
    for row in rows:
        out.add_row(*row)
    return out


def indented(item: Any, spaces: int = 2) -> Any:
    """A table (or text) drawn ``spaces`` columns in from the left."""
    from rich.padding import Padding

    return Padding(item, (0, 0, 0, spaces), expand=False)


def render(*items: Any) -> str:
    """Tables and lines of text (printed as they are: no markup, no highlighting) one after the other."""
    return render_plain(*items)
