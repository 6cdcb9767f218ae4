"""The ``navlog`` commands, one module each (``navlog world-map`` is ``world_map.py``).

Each module has ``register(subparsers)``, which adds the command's parser, and ``run(args)``, which
calls the library function a Python user would call and prints its result. A module imports the
library only inside ``run``, so that building the parser (and ``--help``) loads nothing heavy.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_force", "refuse_existing", "skipped_note"]

FORCE_HELP = "overwrite existing output files"


def add_force(parser: argparse.ArgumentParser, help: str = FORCE_HELP) -> None:
    """``--force``: the one rule of every command that writes files: an existing output needs it."""
    parser.add_argument("--force", action="store_true", help=help)


def refuse_existing(force: bool, *paths: str | Path | None) -> None:
    """Raise ``NavlogError`` naming the first of ``paths`` that exists, unless ``force``; before anything
    is computed, so that a refused command has written nothing. A device node, FIFO or socket is refused
    with or without ``force`` (``navlog.replay.io.atomic.check_output``)."""
    from navlog.errors import NavlogError
    from navlog.replay.io.atomic import check_output

    for path in paths:  # a device, FIFO or socket is refused even with --force
        if path is not None and str(path):
            check_output(Path(path))
    if force:
        return
    for path in paths:
        if path is not None and str(path) and Path(path).exists():
            raise NavlogError(f"{path}: already exists; choose another name or pass --force to overwrite it")


def skipped_note(skipped: dict[str, int]) -> str:
    """'; skipped N: reason xK; ...' for a command's one-line summary, or '' when nothing was skipped."""
    total = sum(skipped.values())
    if not total:
        return ""
    return f"; skipped {total}: " + "; ".join(f"{k} x{v}" for k, v in sorted(skipped.items()))
