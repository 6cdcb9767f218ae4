"""The replay packages state their public API: every name in ``__all__`` resolves, lazily, to its definition."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

PACKAGES = ["navlog.replay", "navlog.replay.io", "navlog.replay.runtime", "navlog.replay.nodes"]


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
