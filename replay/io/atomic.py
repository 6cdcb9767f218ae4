"""Outputs that appear whole or not at all: a temporary name beside the output, then a rename.

A file under its final name is always complete; a process killed mid-write leaves only a temporary
(``.NAME.PID.part``) file, and a symlink at an output path is replaced, never written through. The next
run for the same output removes the temporaries that killed runs left beside it (``remove_stale``).
"""

from __future__ import annotations

import os
import re
import shutil
from pathlib import Path
from typing import BinaryIO

from navlog.errors import NavlogError

__all__ = ["open_new", "remove_stale", "replace_output", "temp_path", "write_error", "write_file"]


def open_new(path: Path) -> BinaryIO:
    """Open a temporary output for writing as a new file: a stale file or a symlink at ``path`` is removed
    first, so writing never follows a link to somewhere else."""
    path.unlink(missing_ok=True)
    return open(path, "xb")


def _running(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def remove_stale(out: Path) -> list[Path]:
    """Clear what killed runs left beside ``out``: their temporaries (``.NAME.PID.part``, ``.NAME.PID.partial``,
    files or folders) are removed, and an old output moved aside (``.NAME.old-PID``) is put back when nothing
    holds the final name (a run killed between its two renames), else removed. Only names whose process no
    longer runs are touched, so a run writing the same output at the same time keeps its files; symlinks
    are removed as links. Returns the paths removed or restored."""
    if not out.parent.is_dir():
        return []
    pattern = re.compile(rf"\.{re.escape(out.name)}\.(?:(\d+)\.(?:part|partial)|old-(\d+))")
    done = []
    for path in sorted(out.parent.iterdir()):
        m = pattern.fullmatch(path.name)
        if m is None or _running(int(m[1] or m[2])):
            continue
        if m[2] and not out.exists() and not out.is_symlink():
            os.replace(path, out)
        elif path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)
        done.append(path)
    return done


def temp_path(out: Path, suffix: str = ".part") -> Path:
    """The temporary name this process writes ``out`` under (``.NAME.PID.part`` beside it), after clearing
    what killed runs left there (``remove_stale``) and anything at that name (a killed run of the same PID)."""
    remove_stale(out)
    tmp = out.with_name(f".{out.name}.{os.getpid()}{suffix}")
    if tmp.is_dir() and not tmp.is_symlink():
        shutil.rmtree(tmp)
    else:
        tmp.unlink(missing_ok=True)
    return tmp


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
    tmp = temp_path(path)
    try:
        with open_new(tmp) as f:
            f.write(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
