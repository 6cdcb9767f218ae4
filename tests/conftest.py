"""Shared fixtures: where the external data lives."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = (REPO / ".." / "shared").resolve()


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    if not SHARED.is_dir():
        pytest.skip(f"external data not found at {SHARED}")
    return SHARED


@pytest.fixture(scope="session")
def bags_dir(shared_dir: Path) -> Path:
    return shared_dir / "external-data" / "bags"


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
