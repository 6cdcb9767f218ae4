"""Worlds: a walled room and objects from YAML, a Gazebo SDF world, or a map_server map, as solids.

A world is one of:

- navlog's world YAML (below);
- a Gazebo SDF world (``.sdf``, ``.world``, ``.sdf.xacro``): the collision geometry of its models
  (``navlog.recorder.sdf_world``), meshes as triangles;
- a map_server map (a YAML naming its ``image``): its occupied cells as walls
  (``navlog.recorder.map_world``).

A world file (``config/worlds/NAME.yaml``) places objects by ``pose: [x, y, yaw]`` (yaw in radians,
the object's base on the floor). An object is either a primitive (``shape: box | cylinder``) or an
instance of a model (``model: NAME``, ``config/models/NAME.yaml``), whose parts are boxes given as
in the Gazebo model's collision geometry: centre ``pos`` in the model frame and full ``size``.

The resolved ``Solid`` list is the one truth about the world's geometry: the simulator builds its
MuJoCo model from it (``build_spec``), the sensors cast rays against its mesh (``world_mesh``), and
the ground-truth grid (``occupancy``) and clearance checks (``clearance``) are computed from it.
"""

from __future__ import annotations

import logging
import math
import os
import sys
import types
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.solids import Solid
from navlog.replay.config import load_config, named_config, to_mapping
from navlog.replay.geometry import cell_to_world, se2_compose
from navlog.replay.limits import MAX_GRID_RESOLUTION_M, MAX_INFLATION_RADIUS_M

log = logging.getLogger(__name__)

SDF_SUFFIXES = (".sdf", ".world")  # a Gazebo SDF world, also with .xacro after it


@dataclass(frozen=True)
class Part:
    name: str
    shape: Literal["box", "cylinder"] = "box"
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)  # box: full edge lengths
    radius: float = 0.0  # cylinder
    height: float = 0.0  # cylinder
    yaw: float = 0.0


@dataclass(frozen=True)
class ModelSpec:
    parts: list[Part]
    description: str = ""
    source: str = ""


@dataclass(frozen=True)
class ObjectSpec:
    name: str
    pose: tuple[float, float, float]  # x, y, yaw (rad)
    model: str = ""
    shape: Literal["", "box", "cylinder"] = ""
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.0
    height: float = 0.0


@dataclass(frozen=True)
class WallsSpec:
    size: tuple[float, float]  # inner extent x, y (m), centred on the origin
    thickness: float = 0.2
    height: float = 2.5


@dataclass(frozen=True)
class WorldSpec:
    name: str
    description: str = ""
    walls: WallsSpec | None = None
    objects: list[ObjectSpec] = field(default_factory=list)
    floor: bool = True


@dataclass
class World:
    spec: WorldSpec
    solids: list[Solid]
    path: Path
    notes: list[str] = field(default_factory=list)  # what loading ignored or assumed, for the summary

    @property
    def name(self) -> str:
        return self.spec.name

    def bounds(self) -> tuple[float, float, float, float]:
        """xmin, ymin, xmax, ymax over all solids."""
        xs, ys = [], []
        for s in self.solids:
            for dx in (-s.size[0] / 2, s.size[0] / 2):
                for dy in (-s.size[1] / 2, s.size[1] / 2):
                    x, y, _ = se2_compose((s.center[0], s.center[1], s.yaw), (dx, dy, 0.0))
                    xs.append(x)
                    ys.append(y)
        return min(xs), min(ys), max(xs), max(ys)


def load_model(name: str) -> ModelSpec:
    return load_config(ModelSpec, named_config("models", name))


def _numbers(node: object) -> list[float]:
    if isinstance(node, dict):
        node = list(node.values())
    if isinstance(node, list):
        return [v for item in node for v in _numbers(item)]
    return [node] if isinstance(node, (int, float)) and not isinstance(node, bool) else []


def load_world(
    name: str,
    *,
    resource_paths: Sequence[Path | str] = (),
    wall_height: float | None = None,
    args: dict[str, str] | None = None,
) -> World:
    """Load a world: ``config/worlds/NAME.yaml`` or a path to a world YAML, an SDF world or a
    map_server map (module docstring), resolved into solids.

    ``resource_paths``: folders searched first for an SDF world's ``model://`` and ``package://``
    files; ``wall_height``: a map's walls (default 2 m); ``args``: an ``.sdf.xacro`` world's xacro
    arguments."""
    from navlog.recorder.map_world import DEFAULT_WALL_HEIGHT, is_map_yaml

    if name.removesuffix(".xacro").endswith(SDF_SUFFIXES):
        return load_sdf_world(Path(name), resource_paths, args)
    if is_map_yaml(Path(name)):
        return load_map_world(Path(name), DEFAULT_WALL_HEIGHT if wall_height is None else wall_height)
    path = named_config("worlds", name)
    return resolve_world(load_config(WorldSpec, path), path)


