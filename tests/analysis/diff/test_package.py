"""navlog.analysis.diff states its public API and stays light to import."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest


def test_every_public_name_resolves():
    mod = importlib.import_module("navlog.analysis.diff")
    assert mod.__doc__ and len(set(mod.__all__)) == len(mod.__all__)
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name
    assert set(mod.__all__) <= set(dir(mod))


def test_importing_the_package_and_the_command_loads_no_numpy():
    code = (
        "import sys, navlog.analysis.diff, navlog.commands.diff; "
        "print(sorted(m for m in ('numpy', 'scipy', 'open3d', 'rerun') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_help_lists_every_tolerance_key(capsys):
    from navlog.analysis.diff.tolerances import tolerance_keys
    from navlog.cli import main

    with pytest.raises(SystemExit):
        main(["diff", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert [k for k in tolerance_keys() if k not in text] == []
