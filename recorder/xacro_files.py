"""Description files as XML text: xacro files expanded with the ``xacro`` package, others read as they are.

``read_description(path, args, search_paths)`` answers the XML text of a URDF or SDF file, robot or
world; a file whose name ends in ``.xacro`` is expanded first, with ``args`` as its ``xacro:arg``
values (``NAME:=VALUE`` on the command line of ``ros2 launch``) and ``$(find PKG)`` along the package
path of ``navlog.recorder.resources`` (``search_paths`` first) instead of the ament index. A xacro
error becomes a ConfigError naming the file (the included file where the error is) and, where it can
be found, the line: ``FILE:LINE: xacro error: MESSAGE``. A xacro file is expanded in a child process
held to ``XACRO_SECONDS`` of CPU, ``XACRO_MEMORY`` and ``XACRO_OUTPUT``: past them it is a ConfigError.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path

from navlog.errors import ConfigError
from navlog.recorder.resources import package_folder


@contextmanager
def _find_along(search_paths: Sequence[Path | str], near: Path) -> Iterator[None]:
    """xacro's ``$(find PKG)`` along the package path instead of the ament index, while the block runs."""
    import xacro.substitution_args as substitution

    previous = substitution._eval_find
    substitution._eval_find = lambda pkg: str(package_folder(pkg, search_paths, near=near))
    try:
        yield
    finally:
        substitution._eval_find = previous


def _line_of(path: Path, text: str) -> int | None:
    """The first line of ``path`` that holds ``text``, if any."""
    try:
        lines = path.read_text(errors="replace").splitlines()
    except OSError:
        return None
    for i, line in enumerate(lines, 1):
        if text in line:
            return i
    return None


def _xacro_error(path: Path, exc: Exception) -> ConfigError:
    import xacro

    stack = [f for f in (getattr(xacro, "filestack", None) or []) if f]
    where = Path(stack[-1]) if stack else path
    cause: BaseException | None = exc
    while cause is not None and not isinstance(cause, ConfigError):  # ours, raised inside xacro and wrapped by it
        cause = cause.__cause__ or cause.__context__
    undefined = re.match(r"Undefined substitution argument (\S+)", str(exc))
    line = getattr(exc, "lineno", None)
    if isinstance(exc, KeyError):
        message = f"undefined argument {exc} (give it as NAME:=VALUE, e.g. --robot-arg)"
    elif cause is not None:
        message = str(cause)
    elif undefined is not None:
        name = undefined.group(1)
        message = f"argument '{name}' has no value and no default: give it with --robot-arg {name}:=VALUE"
        line = _line_of(where, f"$(arg {name})")
    else:
        message = " ".join(str(exc).split()) or type(exc).__name__
    m = re.search(r"line (\d+)", message)
    if line is None and m is not None:
        line = int(m.group(1))
    if line is None:
        m = re.search(r"expression '([^']+)'", message) or re.search(r"'([^']+)'", message)
        if m is not None:
            line = _line_of(where, "${" + m.group(1) + "}") or _line_of(where, m.group(1))
    at = f"{where}:{line}" if line is not None else str(where)
    inside = "" if where == path else f" (included from {path})"
    return ConfigError(f"{at}: xacro error: {message}{inside}")


def read_description(
    path: Path | str, args: Mapping[str, str] | None = None, search_paths: Sequence[Path | str] = ()
) -> str:
    """The XML text of ``path``, xacro-expanded when its name ends in ``.xacro`` (module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such file")
    if path.suffix != ".xacro":
        if args:
            raise ConfigError(f"{path}: xacro arguments are for .xacro files; this one is not")
        try:
            return path.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read ({exc})") from None
    return _expand_bounded(path, dict(args or {}), [str(p) for p in search_paths])


def expand(path: Path, args: Mapping[str, str], search_paths: Sequence[Path | str]) -> str:
    """The xacro expansion of ``path`` in this process, unbounded (``read_description`` bounds it)."""
    import xacro

    try:
        with _find_along(search_paths, path.parent):
            doc = xacro.process_file(str(path), mappings=dict(args))
    except ConfigError as exc:  # a $(find PKG) that is nowhere on the package path
        raise ConfigError(f"{path}: xacro error: {exc}") from None
    except Exception as exc:  # xacro raises its own, XML parser, evaluation and lookup errors
        cause: BaseException | None = exc
        while cause is not None and not isinstance(cause, MemoryError):
            cause = cause.__cause__ or cause.__context__
        if cause is not None:  # xacro wraps the MemoryError of an expression too large
            raise ConfigError(
                f"{path}: the xacro expansion needs more memory than it may have ({XACRO_MEMORY >> 30} GiB): "
                "an expression too large?"
            ) from None
        raise _xacro_error(path, exc) from None
    return str(doc.toxml())


# a xacro file is a program: a macro that calls itself twice expands 2^n times, ${10**10**9} never ends. It is
# expanded in a child process (``navlog.replay.workers.child``) held to these (a robot's file takes well under
# a second and a few MB)
XACRO_SECONDS = 10
XACRO_MEMORY = 2 << 30  # bytes of address space
XACRO_OUTPUT = 64 << 20  # bytes of expanded XML

_CHILD = """
import json, sys, traceback
from pathlib import Path
from navlog.errors import ConfigError
from navlog.recorder.xacro_files import expand
request = json.loads(sys.argv[1])
try:
    reply = b"T" + expand(Path(request["path"]), request["args"], request["search"]).encode(errors="surrogateescape")
except ConfigError as exc:
    reply = b"E" + str(exc).encode(errors="replace")
except BaseException as exc:  # anything else: its last line, for the parent's error
    reply = b"X" + traceback.format_exception_only(exc)[-1].strip().encode(errors="replace")
sys.stdout.buffer.write(reply[: request["output"] + 2])
"""


def _expand_bounded(path: Path, args: dict[str, str], search_paths: list[str]) -> str:
    import json

    from navlog.replay.workers.child import run_python

    request = {"path": str(path), "args": args, "search": search_paths, "output": XACRO_OUTPUT}
    try:
        reply, code = run_python(
            _CHILD,
            args=[json.dumps(request)],
            timeout=XACRO_SECONDS + 5,
            cpu_seconds=XACRO_SECONDS,
            memory=XACRO_MEMORY,
        )
    except OSError as exc:
        raise ConfigError(f"{path}: cannot start the xacro expansion ({exc})") from None
    limits = f"{XACRO_SECONDS} s and {XACRO_MEMORY >> 30} GiB"
    if reply[:1] == b"T":
        if len(reply) > XACRO_OUTPUT + 1:
            raise ConfigError(
                f"{path}: xacro expands to more than {XACRO_OUTPUT >> 20} MB of XML: a macro that expands without end?"
            )
        return reply[1:].decode(errors="surrogateescape")
    if reply[:1] == b"E":
        raise ConfigError(reply[1:].decode(errors="replace"))
    if reply[:1] == b"X":
        raise ConfigError(f"{path}: the xacro expansion failed: {reply[1:].decode(errors='replace')}")
    raise ConfigError(
        f"{path}: the xacro expansion did not end within {limits} "
        f"(exit code {code}): a macro that expands without end, or an expression too large?"
    )