def resolve_world(spec: WorldSpec, path: Path) -> World:
    """A world YAML's ``spec`` (read from ``path``, which errors name) resolved into solids."""
    if not np.isfinite(np.array(_numbers(to_mapping(spec)), dtype=float)).all():
        raise ConfigError(f"{path}: sizes, poses and heights must be finite numbers (found NaN or inf)")
    solids: list[Solid] = []
    if spec.walls is not None:
        w = spec.walls
        hx, hy, t, h = w.size[0] / 2, w.size[1] / 2, w.thickness, w.height
        solids += [
            Solid("wall_east", "box", (hx + t / 2, 0.0, h / 2), 0.0, (t, 2 * hy + 2 * t, h)),
            Solid("wall_west", "box", (-hx - t / 2, 0.0, h / 2), 0.0, (t, 2 * hy + 2 * t, h)),
            Solid("wall_north", "box", (0.0, hy + t / 2, h / 2), 0.0, (2 * hx, t, h)),
            Solid("wall_south", "box", (0.0, -hy - t / 2, h / 2), 0.0, (2 * hx, t, h)),
        ]
    names = set()
    for i, obj in enumerate(spec.objects):
        where = f"{path}: objects[{i}] ({obj.name})"
        if obj.name in names:
            raise ConfigError(f"{where}: duplicate object name")
        names.add(obj.name)
        if obj.model and obj.shape:
            raise ConfigError(f"{where}: give either 'model' or 'shape', not both")
        if obj.model:
            try:
                parts = load_model(obj.model).parts
            except ConfigError as exc:
                raise ConfigError(f"{where}: {exc}") from None
        elif obj.shape == "box":
            parts = [Part("body", "box", (0.0, 0.0, obj.size[2] / 2), obj.size)]
        elif obj.shape == "cylinder":
            parts = [Part("body", "cylinder", (0.0, 0.0, obj.height / 2), radius=obj.radius, height=obj.height)]
        else:
            raise ConfigError(f"{where}: needs 'model: NAME' or 'shape: box|cylinder'")
        for part in parts:
            px, py, pz = part.pos
            x, y, yaw = se2_compose(obj.pose, (px, py, part.yaw))  # the part's pose in the world
            if part.shape == "box":
                if min(part.size) <= 0:
                    raise ConfigError(f"{where}: part {part.name} needs a positive size")
                size = part.size
            else:
                if part.radius <= 0 or part.height <= 0:
                    raise ConfigError(f"{where}: part {part.name} needs a positive radius and height")
                size = (2 * part.radius, 2 * part.radius, part.height)
            solids.append(Solid(f"{obj.name}/{part.name}", part.shape, (x, y, pz), yaw, size))
    return World(spec, solids, path)


def load_sdf_world(path: Path, resource_paths: Sequence[Path | str] = (), args: dict[str, str] | None = None) -> World:
    """An SDF world file as a World named after the file (``navlog.recorder.sdf_world``)."""
    from navlog.recorder.sdf_world import read_sdf_world, sdf_stem

    if not path.is_file():
        raise ConfigError(f"{path}: no such world file")
    sdf = read_sdf_world(path, resource_paths, args)
    seen: set[str] = set()
    for solid in sdf.solids:
        if solid.name in seen:  # sdformat refuses siblings of one name; two MuJoCo geoms cannot share one
            model, _, collision = solid.name.rpartition("/")
            raise ConfigError(
                f"{path}: two collisions named '{solid.name}' (model or link '{model}' twice, or two collisions "
                f"'{collision}' in it): give models, links and collisions names unique among their siblings"
            )
        seen.add(solid.name)
    spec = WorldSpec(sdf_stem(path), description=f"SDF world {path.name}", floor=True)
    notes = sdf.notes() + ([] if sdf.ground else ["no ground plane in the file: a floor at z = 0 added"])
    return World(spec, sdf.solids, path, notes)


def load_map_world(path: Path, wall_height: float) -> World:
    """A map_server map as a World named after the file (``navlog.recorder.map_world``)."""
    from navlog.recorder.map_world import map_solids

    solids, notes = map_solids(path, wall_height)
    return World(WorldSpec(path.stem, description=f"map_server map {path.name}", floor=True), solids, path, notes)


# ---------------------------------------------------------------- geometry queries


