"""Shared fixtures: where the external data lives, and the recordings several modules replay.

The external data (real rosbag2 folders, the Nav2 parameter files of public robots, the seed texts) is
read from the folder the environment variable ``NAVLOG_SHARED_DIR`` names, else from ``shared`` beside
the repository (``REPO/../shared``; see ``tests/shared_data.py``). A test that needs it takes the
``shared_dir`` fixture or one built on it (``bags_dir``, ``params_dir``, ``seeds_dir``) and never
names a path of its own; when the folder is absent the test is skipped with the path it looked at.

    NAVLOG_SHARED_DIR=/data/navlog-shared .venv/bin/python -m pytest -q
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.shared_data import SHARED_DIR_VARIABLE, default_shared_dir


def _folder(path: Path, what: str) -> Path:
    if not path.is_dir():
        pytest.skip(f"{what} not found at {path} (set {SHARED_DIR_VARIABLE} to the folder that holds it)")
    return path


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The external data folder; skips the test when it is absent."""
    return _folder(default_shared_dir(), "external data")


@pytest.fixture(scope="session")
def bags_dir(shared_dir: Path) -> Path:
    """``external-data/bags``: real rosbag2 folders (neato_drive_square, tb3_gazebo_walker, ...)."""
    return _folder(shared_dir / "external-data" / "bags", "external bags")


@pytest.fixture(scope="session")
def params_dir(shared_dir: Path) -> Path:
    """``external-data/params``: Nav2 parameter files of public robots (Jazzy bringup, TurtleBot3/4 Humble)."""
    return _folder(shared_dir / "external-data" / "params", "external Nav2 parameter files")


@pytest.fixture(scope="session")
def seeds_dir(shared_dir: Path) -> Path:
    """``seeds``: the seed texts (``000_*.txt``, ``001_*.txt``, ...)."""
    return _folder(shared_dir / "seeds", "seed texts")


@pytest.fixture(scope="session")
def teleop_log(tmp_path_factory) -> Path:
    """A 17 s teleop recording of go2 in indoor_room, seed 3, noise on."""
    from navlog.recorder.record import prepare, record

    out = tmp_path_factory.mktemp("teleop") / "teleop.mcap"
    record(prepare("indoor_room", "go2", "teleop", seed=3), out, progress=False)
    return out


@pytest.fixture(scope="session")
def mapping_log(tmp_path_factory) -> Path:
    """The full mapping tour of go2 in indoor_room (about 138 s of sim time), seed 7, noise on."""
    from navlog.recorder.record import prepare, record

    out = tmp_path_factory.mktemp("mapping") / "mapping.mcap"
    record(prepare("indoor_room", "go2", "mapping", seed=7), out, progress=False)
    return out
