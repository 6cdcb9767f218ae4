"""The lint gates: ruff (rules and format), the import-linter contracts, mypy, and no import cycle.

The contracts in pyproject.toml find the import cycles, except those through a package's own
``__init__`` (``PACKAGE_INIT_CYCLES`` says which and finds them).

ruff runs on the checkout. import-linter and mypy need the tree as it installs -- ``recorder/``,
``replay/``, ``analysis/`` and ``config/`` live at the top but import as ``navlog.recorder``, ... --
which an editable install only provides through an import hook they do not follow; so they run on a
folder of links shaped like the installed package (``installed_layout``). To run them by hand, make
such a folder and run ``lint-imports --config pyproject.toml`` or ``mypy -p navlog`` from it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text())

pytestmark = pytest.mark.lint


def package_dirs() -> dict[str, Path]:
    """Import name -> source folder of every root in ``[tool.setuptools.package-dir]``."""
    return {name: REPO / folder for name, folder in PYPROJECT["tool"]["setuptools"]["package-dir"].items()}


def module_files() -> dict[str, Path]:
    """Every module of the distribution by its import name (``navlog.replay.io.map_server``)."""
    modules: dict[str, Path] = {}
    for name, folder in package_dirs().items():
        for path in sorted(folder.rglob("*.py")):
            parts = path.relative_to(folder).with_suffix("").parts
            if "__pycache__" in parts:
                continue
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join((name, *parts))] = path
    return modules


@pytest.fixture(scope="module")
def installed_layout(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding ``navlog/`` as it installs: links to navlog/'s files and to the other roots."""
    root = tmp_path_factory.mktemp("layout")
    for name, folder in sorted(package_dirs().items()):
        target = root.joinpath(*name.split("."))
        if name == "navlog":
            target.mkdir()
            for entry in folder.iterdir():
                if entry.name != "__pycache__":
                    (target / entry.name).symlink_to(entry)
        else:
            target.symlink_to(folder)
    return root


def repo_paths(text: str, layout: Path) -> str:
    """Tool output with the layout's paths (``navlog/replay/x.py``) turned back into the checkout's."""
    text = text.replace(f"{layout}/", "")
    for name, folder in sorted(package_dirs().items(), key=lambda kv: -len(kv[0])):
        if name != "navlog":
            text = text.replace("/".join(name.split(".")) + "/", f"{folder.relative_to(REPO)}/")
    return text


def run_tool(args: list[str], cwd: Path, pythonpath: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    return subprocess.run(
        [str(BIN / args[0]), *args[1:]], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )


def test_ruff_check() -> None:
    res = run_tool(["ruff", "check", "--no-fix", "."], REPO)
    assert res.returncode == 0, f"ruff check .\n{res.stdout}{res.stderr}"


def test_ruff_format() -> None:
    res = run_tool(["ruff", "format", "--check", "."], REPO)
    assert res.returncode == 0, f"ruff format --check . (run `ruff format` on these files)\n{res.stdout}{res.stderr}"


def test_import_contracts(installed_layout: Path) -> None:
    res = run_tool(
        ["lint-imports", "--config", str(REPO / "pyproject.toml"), "--no-cache", "--no-logo"],
        installed_layout,
        installed_layout,
    )
    assert res.returncode == 0, f"lint-imports\n{repo_paths(res.stdout + res.stderr, installed_layout)}"


@pytest.mark.slow
def test_mypy(installed_layout: Path, tmp_path: Path) -> None:
    res = run_tool(
        [
            "mypy",
            "--config-file",
            str(REPO / "pyproject.toml"),
            "--cache-dir",
            str(tmp_path / "mypy-cache"),
            "--no-error-summary",
            "-p",
            "navlog",
        ],
        installed_layout,
        installed_layout,
    )
    assert res.returncode == 0, f"mypy -p navlog\n{repo_paths(res.stdout + res.stderr, installed_layout)}"


def test_mypy_checks_every_package_init_strictly() -> None:
    """The public API (every package's ``__init__``) is in the strict list of ``[tool.mypy]``."""
    strict = {m for o in PYPROJECT["tool"]["mypy"]["overrides"] if o.get("disallow_untyped_defs") for m in o["module"]}
    packages = {name for name, path in module_files().items() if path.name == "__init__.py"}
    public = {"navlog.errors", "navlog.version", "navlog.cli", "navlog.demo"}
    assert sorted((packages | public) - strict) == []


# The `acyclic_siblings` contract (ancestor navlog, depth 10: every package) breaks on every cycle whose
# modules lie in two or more children of one package -- modules of one package, sibling packages, at any
# depth. A package's own __init__ is no child of it, so a cycle made of a package's __init__ and its own
# modules alone (P -> P.a -> P) escapes the contract: this script, on import-linter's graph library and
# with the contract's settings, prints each such chain.
PACKAGE_INIT_CYCLES = """\
import sys

import grimp

graph = grimp.build_graph(sys.argv[1], exclude_type_checking_imports=True, cache_dir=None)
for package in sorted(m for m in graph.modules if graph.find_children(m)):
    for module in sorted(graph.find_descendants(package)):
        down = graph.find_shortest_chain(importer=package, imported=module)
        up = graph.find_shortest_chain(importer=module, imported=package) if down else None
        if up:
            print(" -> ".join((*down, *up[1:])))
"""


def package_init_cycles(root: Path, package: str) -> list[str]:
    """The chains ``P -> ... -> P`` through a package's ``__init__`` and its own modules, of ``package`` in ``root``."""
    res = run_tool(["python", "-c", PACKAGE_INIT_CYCLES, package], root, root)
    assert res.returncode == 0, res.stderr
    return res.stdout.splitlines()


def test_cycle_check_sees_a_package_init_and_its_own_module(tmp_path: Path) -> None:
    """Imports inside functions count; imports under ``if TYPE_CHECKING:`` never run and do not."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("def f():\n    from pkg import a, b\n")
    (pkg / "a.py").write_text("import pkg\n")
    (pkg / "b.py").write_text("from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n    import pkg\n")
    assert package_init_cycles(tmp_path, "pkg") == ["pkg -> pkg.a -> pkg"]


def test_no_import_cycle_through_a_package_init(installed_layout: Path) -> None:
    """No package's ``__init__`` imports a module of its own that imports it back (the contract misses those)."""
    assert package_init_cycles(installed_layout, "navlog") == []