def clearance(world: World, xy: np.ndarray, z_min: float = 0.0, z_max: float = 2.0) -> np.ndarray:
    """Horizontal distance (m) from each point to the nearest solid overlapping heights [z_min, z_max].

    Negative inside a solid's footprint.
    """
    pts = np.atleast_2d(np.asarray(xy, dtype=np.float64))
    best = np.full(len(pts), np.inf)
    for s in world.solids:
        dist = solid_distance(s, pts, z_min, z_max)
        if dist is not None:
            best = np.minimum(best, dist)
    return best


def nearest_solid(world: World, xy: tuple[float, float], z_min: float = 0.0, z_max: float = 2.0) -> tuple[str, float]:
    """The name of the solid nearest to point ``xy`` (as ``clearance`` measures) and its distance (m);
    ("", inf) in a world without solids."""
    pts = np.array([xy], dtype=np.float64)
    best = ("", math.inf)
    for s in world.solids:
        dist = solid_distance(s, pts, z_min, z_max)
        if dist is not None and float(dist[0]) < best[1]:
            best = (s.name, float(dist[0]))
    return best


def solid_distance(s: Solid, pts: np.ndarray, z_min: float, z_max: float) -> np.ndarray | None:
    """Horizontal distance (m) from each point (n, 2) to solid ``s`` (negative inside its footprint),
    or None when ``s`` does not reach into heights [z_min, z_max]."""
    lo, hi = s.z_range
    if hi < z_min or lo > z_max:
        return None
    if s.shape == "mesh":
        from navlog.recorder.meshes import footprint_distance

        return footprint_distance(*s.triangles(), s.closed, pts, z_min, z_max)
    d = pts - np.asarray(s.center[:2])
    if s.shape == "cylinder":
        return np.hypot(d[:, 0], d[:, 1]) - s.size[0] / 2
    c, sn = math.cos(s.yaw), math.sin(s.yaw)
    local = np.stack([c * d[:, 0] + sn * d[:, 1], -sn * d[:, 0] + c * d[:, 1]], axis=1)
    q = np.abs(local) - np.asarray(s.size[:2]) / 2
    outside = np.hypot(np.maximum(q[:, 0], 0), np.maximum(q[:, 1], 0))
    inside = np.minimum(np.maximum(q[:, 0], q[:, 1]), 0)
    return outside + inside


def import_mujoco():
    """The ``mujoco`` module, imported headless unless the environment chooses a GL backend.

    Importing MuJoCo loads an OpenGL context library (GLFW: about 0.5 s of searching) for its
    renderer, which the simulator never uses; with ``MUJOCO_GL`` unset it is imported with
    ``MUJOCO_GL=disable`` (the variable is restored after). Set ``MUJOCO_GL`` (e.g. ``egl``), or
    import MuJoCo first, to render in the same process. MuJoCo's warnings go to this module's logger
    (unless a handler of MuJoCo's is already set), not to ``MUJOCO_LOG.TXT`` in the working folder.
    """
    if "mujoco" in sys.modules or "MUJOCO_GL" in os.environ:
        import mujoco
    else:
        os.environ["MUJOCO_GL"] = "disable"
        try:
            import mujoco
        finally:
            del os.environ["MUJOCO_GL"]
    if mujoco.get_mju_user_warning() is None:  # MuJoCo's warnings to the log, not to a file in the working folder
        mujoco.set_mju_user_warning(_mujoco_warning)
    return mujoco


def _mujoco_warning(text: str) -> None:
    log.warning("MuJoCo: %s", text.strip())


def import_open3d():
    """The ``open3d`` module, imported without its viewer package on first use.

    ``import open3d`` also imports ``open3d.visualization``, which pulls in Dash and Plotly (about
    1 s, half of Open3D's import) that ray casting and meshes never use. A placeholder stands in for
    that package while Open3D is imported and is removed after, so that a later
    ``import open3d.visualization`` imports the real package.
    """
    if "open3d" not in sys.modules:
        name = "open3d.visualization"
        placeholder = types.ModuleType(name)
        ours = sys.modules.setdefault(name, placeholder) is placeholder  # not another thread's, importing too
        try:
            import open3d
        finally:
            if ours and sys.modules.get(name) is placeholder:
                del sys.modules[name]
        if getattr(open3d, "visualization", None) is placeholder:
            del open3d.visualization
    # a thread that comes while another imports Open3D waits here for the whole module (the import
    # system locks a module while it runs)
    import open3d

    return open3d


