"""Description files as XML text: xacro files expanded with the ``xacro`` package, others read as they are.

``read_description(path, args, search_paths)`` answers the XML text of a URDF or SDF file, robot or
world; a file whose name ends in ``.xacro`` is expanded first, with ``args`` as its ``xacro:arg``
values (``NAME:=VALUE`` on the command line of ``ros2 launch``) and ``$(find PKG)`` along the package
path of ``navlog.recorder.resources`` (``search_paths`` first) instead of the ament index. A xacro
error becomes a ConfigError naming the file (the included file where the error is) and, where it can
be found, the line: ``FILE:LINE: xacro error: MESSAGE``.
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
    if isinstance(exc, KeyError):
        message = f"undefined argument {exc} (give it as NAME:=VALUE, e.g. --robot-arg)"
    else:
        message = " ".join(str(exc).split()) or type(exc).__name__
    line = getattr(exc, "lineno", None)
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
    import xacro

    try:
        with _find_along(search_paths, path.parent):
            doc = xacro.process_file(str(path), mappings=dict(args or {}))
    except ConfigError as exc:  # a $(find PKG) that is nowhere on the package path
        raise ConfigError(f"{path}: xacro error: {exc}") from None
    except Exception as exc:  # xacro raises its own, XML parser, evaluation and lookup errors
        raise _xacro_error(path, exc) from None
    return str(doc.toxml())
