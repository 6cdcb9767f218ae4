"""Outputs that appear whole or not at all: a temporary name beside the output, then a rename.

A file under its final name is always complete; a process killed mid-write leaves only a temporary
(``.NAME.PID.part``) file, and a symlink at an output path is replaced, never written through. The next
run for the same output removes the temporaries that killed runs left beside it (``remove_stale``).

One run writes an output at a time: ``hold_output`` takes a lock beside it (``.NAME.lock``, an
``flock`` that goes with the process, also when it is killed), and a second run for the same output is
refused, naming the lock and the process that holds it, instead of mixing its files with the first's.
"""

from __future__ import annotations

import errno
import fcntl
import os
import re
import shutil
import stat
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import BinaryIO

from navlog.errors import NavlogError

__all__ = [
    "WriteError",
    "check_not_input",
    "check_output",
    "hold_output",
    "open_new",
    "output_failure",
    "remove_stale",
    "replace_output",
    "temp_path",
    "write_error",
    "write_file",
]

# what a path that is neither a file, a folder nor a symlink is, for the error that refuses it as an output
_SPECIAL = (
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
)


def check_output(out: Path) -> None:
    """NavlogError when ``out`` is a device node, a FIFO or a socket (``/dev/null`` among them): navlog
    writes a new file beside an output and renames it into place, which would replace the node, so
    such an output is refused. A missing path, a file, a folder or a symlink (replaced, never written
    through) passes."""
    try:
        mode = os.lstat(out).st_mode
    except OSError:
        return
    for test, what in _SPECIAL:
        if test(mode):
            raise NavlogError(f"{out}: is {what}, not a file; navlog does not write to it: choose a file path")


def check_not_input(out: Path | str, inputs: Iterable[Path | str | None], *, folder: bool = False) -> None:
    """NavlogError when writing ``out`` would replace or write into what the run reads: ``out`` is one of
    ``inputs`` (also through a link, or the link itself), lies inside an input folder (a rosbag2 bag), or, for an
    output folder (``folder``: replaced whole), holds one of them or the current folder. Checked with or without
    ``--force``, before anything is written."""
    target = Path(out).resolve()
    for given in inputs:
        if given is None:
            continue
        path = Path(given)
        # where the input is read from (a link's target) and where its name lies (the link itself)
        places = {path.resolve(), path.absolute().parent.resolve() / path.name}
        for source in places:
            if source == target:
                raise NavlogError(f"{out}: is the input {given}; writing it would replace it: choose another output")
            if source in target.parents:
                raise NavlogError(f"{out}: lies inside the input {given}; choose an output outside it")
            if folder and target in source.parents:
                raise NavlogError(
                    f"{out}: holds the input {given}; the output folder is replaced whole, the input with it: "
                    "choose another output folder"
                )
    cwd = Path.cwd().resolve()
    if folder and (target == cwd or target in cwd.parents):
        raise NavlogError(
            f"{out}: is (or holds) the current folder; the output folder is replaced whole: "
            "choose a new folder, e.g. -o out/"
        )


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
    check_output(out)
    remove_stale(out)
    tmp = out.with_name(f".{out.name}.{os.getpid()}{suffix}")
    if tmp.is_dir() and not tmp.is_symlink():
        shutil.rmtree(tmp)
    else:
        tmp.unlink(missing_ok=True)
    return tmp


class WriteError(NavlogError):
    """An output that could not be written: the message is ``"{path}: {detail}"``."""

    def __init__(self, path: Path, detail: str) -> None:
        super().__init__(f"{path}: {detail}")
        self.path, self.detail = Path(path), detail

    def moved(self, tmp: Path, final: Path) -> WriteError:
        """The same error naming the path under ``final`` that it had under ``tmp`` (a temporary folder
        that would have become ``final``), in its detail too; itself when its path is not under ``tmp``."""
        try:
            inside = self.path.relative_to(tmp)
        except ValueError:
            return self
        return WriteError(final / inside, self.detail.replace(str(tmp), str(final)))

    def __reduce__(self):
        return WriteError, (self.path, self.detail)


def write_error(path: Path, exc: OSError) -> WriteError:
    """A write that failed (a read-only folder, a full disk, a file-size limit), as one message naming the
    output."""
    if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return WriteError(path, f"cannot write: {exc.strerror or exc} (a read-only folder?); nothing was written")
    if exc.errno in (errno.ENOENT, errno.ENOTDIR, errno.EISDIR):
        return WriteError(
            path, f"cannot write: {exc.strerror or exc} (a folder on the way missing, or a file where a folder is?)"
        )
    return WriteError(
        path, f"cannot write: {exc.strerror or exc} (a full disk or a file-size limit?); the partial file was removed"
    )


WRITE_ERRNOS = (errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EACCES, errno.EPERM, errno.EROFS)


def output_failure(out: Path, exc: BaseException) -> NavlogError | None:
    """The one-line error for an output that a library writing it (SQLite, Rerun) failed to write, by
    the errno of an ``OSError`` (``WRITE_ERRNOS``) or the library's own words; None when ``exc`` is no
    write failure."""
    if isinstance(exc, OSError):
        return write_error(out, exc) if exc.errno in WRITE_ERRNOS else None
    return WriteError(
        out, f"cannot write: {exc} (a read-only folder, a full disk or a file-size limit?); nothing was written"
    )


def replace_output(tmp: Path, out: Path) -> None:
    """Move a finished output (a file or a folder) into place; an old one is moved aside first and removed
    only afterwards, so the final name holds either the old output whole or the new one whole."""
    check_output(out)
    if out.is_symlink():
        out.unlink()  # the link itself, never what it points to
    if not out.exists() or (tmp.is_file() and out.is_file()):
        os.replace(tmp, out)
        return
    old = out.with_name(f".{out.name}.old-{os.getpid()}")
    os.replace(out, old)
    os.replace(tmp, out)
    shutil.rmtree(old) if old.is_dir() else old.unlink()


def write_file(path: Path, data: bytes | str) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` through a temporary file and a rename, its folder created:
    a symlink at ``path`` is replaced, a device, FIFO or socket refused (``check_output``); a write that
    fails (a read-only folder, a full disk, a file-size limit) is one NavlogError naming ``path``, and
    leaves neither a partial file nor a temporary."""
    path = Path(path)
    payload = data.encode() if isinstance(data, str) else data
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = temp_path(path)
    except OSError as exc:
        raise write_error(path, exc) from None
    try:
        with open_new(tmp) as f:
            f.write(payload)
        os.replace(tmp, path)
    except OSError as exc:
        raise write_error(path, exc) from None
    finally:
        tmp.unlink(missing_ok=True)
    return path


@contextmanager
def hold_output(out: Path) -> Iterator[None]:
    """Hold ``out`` for this run (module docstring): NavlogError when another run holds it. The lock file
    is removed when the run ends; one that a killed run left is taken over (its ``flock`` died with it)."""
    out = Path(out)
    lock = out.parent / f".{out.name}.lock"
    while True:
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        except OSError as exc:
            raise write_error(lock, exc) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise NavlogError(
                f"{out}: another navlog run (pid {holder}) is writing this output (lock {lock}); "
                "wait for it to end, or choose another output"
            ) from None
        try:  # the run that held it may have removed the lock file between our open and our lock
            same = os.fstat(fd).st_ino == os.stat(lock, follow_symlinks=False).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    try:
        try:  # who holds it, for the error a second run gives (the lock holds without it: a full disk)
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        except OSError:
            pass
        yield
    finally:
        try:
            os.unlink(lock)
        except OSError:
            pass
        os.close(fd)
