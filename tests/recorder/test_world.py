"""World geometry: solids from YAML, clearance, the ground-truth grid."""

from __future__ import annotations

import math
import re
import subprocess
import sys

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.recorder.world import clearance, load_world, occupancy, world_mesh, write_world_map


def test_indoor_room_solids_at_the_article_poses():
    w = load_world("indoor_room")
    names = {s.name.split("/")[0] for s in w.solids}
    assert names == {
        "wall_east",
        "wall_west",
        "wall_north",
        "wall_south",
        "wall_block_1",
        "wall_block_2",
        "cabinet_1",
        "bookshelf_1",
        "wooden_case_1",
    }
    back = next(s for s in w.solids if s.name == "bookshelf_1/back")
    assert back.center == pytest.approx((-2.0, -2.0 + 0.005, 0.6)) and back.size == pytest.approx((0.9, 0.01, 1.2))
    # the cabinet is turned 90°: its back plate (model +x) faces +y
    cab = next(s for s in w.solids if s.name == "cabinet_1/back_plate")
    assert cab.center[:2] == pytest.approx((-2.0, 2.0 + 0.235), abs=1e-4)


def test_clearance_to_known_geometry():
    w = load_world("walled_room")
    pts = np.array([[2.0, 2.0], [2.0, 3.0], [0.0, 0.0], [-2.0, -3.0], [4.5, 0.0]])
    d = clearance(w, pts)
    assert d[0] == pytest.approx(-0.5)  # inside the cylinder, 0.5 from its side
    assert d[1] == pytest.approx(0.5)  # 1 m from the cylinder axis
    assert d[2] == pytest.approx(math.hypot(1.5, 1.5))  # to the box corner (-1.5, -1.5)
    assert d[3] == pytest.approx(0.5)  # 0.5 m below the box
    assert d[4] == pytest.approx(0.4)  # wall_1 inner face at x = 4.9
    # the cylinder is 1 m tall: above it, only walls count
    assert clearance(w, pts[:1], z_min=1.2, z_max=1.5)[0] == pytest.approx(2.9)


def test_occupancy_grid_with_margin_and_height_slice():
    w = load_world("walled_room")
    g0 = occupancy(w, 0.05, 0.0)
    g15 = occupancy(w, 0.05, 0.15)
    assert g0.value_at(2.0, 2.0) == 100 and g0.value_at(2.6, 2.0) == 0
    assert g15.value_at(2.6, 2.0) == 100 and g15.value_at(2.7, 2.0) == 0
    assert g0.value_at(0.0, 0.0) == 0
    # above the 1 m obstacles only the 2 m walls remain
    high = occupancy(w, 0.05, 0.0, 1.5, 1.5)
    assert high.value_at(2.0, 2.0) == 0 and high.value_at(5.0, 0.0) == 100
    # indoor_room at the scan plane (0.15 m) crosses the bookshelf's sides and back but not its shelves
    room = occupancy(load_world("indoor_room"), 0.05, 0.0, 0.15, 0.15)
    assert room.value_at(-2.0, -2.2) == 0 and room.value_at(-2.0, -2.0) == 100 and room.value_at(-2.45, -2.2) == 100
    # a margin is a distance a robot keeps: negative or beyond 50 m, it names itself (-1 drew an empty map)
    for bad in (-1.0, 1e308):
        with pytest.raises(ConfigError, match=re.escape(f"margin {bad} m is out of range: must be 0 to 50 m")):
            occupancy(w, 0.05, bad)


def test_mesh_covers_every_solid_and_the_floor():
    mesh = world_mesh(load_world("indoor_room"))
    assert len(mesh.triangles) == 35 * 12 + 12
    lo, hi = mesh.get_min_bound(), mesh.get_max_bound()
    assert lo[2] == pytest.approx(-0.01) and hi[2] == pytest.approx(2.5)


