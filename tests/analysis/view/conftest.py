"""Fixtures of the view tests: the sample log, its .rrd (saved once by `navlog view --save`), and the .rrd read back."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.cli import main
from tests.analysis import sample_nav_log as sample
from tests.analysis.view.rrd import read_rrd


@pytest.fixture(scope="package")
def sample_log(tmp_path_factory) -> Path:
    return sample.write_sample_log(tmp_path_factory.mktemp("log") / "sample.mcap")


@pytest.fixture(scope="package")
def rrd(sample_log, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("view") / "sample.rrd"
    assert main(["-q", "view", str(sample_log), "--save", str(out)]) == 0
    return out


@pytest.fixture(scope="package")
def data(rrd) -> dict:
    return read_rrd(rrd)
