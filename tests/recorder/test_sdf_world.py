"""Gazebo SDF worlds: Nav2's sandbox as a world (poses, meshes, the laser, MuJoCo, its map), and bad input."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import trimesh

from navlog.cli import main
from navlog.errors import ConfigError
from navlog.recorder.world import build_spec, clearance, import_mujoco, load_world, world_mesh
from navlog.replay.io.map_server import load_map
from tests.recorder.descriptions import MODEL_SDF, POLYLINE_WORLD, WORLD_SDF

INCH = 0.0254  # the unit of the sandbox's DAE files (<unit meter="0.0254">)


@pytest.fixture(scope="module")
def tb3_sim(shared_dir: Path) -> Path:
    return shared_dir / "external-data" / "nav2_sim" / "nav2_minimal_tb3_sim"


@pytest.fixture(scope="module")
def sandbox(tb3_sim: Path):
    return load_world(str(tb3_sim / "worlds" / "tb3_sandbox.sdf.xacro"))


def _poses(model_sdf: Path) -> dict[str, tuple[float, ...]]:
    link = ET.parse(model_sdf).getroot().find("model/link")
    assert link is not None
    return {
        c.get("name", ""): tuple(float(v) for v in (c.findtext("pose") or "").split()) for c in link.iter("collision")
    }


def test_sandbox_has_its_walls_pillars_and_hexagons_at_the_model_poses(sandbox, tb3_sim):
    poses = _poses(tb3_sim / "models" / "turtlebot3_world" / "model.sdf")
    by_name = {s.name.rsplit("/", 1)[-1]: s for s in sandbox.solids}
    assert set(by_name) == set(poses)
    pillars = [s for s in sandbox.solids if s.shape == "cylinder"]
    assert len(pillars) == 9
    for s in pillars:
        x, y, z = poses[s.name.rsplit("/", 1)[-1]][:3]
        assert s.center == pytest.approx((x, y, z)) and s.size == pytest.approx((0.3, 0.3, 0.5))
    hexagons = {n: s for n, s in by_name.items() if n in ("head", "left_hand", "right_hand", "left_foot", "right_foot")}
    for name, s in hexagons.items():
        assert s.shape == "mesh" and s.convex and s.closed and len(s.faces) == 3 * 20
        scale = 0.8 if name == "head" else 0.55
        x, y, z = poses[name][:3]
        assert s.center[:2] == pytest.approx((x, y), abs=1e-6)  # the hexagon mesh is centred on its origin
        # hexagon.dae: corners at x = ±57.735 in, flats at y = ±50 in, 100 in high, from z = 0
        assert s.size == pytest.approx((2 * 57.735 * INCH * scale, 100 * INCH * scale, 100 * INCH * scale), abs=1e-4)
        assert s.z_range[0] == pytest.approx(z, abs=1e-9)
    wall = by_name["body"]  # one ring of walls turned by -90°: not convex, closed
    assert wall.shape == "mesh" and not wall.convex and wall.closed
    k = 0.25 * INCH
    assert wall.size == pytest.approx((2 * 519.615 * k, 2 * 450 * k, 200 * k), abs=1e-4)
    assert wall.z_range == pytest.approx((-0.3, -0.3 + 200 * k))
    assert sandbox.name == "tb3_sandbox"
    assert sandbox.notes[0] == "ignored: 1 light, 1 physics, 4 plugin, 1 scene"


def _inner_wall_distance(x: float, y: float) -> float:
    """Distance from (x, y) to the sandbox's inner wall hexagon (wall.dae's inner corners, turned by -90°)."""
    k = 0.25 * INCH
    corners = [(-400, 230.94), (0, 461.88), (400, 230.94), (400, -230.94), (0, -461.88), (-400, -230.94)]
    pts = [np.array([cy, -cx]) * k for cx, cy in corners]  # yaw -90°: (x, y) -> (y, -x)
    p = np.array([x, y])
    best = math.inf
    for a, b in zip(pts, pts[1:] + pts[:1]):
        t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0, 1)
        best = min(best, float(np.linalg.norm(p - (a + t * (b - a)))))
    return best


def test_laser_from_the_tutorial_start_sees_the_pillar_and_the_wall(sandbox):
    from navlog.recorder.sensors import RayCaster

    caster = RayCaster(world_mesh(sandbox))
    origin = np.array([-2.0, -0.5, 0.2])  # the tutorial's start pose, at a laser's height
    bearing = math.atan2(0.0 - -0.5, -1.1 - -2.0)  # towards the nearest pillar, at (-1.1, 0), r 0.15
    d = caster.cast_distances(origin[None], np.array([[math.cos(bearing), math.sin(bearing), 0.0]]))
    assert d[0] == pytest.approx(math.hypot(0.9, 0.5) - 0.15, abs=1e-3)
    angles = np.linspace(-math.pi, math.pi, 3600, endpoint=False)
    dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    ranges = caster.cast_distances(np.broadcast_to(origin, dirs.shape), dirs)
    assert ranges.min() == pytest.approx(_inner_wall_distance(-2.0, -0.5), abs=2e-3)  # the wall: 0.555 m
    assert float(clearance(sandbox, np.array([[-2.0, -0.5]]), 0.1, 0.3)[0]) == pytest.approx(ranges.min(), abs=2e-3)


def test_mujoco_sees_the_same_geometry(sandbox):
    mujoco = import_mujoco()
    model = build_spec(sandbox).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    meshes = int((model.geom_type == mujoco.mjtGeom.mjGEOM_MESH).sum())
    assert meshes == 5 + 48  # a hull per hexagon; one slab per triangle of the walls (a hull would fill the room)
    geomid = np.array([-1], dtype=np.int32)

    def ray(origin, direction):
        return mujoco.mj_ray(model, data, np.array(origin, float), np.array(direction, float), None, 1, -1, geomid)

    start = [-2.0, -0.5, 0.2]
    to_pillar = np.array([0.9, 0.5, 0.0]) / math.hypot(0.9, 0.5)
    assert ray(start, to_pillar) == pytest.approx(math.hypot(0.9, 0.5) - 0.15, abs=1e-6)
    # the head hexagon at (3.5, 0), scale 0.8: its corner at x = 3.5 - 57.735 in * 0.8
    assert ray([2.0, 0.0, 0.2], [1.0, 0.0, 0.0]) == pytest.approx(1.5 - 57.735 * INCH * 0.8, abs=1e-4)
    # the inner face of the west walls, from (0, 0.55) between the pillars; less half a slab (1 cm along
    # the wall's normal, 30° off the ray)
    k = 0.25 * INCH
    corner, top = 461.88 * k, (230.94 * k, 400 * k)  # the corner (-corner, 0) and the next (-top[0], top[1])
    wall_x = corner - 0.55 * (corner - top[0]) / top[1]
    assert ray([0.0, 0.55, 0.2], [-1.0, 0.0, 0.0]) == pytest.approx(
        wall_x - 0.01 / math.cos(math.radians(30)), abs=1e-4
    )


def test_world_map_of_the_sandbox_agrees_with_nav2s_map(tmp_path, tb3_sim, shared_dir):
    from scipy.ndimage import binary_dilation

    out = tmp_path / "sandbox.yaml"
    world = tb3_sim / "worlds" / "tb3_sandbox.sdf.xacro"
    assert main(["world-map", str(world), "--height", "0.17", "--margin", "0", "-o", str(out)]) == 0
    ours, ref = load_map(out), load_map(shared_dir / "external-data" / "nav2_bringup" / "maps" / "tb3_sandbox.yaml")
    assert ours.resolution == ref.resolution == 0.05
    # align: our grid placed in Nav2's by the two origins (both whole cells)
    ox, oy = (round((ours.origin[i] - ref.origin[i]) / ref.resolution) for i in (0, 1))
    mine = np.zeros(ref.data.shape, bool)
    mine[oy : oy + ours.height, ox : ox + ours.width] = ours.data == 100
    theirs, known = ref.data == 100, ref.data >= 0
    near = np.ones((3, 3), bool)  # a cell matches within one cell
    seen = mine & binary_dilation(known, near)  # Nav2's map knows nothing inside the walls
    precision = (seen & binary_dilation(theirs, near)).sum() / seen.sum()
    recall = (theirs & binary_dilation(mine, near)).sum() / theirs.sum()
    f1 = 2 * precision * recall / (precision + recall)
    assert f1 >= 0.9, (precision, recall)


# ---------------------------------------------------------------- poses and includes


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


@pytest.fixture
def small_world(tmp_path) -> Path:
    _write(tmp_path / "models" / "crate" / "model.config", '<model><sdf version="1.9">model.sdf</sdf></model>')
    _write(tmp_path / "models" / "crate" / "model.sdf", MODEL_SDF)
    return _write(tmp_path / "worlds" / "small.sdf", WORLD_SDF)


def test_poses_compose_through_models_links_frames_and_includes(small_world, tmp_path):
    w = load_world(str(small_world), resource_paths=[tmp_path / "models"])
    by_name = {s.name: s for s in w.solids}
    # outer at (10, 0) turned 90°: inner's (1, 0) and the link's (0, 1) turn into (-1, 1) -> (9, 1)
    post = by_name["outer/inner/l/post"]
    assert post.shape == "cylinder" and post.center == pytest.approx((9.0, 1.0, 1.0))
    rel = by_name["outer/l2/rel"]  # relative to the frame "corner": (0, 2) turned -> (-2, 0)
    assert rel.center == pytest.approx((8.0, 0.0, 0.25)) and rel.yaw == pytest.approx(math.pi / 2)
    ball = by_name["outer/l2/ball"]  # a sphere: a convex mesh
    assert ball.shape == "mesh" and ball.convex and ball.center == pytest.approx((10.0, 0.0, 3.0), abs=1e-9)
    assert ball.size == pytest.approx((1.0, 1.0, 1.0), abs=0.03)
    crate = by_name["outer/crate_1/base/c"]  # the include's pose replaces the model's; the link's (1, 0) turns
    assert crate.center == pytest.approx((10.0, 1.0, 0.5)) and crate.size == (1.0, 2.0, 1.0)
    assert "ignored: 1 light" in w.notes
    assert any("warning:" in n and "gone.dae" in n and "crate_1/base" in n for n in w.notes)  # a visual: a warning


# ---------------------------------------------------------------- bad input: exit 2, a message, no file


def _fails(capsys, tmp_path, world: str, *extra: str) -> str:
    out = tmp_path / "out.yaml"
    assert main(["world-map", world, "-o", str(out), *extra]) == 2
    assert not out.exists() and not out.with_suffix(".pgm").exists()
    err = capsys.readouterr().err
    assert err.count("\n") == 1  # one line
    return err


def test_missing_collision_mesh_names_the_file_and_link(capsys, tmp_path):
    bad = MODEL_SDF.replace(
        "<box><size>1 2 1</size></box>", "<mesh><uri>meshes/none.stl</uri><scale>2 2 2</scale></mesh>"
    )
    world = _write(tmp_path / "bad.sdf", bad)
    err = _fails(capsys, tmp_path, str(world))
    assert str(world) in err and "link 'crate/base'" in err and "collision mesh missing" in err
    assert "none.stl" in err


def test_xacro_error_names_file_and_line(capsys, tmp_path):
    text = (
        '<?xml version="1.0"?>\n<sdf xmlns:xacro="http://www.ros.org/wiki/xacro">\n<world name="w">\n'
        '<model name="${undefined_size}"/>\n</world>\n</sdf>\n'
    )
    world = _write(tmp_path / "bad.sdf.xacro", text)
    err = _fails(capsys, tmp_path, str(world))
    assert f"{world}:4: xacro error" in err and "undefined_size" in err


def test_fuel_include_names_the_uri_and_every_folder_searched(capsys, tmp_path, shared_dir, monkeypatch):
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(tmp_path / "gz_models"))
    depot = shared_dir / "external-data" / "nav2_sim" / "nav2_minimal_tb4_sim" / "worlds" / "depot.sdf"
    err = _fails(capsys, tmp_path, str(depot), "--resource-path", str(tmp_path / "mine"))
    assert "https://fuel.gazebosim.org/1.0/OpenRobotics/models/Depot" in err
    assert str(tmp_path / "mine") in err and str(tmp_path / "gz_models") in err
    # a copy of the model on the resource path is what the URL names
    _write(tmp_path / "mine" / "Depot" / "model.config", '<model><sdf version="1.6">model.sdf</sdf></model>')
    _write(tmp_path / "mine" / "Depot" / "model.sdf", MODEL_SDF)
    w = load_world(str(depot), resource_paths=[tmp_path / "mine"])
    assert [s.name for s in w.solids] == ["crate/base/c"]  # no <name> in the include: the model's own


def test_world_without_static_geometry_is_refused(capsys, tmp_path, tb3_sim):
    err = _fails(capsys, tmp_path, str(tb3_sim / "worlds" / "tb3_empty_world.sdf.xacro"))
    assert "tb3_empty_world.sdf.xacro: no collision geometry besides the ground plane" in err


def test_unknown_uri_scheme_in_a_mesh_is_an_error():
    from navlog.recorder.resources import resolve_uri

    with pytest.raises(ConfigError, match="cannot resolve https://example.com/m.dae"):
        resolve_uri("https://example.com/m.dae", Path("."), [])


def test_polyline_walls_are_extruded_with_their_holes_and_poses(tmp_path):
    """A pen: a 3 x 2 m rectangle with a 2.4 x 1.4 m hole (walls 0.3 m thick), 0.8 m high from 0.1 m, the model
    at (2, 1) turned 90 degrees; an L of 1 m arms 0.4 m thick. The laser from the pen's centre meets the inner
    walls 0.7 m (across) and 1.2 m (along) away; MuJoCo's rays agree; the world map has the walls and the
    free hole."""
    from navlog.recorder.sensors import RayCaster
    from navlog.recorder.world import occupancy

    world = load_world(str(_write(tmp_path / "pen.sdf", POLYLINE_WORLD)))
    assert not any("polyline" in n for n in world.notes)
    walls = [s for s in world.solids if s.name.startswith("pen/l/walls")]
    assert len(walls) == 1 and walls[0].shape == "mesh" and walls[0].closed and not walls[0].convex
    assert walls[0].center == pytest.approx((2.0, 1.0, 0.5), abs=1e-9)  # turned: 2 m along x, 3 m along y
    assert walls[0].size == pytest.approx((2.0, 3.0, 0.8), abs=1e-9)
    caster = RayCaster(world_mesh(world))
    origin = np.array([[2.0, 1.0, 0.4]])
    dirs = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]])
    d = caster.cast_distances(np.repeat(origin, 4, axis=0), dirs)
    np.testing.assert_allclose(d, [0.7, 1.2, 1.2, 0.7], atol=1e-6)
    assert caster.cast_distances(np.array([[2.0, 1.0, 0.95]]), dirs[:1])[0] > 5  # above the 0.9 m top
    mujoco = import_mujoco()
    model = build_spec(world).compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    geomid = np.array([-1], dtype=np.int32)
    hit = mujoco.mj_ray(model, data, np.array([2.0, 1.0, 0.4]), np.array([1.0, 0.0, 0.0]), None, 1, -1, geomid)
    assert hit == pytest.approx(0.7 - 0.01, abs=1e-4)  # less half a slab of the non-convex walls
    # the L: its corner at (2, 1) + (0, 3) turned 90 degrees = (-1, 1), turned back by -90 degrees: x in
    # [-1, 0], y in [1, 2] less the notch x in [-0.6, 0], y in [1.4, 2]
    grid = occupancy(world, margin=0.0)
    points = [(-0.8, 1.8), (-0.2, 1.2), (-0.3, 1.7), (2.0, 1.0), (2.85, 1.0), (1.15, 2.4)]
    assert [grid.value_at(*p) == 100 for p in points] == [True, True, False, False, True, True]


def test_a_polyline_with_two_points_names_the_fix(tmp_path):
    bad = POLYLINE_WORLD.replace("<point>0.4 1</point><point>0 1</point>", "").replace(
        "<point>1 0.4</point><point>0.4 0.4</point>", ""
    )
    with pytest.raises(ConfigError, match=r"pen\.sdf: link 'pen/l' collision 'ell' <polyline>: .*3 <point>.*got 2"):
        load_world(str(_write(tmp_path / "pen.sdf", bad)))


def test_a_model_included_twice_under_one_name_is_an_error_naming_it(capsys, small_world, tmp_path):
    twice = small_world.read_text().replace(
        "</include>", "</include>\n      <include><uri>model://crate</uri><name>crate_1</name></include>", 1
    )
    _write(small_world, twice)
    err = _fails(capsys, tmp_path, str(small_world), "--resource-path", str(tmp_path / "models"))
    assert "two collisions named 'outer/crate_1/" in err and "unique among their siblings" in err


def test_a_mesh_scaled_to_nothing_names_the_file_and_link(capsys, tmp_path):
    """A collision mesh with a scale of 0 was flattened away without a word (a robot's was refused)."""
    stl = trimesh.creation.box((1.0, 1.0, 1.0))
    (tmp_path / "meshes").mkdir()
    stl.export(tmp_path / "meshes" / "crate.stl")
    bad = MODEL_SDF.replace(
        "<box><size>1 2 1</size></box>", "<mesh><uri>meshes/crate.stl</uri><scale>0 0 0</scale></mesh>"
    )
    world = _write(tmp_path / "bad.sdf", bad)
    err = _fails(capsys, tmp_path, str(world))
    assert (
        str(world) in err
        and "link 'crate/base'" in err
        and "scale: each factor must be non-zero and finite, got 0 0 0" in err
    )
