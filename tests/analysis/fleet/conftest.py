"""A small fleet, made once per session from the recorded teleop log: two copies of it, a truncated
one and an empty one; and the teleop log replayed alone, to compare the fleet's outputs with."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

OVERRIDES = ("lidar_mapper=off",)  # the 2D mapper only: a replay of the teleop log takes about a second


def copy_log(src: Path, dest: Path) -> Path:
    try:
        os.link(src, dest)
    except OSError:
        shutil.copyfile(src, dest)
    return dest


@pytest.fixture(scope="session")
def fleet_dir(tmp_path_factory: pytest.TempPathFactory, teleop_log: Path) -> Path:
    folder = tmp_path_factory.mktemp("fleet") / "logs"
    folder.mkdir()
    copy_log(teleop_log, folder / "a.mcap")
    copy_log(teleop_log, folder / "b.mcap")
    (folder / "trunc.mcap").write_bytes(teleop_log.read_bytes()[: teleop_log.stat().st_size // 3])
    (folder / "empty.mcap").write_bytes(b"")
    return folder


@pytest.fixture(scope="session")
def reference(tmp_path_factory: pytest.TempPathFactory, teleop_log: Path) -> Path:
    """The teleop log replayed by ``run_replay`` alone (what ``navlog replay LOG -o OUT`` writes)."""
    from navlog.replay.session import run_replay

    out = tmp_path_factory.mktemp("fleet-reference") / "teleop"
    run_replay(teleop_log, "mapping", out, overrides=OVERRIDES, progress=False)
    return out


def folder_bytes(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}