def test_write_world_map_writes_what_it_reports_and_refuses_to_overwrite(tmp_path):
    from navlog.errors import NavlogError
    from navlog.replay.io.map_server import load_map

    res = write_world_map("walled_room", tmp_path / "m.yaml", margin=0.15, mesh=tmp_path / "w.ply")
    loaded = load_map(res.yaml_path)
    assert res.world == "walled_room" and res.pgm_path == tmp_path / "m.pgm" and res.mesh_path.stat().st_size > 0
    assert loaded == occupancy(load_world("walled_room"), 0.05, 0.15)
    assert (res.width, res.height, res.occupied) == (loaded.width, loaded.height, int((loaded.data == 100).sum()))
    assert loaded.value_at(2.6, 2.0) == 100 and loaded.value_at(2.7, 2.0) == 0
    # an existing PGM is found before anything is written: the new YAML does not appear
    with pytest.raises(NavlogError, match="already exists"):
        write_world_map("walled_room", tmp_path / "m2.yaml", mesh=tmp_path / "w.ply")
    assert not (tmp_path / "m2.yaml").exists() and not (tmp_path / "m2.pgm").exists()


def test_open3d_imported_by_two_threads_at_once_is_whole_in_both_without_its_viewer() -> None:
    """The second thread waits for the module the first is importing (no lock of the recorder's own), and
    the viewer's placeholder is gone after: a later ``import open3d.visualization`` imports the real one."""
    code = (
        "import sys, threading\n"
        "from navlog.recorder.world import import_open3d\n"
        "got = []\n"
        "threads = [threading.Thread(target=lambda: got.append(import_open3d())) for _ in range(2)]\n"
        "for t in threads: t.start()\n"
        "for t in threads: t.join()\n"
        "print(len(got), got[0] is got[1], hasattr(got[1].t.geometry, 'RaycastingScene'),\n"
        "      'open3d.visualization' in sys.modules, hasattr(got[0], 'visualization'), 'dash' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["2", "True", "True", "False", "False", "False"]


def test_a_world_map_too_large_names_the_extent_the_obstacles_at_its_edges_and_a_resolution_that_fits(
    tmp_path, monkeypatch
):
    """It said 'choose a coarser --resolution, e.g. 0.05' at 0.05 m, and for a box 1e300 m long printed the
    cell counts in 300 digits; it names the world, its extent and the obstacles at its edges, and a resolution
    that fits (the grid's bound lowered to 10,000 cells here: the suggestion fits, 1 % finer does not)."""
    from navlog.recorder import world as world_module

    monkeypatch.setattr(world_module, "MAX_GRID_CELLS", 10_000)
    room = load_world("indoor_room")
    with pytest.raises(ConfigError) as err:
        write_world_map(room, tmp_path / "m.yaml", resolution=0.05)
    said = str(err.value)
    assert said.startswith(
        "world 'indoor_room': a grid of 228 x 228 cells at 0.05 m is too large (over navlog's 10,000)"
    )
    assert "wall_east" in said and "its obstacles span 10.4 x 10.4 m (x -5.2 to 5.2, y -5.2 to 5.2;" in said
    fits = float(re.search(r"choose a --resolution of ([0-9.]+) m or more$", said).group(1))
    assert write_world_map(room, tmp_path / "m.yaml", resolution=fits).width == 100  # 100 x 100: the bound itself
    with pytest.raises(ConfigError):
        write_world_map(room, tmp_path / "m2.yaml", resolution=fits * 0.99)
    sdf = tmp_path / "far.sdf"
    sdf.write_text(
        '<?xml version="1.0"?>\n<sdf version="1.6"><world name="far"><model name="wall"><static>true</static>'
        '<link name="link"><collision name="c"><geometry><box><size>1e300 0.2 2</size></box></geometry>'
        "</collision></link></model></world></sdf>\n"
    )
    with pytest.raises(ConfigError) as err:
        write_world_map(load_world(str(sdf)), tmp_path / "far.yaml")
    said = str(err.value)
    assert (
        "span 1e+300 x 0.2 m" in said
        and "wall/link/c" in said
        and said.endswith("check those obstacles' poses and sizes")
    )
    assert len(said) < 400
