"""navlog.analysis states its public API and stays light to import (the CLI's --help imports it)."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

HEAVY = ("rerun", "open3d", "scipy")


def test_importing_the_package_loads_no_heavy_library():
    code = (
        "import sys, navlog.analysis, navlog.analysis.metrics, navlog.analysis.info, navlog.analysis.tables; "
        f"print(sorted(m for m in {HEAVY!r} if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize(
    "package",
    ["navlog.analysis", "navlog.analysis.metrics", "navlog.analysis.view", "navlog.analysis.export"],
)
def test_every_public_name_resolves(package):
    mod = importlib.import_module(package)
    assert mod.__doc__ and len(set(mod.__all__)) == len(mod.__all__)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name
    assert set(mod.__all__) <= set(dir(mod))
