"""Description files as XML text: xacro files expanded with the ``xacro`` package, others read as they are.

``read_description(path, args)`` answers the XML text of a URDF or SDF file; a file whose name ends
in ``.xacro`` is expanded first, with ``args`` as its ``xacro:arg`` values (``NAME:=VALUE`` on the
command line of ``ros2 launch``). A xacro error becomes a ConfigError naming the file (the included
file where the error is) and, where it can be found, the line.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path

from navlog.errors import ConfigError


def _line_of(path: Path, text: str) -> int | None:
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
    message = " ".join(str(exc).split())
    line = None
    m = re.search(r"line (\d+)", message)
    if m is not None:
        line = int(m.group(1))
    else:
        m = re.search(r"expression '([^']+)'", message)
        if m is not None:
            line = _line_of(where, "${" + m.group(1) + "}") or _line_of(where, m.group(1))
    at = f"{where}:{line}" if line is not None else str(where)
    inside = "" if where == path else f" (included from {path})"
    return ConfigError(f"{at}: xacro error: {message}{inside}")


def read_description(path: Path | str, args: Mapping[str, str] | None = None) -> str:
    """The XML text of ``path``, xacro-expanded when its name ends in ``.xacro`` (module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such file")
    if path.suffix != ".xacro":
        try:
            return path.read_text()
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read ({exc})") from None
    import xacro

    try:
        doc = xacro.process_file(str(path), mappings=dict(args or {}))
    except Exception as exc:  # xacro raises its own, XML parser and evaluation errors
        raise _xacro_error(path, exc) from None
    return str(doc.toxml())
