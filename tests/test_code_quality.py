"""The lint gates: ruff (rules and format), the import-linter contracts, mypy, and no import cycle.

ruff runs on the checkout. import-linter and mypy need the tree as it installs -- ``recorder/``,
``replay/``, ``analysis/`` and ``config/`` live at the top but import as ``navlog.recorder``, ... --
which an editable install only provides through an import hook they do not follow; so they run on a
folder of links shaped like the installed package (``installed_layout``). To run them by hand, make
such a folder and run ``lint-imports --config pyproject.toml`` or ``mypy -p navlog`` from it.
"""

from __future__ import annotations

import ast
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


def _runtime_imports(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement, at module level or inside functions, except under ``if TYPE_CHECKING:``."""
    found: list[ast.Import | ast.ImportFrom] = []
    todo: list[ast.AST] = [tree]
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found.append(node)
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            todo.extend(node.orelse)
            continue
        todo.extend(ast.iter_child_nodes(node))
    return found


def import_graph() -> dict[str, dict[str, int]]:
    """module -> {imported navlog module: line}, from every module's source (what runs, when it runs)."""
    modules = module_files()
    graph: dict[str, dict[str, int]] = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        edges: dict[str, int] = {}
        for node in _runtime_imports(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            else:
                base = node.module or ""
                if node.level:
                    anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                    base = f"{anchor}.{base}" if base else anchor
                targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            for target in targets:
                if target in modules and target != name:
                    edges.setdefault(target, node.lineno)
        graph[name] = edges
    return graph


def cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    groups: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph)))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(groups)


def test_cycle_finder_sees_function_level_imports() -> None:
    tree = ast.parse("import a\nif TYPE_CHECKING:\n    import b\ndef f():\n    from c import d\n")
    assert sorted(ast.unparse(n) for n in _runtime_imports(tree)) == ["from c import d", "import a"]
    assert cycles({"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}, "d": {"a": 1}}) == [["a", "b", "c"]]


def test_no_import_cycles() -> None:
    """No module imports another that imports it back, directly or through others, also from inside
    functions (imports under ``if TYPE_CHECKING:`` never run and do not count)."""
    graph = import_graph()
    files = module_files()
    report = []
    for group in cycles(graph):
        members = set(group)
        report.append(
            "cycle:\n"
            + "\n".join(
                f"  {files[a].relative_to(REPO)}:{line} imports {b} ({files[b].relative_to(REPO)})"
                for a in group
                for b, line in sorted(graph[a].items())
                if b in members
            )
        )
    assert not report, "\n".join(report)
