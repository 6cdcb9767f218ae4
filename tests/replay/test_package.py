"""The replay packages state their public API: every name in ``__all__`` resolves, lazily, to its definition."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGES = [
    "navlog.replay",
    "navlog.replay.io",
    "navlog.replay.runtime",
    "navlog.replay.nodes",
    "navlog.replay.workers",
]


@pytest.mark.parametrize("package", PACKAGES)
def test_every_public_name_resolves_to_the_object_its_module_defines(package):
    pkg = importlib.import_module(package)
    assert pkg.__doc__ and len(set(pkg.__all__)) == len(pkg.__all__)
    assert set(pkg.__all__) == set(pkg._MODULES)
    for name in pkg.__all__:
        obj = getattr(pkg, name)
        assert obj is getattr(importlib.import_module(f"{package}.{pkg._MODULES[name]}"), name)
        assert name in dir(pkg)
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        pkg.nope  # noqa: B018


def test_importing_the_packages_imports_no_submodule():
    code = (
        "import sys, navlog.replay, navlog.replay.io, navlog.replay.runtime; "
        "print(sorted(m for m in sys.modules if m.startswith('navlog.replay.')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "['navlog.replay.io', 'navlog.replay.runtime']"


def test_the_io_package_imports_without_a_cycle_through_the_runtime():
    code = "from navlog.replay.io import open_log; from navlog.replay.runtime import Progress; from navlog.replay import run_replay"
    subprocess.run([sys.executable, "-c", code], check=True)


# what only the execution layer (navlog.replay.workers) may use
CONCURRENCY_MODULES = {
    "subprocess",
    "threading",
    "multiprocessing",
    "concurrent",
    "mmap",
    "select",
    "fcntl",
    "signal",
    "socket",
}
PROCESS_CALLS = {"fork", "forkpty", "system", "popen", "spawnl", "spawnv", "spawnlp", "spawnvp", "posix_spawn", "execv"}
ALGORITHMS = Path(__file__).resolve().parents[2] / "replay"


def concurrency_in(source: str) -> list[str]:
    """What a module's source imports or calls that starts a process, a thread or a pipe."""
    found = []
    for node in ast.walk(ast.parse(source)):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names = [node.module] + ([f"os.{a.name}" for a in node.names] if node.module == "os" else [])
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "os":
            names = [f"os.{node.attr}"]
        for name in names:
            root = name.partition(".")[0]
            if root in CONCURRENCY_MODULES or (root == "os" and name.partition(".")[2] in PROCESS_CALLS):
                found.append(f"{name} (line {node.lineno})")
    return found


def test_the_source_scan_sees_imports_and_process_calls():
    src = "import os\nfrom threading import Thread\nimport subprocess as sp\nos.fork()\nos.path.join('a')\n"
    assert concurrency_in(src) == ["threading (line 2)", "subprocess (line 3)", "os.fork (line 4)"]


@pytest.mark.parametrize("package", ["mapping", "nav2"])
def test_the_algorithms_start_no_process_thread_or_pipe(package):
    """The algorithms are pure and synchronous: offloading lives in navlog.replay.workers only (the
    import-linter contract says the same of imports; this also sees ``os.fork`` and its kin)."""
    files = sorted((ALGORITHMS / package).rglob("*.py"))
    assert len(files) > 10
    found = {str(f.relative_to(ALGORITHMS)): hits for f in files if (hits := concurrency_in(f.read_text()))}
    assert found == {}
