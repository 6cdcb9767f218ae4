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
