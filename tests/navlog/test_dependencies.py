"""Every package the installed source imports is declared in pyproject.toml.

The installed source is every ``.py`` file under the roots of ``[tool.setuptools.package-dir]``;
its imports (function-level ones too, relative ones excepted) are read with ``ast``. Each top-level
name that is neither the standard library's nor navlog's own is mapped to the distributions that
install it (``importlib.metadata.packages_distributions()``, or for a lone extension module the
distribution whose files hold it), and one of them must be named in ``[project] dependencies`` or
in an optional extra (``fleet``: Ray and fsspec; ``test``: pytest, imported by the pytest plugin).
"""

from __future__ import annotations

import ast
import importlib.metadata
import importlib.util
import re
import sys
import tomllib
from functools import cache
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())


def normalized(name: str) -> str:
    """A distribution name as PEP 503 compares them."""
    return re.sub(r"[-_.]+", "-", name).lower()


def declared() -> set[str]:
    """The normalized names of the distributions pyproject.toml requires, optional extras included."""
    project = PYPROJECT["project"]
    specs = [*project["dependencies"], *(s for extra in project["optional-dependencies"].values() for s in extra)]
    return {normalized(re.match(r"[A-Za-z0-9][A-Za-z0-9._-]*", spec).group()) for spec in specs}


def imported_names(source: str) -> set[str]:
    """The top-level names of the absolute imports in ``source``."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def third_party(names: set[str]) -> set[str]:
    return {n for n in names if n not in sys.stdlib_module_names and n != "navlog"}


@cache
def packages() -> dict[str, list[str]]:
    return importlib.metadata.packages_distributions()


def distributions_of(name: str) -> set[str]:
    """The normalized names of the installed distributions that provide the import name ``name``."""
    found = packages().get(name)
    if found:
        return {normalized(d) for d in found}
    spec = importlib.util.find_spec(name)
    if spec is None or spec.origin is None:
        return set()
    origin = Path(spec.origin).resolve()
    return {
        normalized(dist.metadata["Name"])
        for dist in importlib.metadata.distributions()
        for file in dist.files or ()
        if Path(str(dist.locate_file(file))).resolve() == origin
    }


def undeclared(names: set[str], allowed: set[str]) -> dict[str, set[str]]:
    """Import name -> its distributions, for each name none of whose distributions is ``allowed``."""
    out = {}
    for name in sorted(third_party(names)):
        dists = distributions_of(name)
        if not dists & allowed:
            out[name] = dists
    return out


def source_imports() -> dict[str, set[str]]:
    """Top-level import name -> the source files (relative to the checkout) importing it."""
    users: dict[str, set[str]] = {}
    for folder in PYPROJECT["tool"]["setuptools"]["package-dir"].values():
        for path in sorted((REPO / folder).rglob("*.py")):
            for name in imported_names(path.read_text()):
                users.setdefault(name, set()).add(str(path.relative_to(REPO)))
    return users


def test_every_imported_package_is_declared() -> None:
    users = source_imports()
    assert {"numpy", "mcap", "rosbags", "PIL"} <= set(users)  # the walk sees the tree's imports
    missing = undeclared(set(users), declared())
    assert not missing, "imported but not declared in pyproject.toml: " + "; ".join(
        f"{name} (distribution {', '.join(sorted(dists)) or 'not installed'}; imported by {', '.join(sorted(users[name]))})"
        for name, dists in missing.items()
    )


def test_an_import_of_an_undeclared_package_is_reported() -> None:
    source = "import os\nimport numpy.linalg\nfrom PIL import Image\nfrom . import sibling\nimport navlog.replay\n"
    assert third_party(imported_names(source)) == {"numpy", "PIL"}
    assert undeclared(imported_names(source), {"numpy", "pillow"}) == {}
    assert undeclared(imported_names(source), {"numpy"}) == {"PIL": {"pillow"}}
    assert undeclared({"no_such_module_anywhere"}, declared()) == {"no_such_module_anywhere": set()}
    assert distributions_of("small_gicp") == {"small-gicp"}  # an extension module outside any package
