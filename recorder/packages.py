"""``package://PKG/...`` and ``$(find PKG)`` of robot description files, resolved along a package path.

A package is a folder holding a ``package.xml``; its name is the folder's name (as ament and catkin
find it in a source tree). The package path is searched in order: the folders given
(``--package-path``), then ``ROS_PACKAGE_PATH`` and ``AMENT_PREFIX_PATH`` (each ``PREFIX`` there
also as ``PREFIX/share``), then the folders above the description file itself, so that a file inside
a package finds its own package and its siblings without any setting. Each folder is either a
package or holds packages up to ``MAX_DEPTH`` levels below it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from navlog.errors import ConfigError

PACKAGE_PATH_ENV = ("ROS_PACKAGE_PATH", "AMENT_PREFIX_PATH")
MAX_DEPTH = 3  # package.xml files are looked for this many folders below each folder of the path


def package_path(extra: Sequence[Path | str] = (), near: Path | None = None) -> list[Path]:
    """The folders to search for packages, in order (module docstring); ``near``: the description file."""
    out = [Path(p) for p in extra]
    for var in PACKAGE_PATH_ENV:
        for item in os.environ.get(var, "").split(os.pathsep):
            if item:
                out += [Path(item), Path(item) / "share"] if var == "AMENT_PREFIX_PATH" else [Path(item)]
    if near is not None:
        out += list(near.resolve().parents)[:MAX_DEPTH]
    seen: set[Path] = set()
    return [p for p in out if not (p in seen or seen.add(p))]  # type: ignore[func-returns-value]


def _packages_below(folder: Path, depth: int) -> dict[str, Path]:
    if not folder.is_dir():
        return {}
    if (folder / "package.xml").is_file():
        return {folder.name: folder}
    found: dict[str, Path] = {}
    if depth > 0:
        try:
            children = sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
        except OSError:
            return {}
        for child in children:
            for name, path in _packages_below(child, depth - 1).items():
                found.setdefault(name, path)
    return found


def find_package(name: str, search: Sequence[Path]) -> Path:
    """The folder of package ``name``: the first along ``search`` (ConfigError naming every folder searched)."""
    for folder in search:
        hit = _packages_below(folder, MAX_DEPTH).get(name)
        if hit is not None:
            return hit
    where = ", ".join(str(p) for p in search) or "no folder"
    raise ConfigError(
        f"package '{name}' not found (searched {where}; add a folder with --package-path or ROS_PACKAGE_PATH)"
    )


def resolve_uri(uri: str, base: Path, search: Sequence[Path]) -> Path:
    """The file of a mesh URI: ``package://PKG/REST``, ``file://PATH``, or a path relative to ``base``."""
    if uri.startswith("package://"):
        pkg, _, rest = uri[len("package://") :].partition("/")
        return find_package(pkg, search) / rest
    if uri.startswith("file://"):
        return Path(uri[len("file://") :])
    path = Path(uri)
    return path if path.is_absolute() else base / path
