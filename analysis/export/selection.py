"""Choosing what an export writes: topics by name or shell pattern, a time window, the output path."""

from __future__ import annotations

import fnmatch
from collections.abc import Iterable
from pathlib import Path

from navlog.errors import NavlogError
from navlog.replay.config import suggest
from navlog.replay.io import LogReader


def check_window(start_s: float | None, end_s: float | None) -> None:
    """Refuse a window that starts before the log or ends before it starts (seconds from its start)."""
    if start_s is not None and start_s < 0:
        raise NavlogError(f"--start {start_s}: must be >= 0 (seconds from the log's first message)")
    if start_s is not None and end_s is not None and end_s < start_s:
        raise NavlogError(f"--end {end_s} is before --start {start_s}")


def time_window(reader: LogReader, start_s: float | None, end_s: float | None) -> tuple[int | None, int | None]:
    """Absolute log times (ns) of a window given in seconds from the log's first message."""
    check_window(start_s, end_s)
    dur = reader.duration_ns / 1e9
    if start_s is not None and start_s > dur:
        raise NavlogError(f"--start {start_s}: the log {reader.path} lasts only {dur:.3f} s; nothing to export")
    s = None if start_s is None else reader.start_ns + int(round(start_s * 1e9))
    e = None if end_s is None else reader.start_ns + int(round(end_s * 1e9))
    return s, e


def select_topics(reader: LogReader, patterns: Iterable[str]) -> list[str]:
    """Topics of a log matching names or shell patterns; every pattern must match something."""
    names = sorted(reader.topics)
    patterns = [p for p in patterns if p]
    if not patterns:
        return names
    chosen: set[str] = set()
    for p in patterns:
        hits = [n for n in names if n == p or fnmatch.fnmatchcase(n, p)]
        if not hits:
            raise NavlogError(
                f"--topics {p}: matches no topic of {reader.path}{suggest(p, names)}; it has {', '.join(names) or 'none'}"
            )
        chosen.update(hits)
    return sorted(chosen)


def check_output(out: Path, force: bool) -> None:
    """Refuse an existing output without ``force``, an output in a folder that does not exist, and a device,
    FIFO or socket at the output (``navlog.replay.io.atomic.check_output``)."""
    from navlog.replay.io.atomic import check_output as refuse_special

    refuse_special(out)
    if out.exists() and not force:
        raise NavlogError(f"{out}: already exists; choose another name or pass --force to overwrite it")
    if not out.parent.is_dir():
        raise NavlogError(f"{out.parent}: output folder does not exist")
