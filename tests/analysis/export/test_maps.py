"""A PCD map projected to a map_server map (``navlog.analysis.export.pcd_to_map``)."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.analysis.export import pcd_to_map
from navlog.errors import NavlogError
from navlog.replay.io.map_server import load_map
from navlog.replay.io.pcd import write_pcd


def room_cloud() -> np.ndarray:
    """A 2 x 2 m floor (z = 0) sampled every 2.5 cm, and a wall along x = 1.0 m, 0.1..1.0 m high."""
    g = np.arange(0.0, 2.0, 0.025) + 0.0125
    fx, fy = np.meshgrid(g, g)
    floor = np.stack([fx.ravel(), fy.ravel(), np.zeros(fx.size)], axis=1)
    wy, wz = np.meshgrid(g, np.arange(0.1, 1.0, 0.05))
    wall = np.stack([np.full(wy.size, 1.01), wy.ravel(), wz.ravel()], axis=1)
    return np.concatenate([floor, wall]).astype(np.float32)


def test_wall_occupied_floor_free_outside_unknown(tmp_path):
    write_pcd(tmp_path / "room.pcd", room_cloud())
    res = pcd_to_map(tmp_path / "room.pcd", tmp_path / "map.yaml", z_min=0.05, z_max=1.5)
    grid = load_map(res.yaml_path)
    assert res.points == len(room_cloud())
    assert grid.value_at(1.01, 1.0) == 100  # the wall
    assert grid.value_at(0.5, 1.0) == 0 and grid.value_at(1.5, 1.0) == 0  # floor on both sides
    assert grid.value_at(-0.04, 1.0) == -1  # the padding cell outside the cloud
    # one column of 0.05 m cells along the 2 m wall
    assert res.occupied == int((grid.data == 100).sum()) == 40
    assert res.free == int((grid.data == 0).sum())


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("resolution", -1.0, "resolution -1.0: must be 0.005 to 5 m a cell"),
        ("resolution", 1e-300, "resolution 1e-300: must be 0.005 to 5 m a cell"),
        ("resolution", float("nan"), "resolution nan"),
        ("z_min", float("nan"), "must be finite heights"),
        ("min_points", 0, "min_points 0: must be 1 to"),
    ],
)
def test_absurd_projection_settings_are_refused_with_their_names(tmp_path, key, value, message):
    # a negative resolution ended in an IndexError, a 1e-300 one in an index of -2^63
    write_pcd(tmp_path / "room.pcd", np.array([[0.0, 0.0, 0.5], [1.0, 0.0, 0.5]], dtype=np.float32))
    settings = {"z_min": 0.1, "z_max": 1.0, key: value}
    with pytest.raises(NavlogError, match=message):
        pcd_to_map(tmp_path / "room.pcd", tmp_path / "m.yaml", **settings)
    assert not (tmp_path / "m.yaml").exists()


def test_missing_or_empty_pcd_is_named(tmp_path):
    with pytest.raises(NavlogError, match="nope.pcd: no such file"):
        pcd_to_map(tmp_path / "nope.pcd", tmp_path / "m.yaml", z_min=0.1, z_max=1.0)
    (tmp_path / "bad.pcd").write_text("not a point cloud\n")
    with pytest.raises(NavlogError, match="bad.pcd"):
        pcd_to_map(tmp_path / "bad.pcd", tmp_path / "m.yaml", z_min=0.1, z_max=1.0)
    assert not (tmp_path / "m.yaml").exists()
