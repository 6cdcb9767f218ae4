"""Fixtures of the export tests: the sample log, and a check that a bad request writes nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from navlog.cli import main
from tests.analysis import sample_nav_log as sample


@pytest.fixture(scope="package")
def sample_log(tmp_path_factory) -> Path:
    return sample.write_sample_log(tmp_path_factory.mktemp("log") / "sample.mcap")


@pytest.fixture
def refused(sample_log, tmp_path, capsys):
    """``refused(args, message)``: `navlog export SAMPLE -o OUT ARGS` fails naming ``message`` and writes nothing."""

    def check(args: list[str], message: str) -> None:
        out = tmp_path / "out"
        assert main(["export", str(sample_log), "-o", str(out)] + args) == 2
        err = capsys.readouterr().err
        assert message in err, err
        assert list(tmp_path.iterdir()) == []  # no output, no temporary folder left

    return check
