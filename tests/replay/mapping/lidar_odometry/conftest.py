from __future__ import annotations

import pytest

from tests.replay import lidar_scene as scene


@pytest.fixture(scope="package")
def room():
    """The ray-casting scene of the test room (see tests/replay/lidar_scene.py)."""
    return scene.raycasting_scene(scene.room_mesh())