def world_mesh(world: World, with_floor: bool | None = None):
    """One Open3D triangle mesh of every solid (and the floor), for ray casting and distances."""
    o3d = import_open3d()

    mesh = o3d.geometry.TriangleMesh()
    for s in world.solids:
        if s.shape == "mesh":
            v, f = s.triangles()
            mesh += o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(v), o3d.utility.Vector3iVector(f))
            continue
        if s.shape == "box":
            m = o3d.geometry.TriangleMesh.create_box(*s.size)
            m.translate(-np.asarray(s.size) / 2)
        else:
            m = o3d.geometry.TriangleMesh.create_cylinder(
                radius=s.size[0] / 2, height=s.size[2], resolution=48, split=1
            )
        rot = o3d.geometry.get_rotation_matrix_from_xyz((0.0, 0.0, s.yaw))
        m.rotate(rot, center=(0, 0, 0))
        m.translate(s.center)
        mesh += m
    floor = world.spec.floor if with_floor is None else with_floor
    if floor:
        x0, y0, x1, y1 = world.bounds()
        m = o3d.geometry.TriangleMesh.create_box(x1 - x0 + 2, y1 - y0 + 2, 0.01)
        m.translate((x0 - 1, y0 - 1, -0.01))
        mesh += m
    return mesh


def build_spec(world: World):
    """The world as a MuJoCo MjSpec: a floor plane and every solid as a static geom.

    A convex mesh is one mesh geom; MuJoCo collides a mesh by its convex hull, so a mesh that is not
    convex (a ring of walls: its hull would fill the room) is one thin convex slab per triangle
    (``navlog.recorder.meshes.triangle_prisms``), named ``SOLID#k``."""
    mujoco = import_mujoco()

    spec = mujoco.MjSpec()
    spec.modelname = world.name
    body = spec.worldbody
    if world.spec.floor:
        body.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], pos=[0, 0, 0])
    for s in world.solids:
        if s.shape == "mesh":
            _add_mesh_geoms(spec, s)
        elif s.shape == "box":
            body.add_geom(
                name=s.name,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[v / 2 for v in s.size],
                pos=list(s.center),
                euler=[0, 0, math.degrees(s.yaw)],
            )
        else:
            body.add_geom(
                name=s.name,
                type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                size=[s.size[0] / 2, s.size[2] / 2, 0],
                pos=list(s.center),
            )
    return spec


def _add_mesh_geoms(spec, s: Solid) -> None:
    from navlog.recorder.meshes import triangle_prisms

    mujoco = import_mujoco()
    v, f = s.triangles()
    pieces = [v] if s.convex else triangle_prisms(v, f)
    for k, piece in enumerate(pieces):
        name = s.name if s.convex else f"{s.name}#{k}"
        centre = (piece.min(axis=0) + piece.max(axis=0)) / 2  # vertices near the origin: a well-conditioned hull
        spec.add_mesh(name=name, uservert=(piece - centre).reshape(-1).tolist())
        spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=name, pos=centre.tolist())


MAX_GRID_CELLS = 200_000_000  # 200 M cells (a 700 m square at 5 cm): beyond it, a resolution typo


