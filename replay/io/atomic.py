"""Outputs that appear whole or not at all: a temporary name beside the output, then a rename.

A file under its final name is always complete; a process killed mid-write leaves only a temporary
(``.part``) file, and a symlink at an output path is replaced, never written through.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import BinaryIO

from navlog.errors import NavlogError

__all__ = ["open_new", "replace_output", "write_error", "write_file"]


def open_new(path: Path) -> BinaryIO:
    """Open a temporary output for writing as a new file: a stale file or a symlink at ``path`` is removed
    first, so writing never follows a link to somewhere else."""
    path.unlink(missing_ok=True)
    return open(path, "xb")


def write_error(path: Path, exc: OSError) -> NavlogError:
    """A write that failed (a full disk, a file-size limit), as one message naming the output."""
    return NavlogError(
        f"{path}: cannot write: {exc.strerror or exc} (a full disk or a file-size limit?); the partial file was removed"
    )


def replace_output(tmp: Path, out: Path) -> None:
    """Move a finished output (a file or a folder) into place; an old one is moved aside first and removed
    only afterwards, so the final name holds either the old output whole or the new one whole."""
    if out.is_symlink():
        out.unlink()  # the link itself, never what it points to
    if not out.exists() or (tmp.is_file() and out.is_file()):
        os.replace(tmp, out)
        return
    old = out.with_name(f".{out.name}.old-{os.getpid()}")
    os.replace(out, old)
    os.replace(tmp, out)
    shutil.rmtree(old) if old.is_dir() else old.unlink()


def write_file(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename (a symlink at ``path`` is replaced)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.part")
    try:
        with open_new(tmp) as f:
            f.write(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
