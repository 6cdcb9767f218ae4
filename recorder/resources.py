"""Where the files a robot or world description names are: ``model://``, ``package://``, ``file://`` and paths.

Gazebo and ROS name the files a description uses by URI:

- ``model://NAME/rest`` is the model folder ``NAME`` (a folder holding ``model.config``) found in a
  folder of the resource path: the folders given (``--resource-path``), then ``GZ_SIM_RESOURCE_PATH``,
  ``IGN_GAZEBO_RESOURCE_PATH``, ``SDF_PATH`` and ``GAZEBO_MODEL_PATH``;
- ``package://PKG/rest`` (and xacro's ``$(find PKG)``) is the package folder ``PKG`` (a folder holding
  ``package.xml``) found in a folder of the package path: the folders given (``--package-path``,
  ``--resource-path``), then ``ROS_PACKAGE_PATH``, and ``share/`` below each prefix of
  ``AMENT_PREFIX_PATH`` and ``COLCON_PREFIX_PATH``, then the folder of the naming file and the two
  above it (a file inside a package finds its own package and its siblings without any setting). A
  package is the folder named PKG directly in a search folder (with or without a ``package.xml``: a
  package's files kept without it, as Nav2's ``nav2_bringup`` params and maps in a source snapshot), or
  any folder up to ``PACKAGE_SEARCH_DEPTH`` levels below whose ``package.xml`` is named PKG;
- ``model://NAME`` also looks, as a last resort, in the folder above the naming file and its
  ``models`` folder: a package's ``worlds/`` next to its ``models/``, a model's meshes naming their own
  model;
- ``file://PATH`` and plain paths are relative to the folder of the file that names them.

``resolve_uri`` answers the file, or raises ``ConfigError`` naming the URI and every folder searched
(an ``https://`` URI, e.g. a Gazebo Fuel model, is never fetched: it names the model folder of the
same name, ``.../models/NAME``, when one is on the resource path).
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path

from navlog.errors import ConfigError

MODEL_PATH_ENV = ("GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH", "SDF_PATH", "GAZEBO_MODEL_PATH")
PACKAGE_PATH_ENV = ("ROS_PACKAGE_PATH",)
PREFIX_PATH_ENV = ("AMENT_PREFIX_PATH", "COLCON_PREFIX_PATH")  # packages in PREFIX/share/PKG
PACKAGE_SEARCH_DEPTH = 3  # how deep below a search folder a package.xml is looked for


def _env_folders(names: Sequence[str], suffix: str = "") -> list[Path]:
    out = []
    for name in names:
        for item in os.environ.get(name, "").split(os.pathsep):
            if item:
                out.append(Path(item) / suffix if suffix else Path(item))
    return out


def search_folders(
    search_paths: Sequence[Path | str] = (), kind: str = "model", near: Path | str | None = None
) -> list[Path]:
    """The folders searched for a ``model://`` (``kind="model"``) or ``package://`` (``"package"``) URI,
    in order: ``search_paths``, then the environment's, then those near ``near``, the folder of the file
    that names the URI (module docstring); each once."""
    folders = [Path(p) for p in search_paths]
    if kind == "model":
        folders += _env_folders(MODEL_PATH_ENV)
        if near is not None:
            folders += [Path(near).parent, Path(near).parent / "models"]
    else:
        folders += _env_folders(PACKAGE_PATH_ENV) + _env_folders(PREFIX_PATH_ENV, "share")
        if near is not None:
            folders += [Path(near), *list(Path(near).resolve().parents)[: PACKAGE_SEARCH_DEPTH - 1]]
    seen: set[Path] = set()
    out = []
    for f in folders:
        key = f.resolve()
        if key not in seen:
            seen.add(key)
            out.append(f)
    return out


def _package_name(folder: Path) -> str | None:
    try:
        text = (folder / "package.xml").read_text(errors="replace")
    except OSError:
        return None
    m = re.search(r"<name>\s*([^<\s]+)\s*</name>", text)
    return m.group(1) if m else folder.name


def find_package(name: str, folders: Sequence[Path]) -> Path | None:
    """The folder of package ``name`` in or below ``folders`` (module docstring), or None."""
    for root in folders:
        if (root / name).is_dir():
            return root / name
        if (root / "package.xml").is_file() and _package_name(root) == name:
            return root
        for folder in _folders_below(root, PACKAGE_SEARCH_DEPTH):
            if (folder / "package.xml").is_file() and _package_name(folder) == name:
                return folder
    return None


def _folders_below(root: Path, depth: int) -> list[Path]:
    """The folders 1 to ``depth`` levels below ``root``, level by level, each level sorted; hidden folders
    (``.git``, ``.venv``) are not entered, as ROS's package crawlers skip them, and a folder that cannot be
    read or vanishes while it is listed is passed over."""
    out: list[Path] = []
    level = [root]
    for _ in range(depth):
        below = []
        for folder in level:
            try:
                with os.scandir(folder) as entries:
                    below += [Path(e.path) for e in entries if not e.name.startswith(".") and e.is_dir()]
            except OSError:
                continue
        level = sorted(below)
        out += level
    return out


def find_model(name: str, folders: Sequence[Path]) -> Path | None:
    """The model folder ``name`` (holding ``model.config``) in ``folders``, or None."""
    for root in folders:
        if (root / name / "model.config").is_file():
            return root / name
    return None


def searched(folders: Sequence[Path], kind: str) -> str:
    """The end of a not-found message: every folder searched and how to add one."""
    where = ", ".join(str(f) for f in folders) or "no folder"
    how = "--resource-path or GZ_SIM_RESOURCE_PATH" if kind == "model" else "--package-path or ROS_PACKAGE_PATH"
    return f"searched {where}; add folders with {how}"


def package_folder(name: str, search_paths: Sequence[Path | str] = (), near: Path | str | None = None) -> Path:
    """The folder of package ``name`` (xacro's ``$(find PKG)``); ConfigError naming every folder searched."""
    folders = search_folders(search_paths, "package", near=near)
    root = find_package(name, folders)
    if root is None:
        raise ConfigError(f"package '{name}' not found ({searched(folders, 'package')})")
    return root


def resolve_uri(uri: str, base_dir: Path | str, search_paths: Sequence[Path | str] = ()) -> Path:
    """The local file or folder ``uri`` names (module docstring); ConfigError when there is none.

    ``base_dir``: the folder of the file that names ``uri`` (relative paths start there);
    ``search_paths``: folders searched first for ``model://`` and ``package://`` URIs."""
    uri = uri.strip()
    base = Path(base_dir)
    for scheme, kind, finder in (("model://", "model", find_model), ("package://", "package", find_package)):
        if uri.startswith(scheme):
            name, _, rest = uri[len(scheme) :].partition("/")
            folders = search_folders(search_paths, kind, near=base)
            root = finder(name, folders)
            if root is None or not (root / rest).exists():
                what = f"no {kind} '{name}'" if root is None else f"no {rest} in {root}"
                raise ConfigError(f"cannot resolve {uri}: {what} ({searched(folders, kind)})")
            return root / rest
    if "://" in uri and not uri.startswith("file://"):
        folders = search_folders(search_paths, "model")
        m = re.search(r"/models/([^/]+)", uri)  # a Fuel URL: a copy of that model on the resource path
        if m is not None:
            for name in dict.fromkeys((m.group(1), m.group(1).lower())):
                root = find_model(name, folders)
                if root is not None:
                    return root
        where = ", ".join(str(f) for f in folders) or "no folder"
        raise ConfigError(
            f"cannot resolve {uri}: only model://, package://, file:// and local paths are read (no download; "
            f"searched {where}); download the model into a folder and give it with --resource-path"
        )
    path = Path(uri[len("file://") :] if uri.startswith("file://") else uri)
    path = path if path.is_absolute() else base / path
    if not path.exists():
        raise ConfigError(f"cannot resolve {uri}: no such file {path}")
    return path