def occupancy(
    world: World,
    resolution: float = 0.05,
    margin: float = 0.0,
    z_min: float = 0.0,
    z_max: float = 2.0,
    padding: float = 0.5,
):
    """The world's obstacles as a map_server grid: a cell is occupied (100) when a solid that reaches
    into heights [z_min, z_max] comes within ``margin`` of the cell; every other cell is free (0).

    A cell counts as touched when the solid comes within half a cell of its centre, so thin panels
    (2 cm shelf sides) always occupy at least one cell.
    """
    from navlog.replay.occupancy_map import OccupancyMap

    if not 0 < resolution < math.inf:
        raise ConfigError(f"resolution must be positive, got {resolution}")
    if not all(math.isfinite(v) for v in (margin, z_min, z_max, padding)):
        raise ConfigError(f"margin, z_min, z_max must be finite numbers, got {margin}, {z_min}, {z_max}")
    if z_min > z_max:
        raise ConfigError(f"z_min ({z_min}) must not exceed z_max ({z_max})")
    if not 0.0 <= margin <= MAX_INFLATION_RADIUS_M:
        raise ConfigError(f"margin {margin} m is out of range: must be 0 to {MAX_INFLATION_RADIUS_M:g} m")
    x0, y0, x1, y1 = world.bounds()

    def cells(res: float) -> tuple[float, float, int, int]:
        ox, oy = math.floor((x0 - padding) / res) * res, math.floor((y0 - padding) / res) * res
        return ox, oy, int(math.ceil((x1 + padding - ox) / res)), int(math.ceil((y1 + padding - oy) / res))

    ox, oy, nx, ny = cells(resolution)
    if nx * ny > MAX_GRID_CELLS:
        boxes = [(s.footprint_box(), s.name) for s in world.solids]
        edges = {min(boxes, key=lambda b: b[0][i])[1] for i in (0, 1)} | {
            max(boxes, key=lambda b: b[0][i])[1] for i in (2, 3)
        }
        fits = math.sqrt((x1 - x0 + 2 * padding) * (y1 - y0 + 2 * padding) / MAX_GRID_CELLS)
        while fits <= MAX_GRID_RESOLUTION_M and math.prod(cells(fits)[2:]) > MAX_GRID_CELLS:
            fits *= 1.001  # (the cells' rounding at the edges)
        fits = math.ceil(fits / 10 ** math.floor(math.log10(fits) - 2)) * 10 ** math.floor(math.log10(fits) - 2)
        count = f"{nx:,} x {ny:,}" if nx * ny < 1e15 else f"{nx:.3g} x {ny:.3g}"
        raise ConfigError(
            f"world '{world.name}': a grid of {count} cells at {resolution:g} m is too large (over navlog's "
            f"{MAX_GRID_CELLS:,}): its obstacles span {x1 - x0:.6g} x {y1 - y0:.6g} m (x {x0:.6g} to {x1:.6g}, y "
            f"{y0:.6g} to {y1:.6g}; at the edges: {', '.join(sorted(edges))}); check those obstacles' poses and sizes"
            + (f", or choose a --resolution of {fits:.3g} m or more" if fits <= MAX_GRID_RESOLUTION_M else "")
        )
    xs = cell_to_world(np.arange(nx), ox, resolution)
    ys = cell_to_world(np.arange(ny), oy, resolution)
    reach = margin + resolution / 2  # a cell is occupied within this distance of a solid
    d = np.full((ny, nx), np.inf)
    for s in world.solids:  # each solid over the cells it can reach (its footprint grown by one more cell)
        bx0, by0, bx1, by1 = s.footprint_box()
        i0, i1 = np.searchsorted(xs, (bx0 - reach - resolution, bx1 + reach + resolution))
        j0, j1 = np.searchsorted(ys, (by0 - reach - resolution, by1 + reach + resolution))
        if i0 >= i1 or j0 >= j1:
            continue
        gx, gy = np.meshgrid(xs[i0:i1], ys[j0:j1])
        dist = solid_distance(s, np.stack([gx.ravel(), gy.ravel()], axis=1), z_min, z_max)
        if dist is not None:
            window = d[j0:j1, i0:i1]
            np.minimum(window, dist.reshape(window.shape), out=window)
    data = np.where(d <= reach, 100, 0).astype(np.int8)
    return OccupancyMap(data=data, resolution=resolution, origin=(ox, oy, 0.0))


def write_mesh(world: World, path: Path | str) -> Path:
    """Write the world's surfaces (floor included) as a triangle mesh file (.ply, .obj, .stl)."""
    o3d = import_open3d()

    path = Path(path)
    mesh = world_mesh(world)
    mesh.compute_triangle_normals()
    if not o3d.io.write_triangle_mesh(path, mesh):
        raise ConfigError(f"{path}: cannot write the mesh (use .ply, .obj or .stl)")
    return path


@dataclass(frozen=True)
class WorldMapFiles:
    """What ``write_world_map`` wrote and what the map holds."""

    world: str
    yaml_path: Path
    pgm_path: Path
    mesh_path: Path | None
    width: int
    height: int
    resolution: float
    occupied: int


def write_world_map(
    world: World | str,
    output: Path | str,
    *,
    margin: float = 0.15,
    resolution: float = 0.05,
    z_min: float = 0.0,
    z_max: float = 2.0,
    mesh: Path | str | None = None,
    force: bool = False,
) -> WorldMapFiles:
    """The map_server map (YAML + PGM beside it) of a world's obstacles, and optionally its mesh.

    ``world`` is a World or a world name / YAML path. Every output is checked before anything is
    written, so an existing file (without ``force``) leaves nothing half-done.
    """
    from navlog.replay.io.logwriter import check_output
    from navlog.replay.io.map_server import save_map

    w = load_world(world) if isinstance(world, str) else world
    output = Path(output)
    check_output(output, force)
    check_output(output.with_suffix(".pgm"), force)
    if mesh is not None:
        check_output(Path(mesh), force)
    grid = occupancy(w, resolution, margin, z_min, z_max)
    yaml_path, pgm_path = save_map(grid, output)
    mesh_path = write_mesh(w, mesh) if mesh is not None else None
    return WorldMapFiles(
        w.name, yaml_path, pgm_path, mesh_path, grid.width, grid.height, grid.resolution, int((grid.data == 100).sum())
    )
