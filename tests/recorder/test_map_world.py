"""map_server maps as worlds: occupied cells as merged wall boxes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from navlog.cli import main
from navlog.recorder.map_world import merge_cells
from navlog.recorder.world import build_spec, clearance, load_world, occupancy
from navlog.replay.geometry import cell_to_world
from navlog.replay.io.map_server import load_map


def test_merge_cells_covers_exactly_the_occupied_cells():
    rng = np.random.default_rng(4)
    grid = rng.random((40, 60)) < 0.3
    grid[5:15, 10:20] = True  # a block: one rectangle of its own rows
    rects = merge_cells(grid)
    cover = np.zeros(grid.shape, int)
    for r0, c0, rows, cols in rects:
        cover[r0 : r0 + rows, c0 : c0 + cols] += 1
    assert np.array_equal(cover, grid.astype(int))  # every occupied cell once, nothing else
    assert merge_cells(np.ones((3, 4), bool)) == [(0, 0, 3, 4)]
    assert merge_cells(np.zeros((3, 4), bool)) == []


@pytest.fixture(scope="module")
def depot_yaml(shared_dir: Path) -> Path:
    return shared_dir / "external-data" / "nav2_bringup" / "maps" / "depot.yaml"


def test_depot_map_as_a_world(depot_yaml):
    ref = load_map(depot_yaml)
    occupied = ref.data == 100
    world = load_world(str(depot_yaml))
    assert world.name == "depot"
    assert len(world.solids) < occupied.sum() / 4  # 5947 cells as 1327 boxes
    assert all(s.shape == "box" and s.size[2] == 2.0 and s.center[2] == 1.0 for s in world.solids)
    # the world reproduces the map: a cell's centre is inside a wall exactly when the map says occupied
    rows, cols = slice(50, 150), slice(240, 360)  # a window of 100 x 120 cells, 601 of them walls
    xs = cell_to_world(np.arange(ref.width)[cols], ref.origin[0], ref.resolution)
    ys = cell_to_world(np.arange(ref.height)[rows], ref.origin[1], ref.resolution)
    gx, gy = np.meshgrid(xs, ys)
    inside = clearance(world, np.stack([gx.ravel(), gy.ravel()], axis=1)).reshape(gx.shape) < 0
    assert occupied[rows, cols].sum() > 300 and np.array_equal(inside, occupied[rows, cols])
    grid = occupancy(world, resolution=ref.resolution, margin=0.0)  # the ground-truth grid holds every wall cell
    ox, oy = (round((ref.origin[i] - grid.origin[i]) / ref.resolution) for i in (0, 1))
    assert grid.data[oy : oy + ref.height, ox : ox + ref.width][occupied].min() == 100
    assert build_spec(world).compile().ngeom == len(world.solids) + 1  # and the floor


def test_wall_height_and_unknown_cells(tmp_path, shared_dir):
    warehouse = shared_dir / "external-data" / "nav2_bringup" / "maps" / "warehouse.yaml"
    world = load_world(str(warehouse), wall_height=0.5)
    assert {s.size[2] for s in world.solids} == {0.5}
    assert "unknown cells treated as free" in world.notes[0]


def test_map_without_occupied_cells_is_refused(tmp_path, capsys):
    (tmp_path / "empty.pgm").write_bytes(b"P5\n4 3\n255\n" + bytes([254] * 12))
    (tmp_path / "empty.yaml").write_text(
        "image: empty.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n"
    )
    out = tmp_path / "out.yaml"
    assert main(["world-map", str(tmp_path / "empty.yaml"), "-o", str(out)]) == 2
    assert "empty.yaml: the map has no occupied cell" in capsys.readouterr().err
    assert not out.exists()


def test_a_wall_height_beyond_the_bound_or_an_origin_beyond_reach_is_refused(tmp_path, capsys):
    """--wall-height 1e300 made boxes no beam hit (every range inf), and a map origin of 1e300 m a world-map of
    0 x 126 cells: each is refused, naming the file and the value."""
    (tmp_path / "m.pgm").write_bytes(b"P5\n4 3\n255\n" + bytes([0] * 4 + [254] * 8))
    yaml = "image: m.pgm\nresolution: 0.05\norigin: [{x}, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n"
    (tmp_path / "m.yaml").write_text(yaml.format(x=0))
    out = tmp_path / "out.yaml"
    assert main(["world-map", str(tmp_path / "m.yaml"), "--wall-height", "1e300", "-o", str(out)]) == 2
    assert "m.yaml: wall height must be above 0 and at most 100 m, got 1e+300" in capsys.readouterr().err
    assert main(["world-map", str(tmp_path / "m.yaml"), "--wall-height", "100", "-o", str(out)]) == 0
    (tmp_path / "far.yaml").write_text(yaml.format(x="1.0e+300"))
    assert main(["world-map", str(tmp_path / "far.yaml"), "-o", str(tmp_path / "far_out.yaml")]) == 2
    assert "far.yaml: key 'origin' [1e+300, 0, 0] lies farther than 1e+08 m" in capsys.readouterr().err
    assert not (tmp_path / "far_out.yaml").exists()
