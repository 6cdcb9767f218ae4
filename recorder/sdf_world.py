"""Gazebo SDF worlds (``.sdf``, ``.world``, ``.sdf.xacro``) as static solids.

Every model of the world (static or not: a dynamic model stays where the world places it) gives the
collision geometry of its links, posed through model -> nested model -> link -> collision as SDF
composes poses (``relative_to`` a link, frame or nested model of the same model, or the world).
Geometry: box, cylinder, sphere, capsule, ellipsoid, mesh (with ``<scale>``; one solid per connected
piece, ``navlog.recorder.meshes``), polyline (the geometry's ``<polyline>`` paths extruded from z = 0
to the first one's ``<height>``, a path inside another a hole in it, as gz-sim builds them: a closed
mesh, ``navlog.recorder.meshes.extruded_polygons``) and plane (a plane facing up is the ground: the
world's floor). Other geometry (``<heightmap>``) is counted and named in the summary.
``<include>`` of ``model://NAME`` (a folder with ``model.config``, whose highest-version ``<sdf>``
file is read) or of a path is found along the resource path (``navlog.recorder.resources``).

What a recording does not simulate is counted, not read: lights, plugins, sensors, joints, actors,
GUI, physics and scene settings (``SdfWorld.ignored``). A missing visual mesh is a warning; a
missing collision mesh, an include that cannot be found, a xacro error and a world without any
collision geometry besides the ground are ConfigErrors naming the file.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.resources import resolve_uri
from navlog.recorder.solids import Solid, mesh_solid
from navlog.recorder.xacro_files import read_description

COUNTED = ("light", "plugin", "sensor", "joint", "actor", "gui", "physics", "scene")  # ignored, named in the summary
MODEL_KEYS = ("link", "model", "include", "pose", "static", "frame", "name")
SPHERE_SUBDIVISIONS = 2  # an icosphere of 320 triangles stands for a sphere
ROUND_SECTIONS = 32  # sides of a tilted cylinder's or a capsule's mesh


@dataclass
class SdfWorld:
    """What an SDF file holds as world geometry (``Solid`` list) and what was ignored or is missing."""

    solids: list[Solid] = field(default_factory=list)
    ground: bool = False  # a plane facing up at height 0: the world's floor
    ignored: Counter[str] = field(default_factory=Counter)
    warnings: list[str] = field(default_factory=list)
    dynamic_models: int = 0  # models that are not static, fixed where the world places them

    def notes(self) -> list[str]:
        """One line each: what was ignored (counted) and the warnings, for the summary."""
        out = []
        if self.ignored:
            out.append("ignored: " + ", ".join(f"{n} {tag}" for tag, n in sorted(self.ignored.items())))
        if self.dynamic_models:
            out.append(f"{self.dynamic_models} model(s) not static, fixed where the world places them")
        return out + self.warnings


def sdf_stem(path: Path) -> str:
    """The file name without its ``.sdf``/``.world`` and ``.xacro`` suffixes (the world's name)."""
    name = path.name.removesuffix(".xacro")
    for suffix in (".sdf", ".world"):
        if name.endswith(suffix):
            return name[: -len(suffix)]
    return name


# ---------------------------------------------------------------- poses


def rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The rotation matrix of SDF's roll, pitch, yaw (about fixed x, then y, then z)."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _floats(text: str | None, n: int, where: str) -> list[float]:
    try:
        values = [float(v) for v in (text or "").split()]
    except ValueError:
        raise ConfigError(f"{where}: expected {n} numbers, got '{(text or '').strip()}'") from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{where}: expected {n} finite numbers, got '{(text or '').strip()}'")
    return values


def pose_matrix(el: ET.Element | None, where: str) -> np.ndarray:
    """The 4x4 transform of a ``<pose>`` element (identity when absent): ``x y z roll pitch yaw``, with
    ``degrees="true"`` or ``rotation_format="quat_xyzw"`` (``x y z qx qy qz qw``) as SDF 1.9 allows."""
    t = np.eye(4)
    if el is None or not (el.text or "").strip():
        return t
    if el.get("rotation_format") == "quat_xyzw":
        x, y, z, qx, qy, qz, qw = _floats(el.text, 7, where)
        n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw) or 1.0
        qx, qy, qz, qw = qx / n, qy / n, qz / n, qw / n
        t[:3, :3] = [
            [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
            [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
            [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)],
        ]
    else:
        x, y, z, roll, pitch, yaw = _floats(el.text, 6, where)
        if el.get("degrees", "false").strip().lower() in ("true", "1"):
            roll, pitch, yaw = (math.radians(v) for v in (roll, pitch, yaw))
        t[:3, :3] = rotation(roll, pitch, yaw)
    t[:3, 3] = (x, y, z)
    return t


class _Scope:
    """The frames of one model (its links, frames and nested models), for ``relative_to``."""

    def __init__(self, model: ET.Element, pose: np.ndarray, where: str) -> None:
        self.pose = pose
        self.where = where
        self.elements = {
            el.get("name", ""): el for el in model if el.tag in ("link", "frame", "model") and el.get("name")
        }
        self.cache: dict[str, np.ndarray] = {"__model__": pose}
        self.busy: set[str] = set()

    def frame(self, name: str) -> np.ndarray:
        if name in self.cache:
            return self.cache[name]
        if name == "world":
            return np.eye(4)
        el = self.elements.get(name)
        if el is None or name in self.busy:
            why = "a cycle of relative_to" if name in self.busy else "no link, frame or model of that name"
            raise ConfigError(f"{self.where}: pose relative_to '{name}': {why}")
        self.busy.add(name)
        pose_el = el.find("pose")
        parent = pose_el.get("relative_to") if pose_el is not None else None
        if not parent and el.tag == "frame":
            parent = el.get("attached_to")
        self.cache[name] = self.relative(parent) @ pose_matrix(pose_el, f"{self.where}: {el.tag} '{name}' pose")
        self.busy.discard(name)
        return self.cache[name]

    def relative(self, name: str | None) -> np.ndarray:
        return self.pose if not name or name == "__model__" else self.frame(name)


# ---------------------------------------------------------------- the walk


class _Reader:
    def __init__(self, search_paths: Sequence[Path | str]) -> None:
        self.search_paths = list(search_paths)
        self.out = SdfWorld()
        self.meshes: dict[tuple[Path, tuple[float, float, float]], tuple[np.ndarray, np.ndarray]] = {}

    def count(self, el: ET.Element) -> None:
        for child in el:
            if child.tag in COUNTED:
                self.out.ignored[child.tag] += 1

    def world(self, world: ET.Element, base: Path, file: Path) -> None:
        for el in world:
            if el.tag == "model":
                self.model(el, np.eye(4), base, file, "", False)
            elif el.tag == "include":
                self.include(el, np.eye(4), base, file, "", False)
            elif isinstance(el.tag, str) and el.tag not in ("frame",):
                self.out.ignored[el.tag] += 1

    def include(self, el: ET.Element, parent: np.ndarray, base: Path, file: Path, prefix: str, static: bool) -> None:
        uri = (el.findtext("uri") or "").strip()
        if not uri:
            raise ConfigError(f"{file}: <include> without <uri>")
        try:
            target = resolve_uri(uri, base, self.search_paths)
        except ConfigError as exc:
            raise ConfigError(f"{file}: {exc}") from None
        model_file = model_sdf_file(target) if target.is_dir() else target
        root = _parse(model_file, None, self.search_paths)
        model = root.find("model") if root.tag == "sdf" else (root if root.tag == "model" else None)
        if model is None:
            raise ConfigError(f"{model_file}: included by {file} ({uri}), but holds no <model>")
        name = (el.findtext("name") or "").strip() or model.get("name", "")
        static = static or (el.findtext("static") or "").strip().lower() in ("1", "true")
        pose_el = el.find("pose")
        if pose_el is not None:  # the include's pose replaces the model's own
            rel = pose_el.get("relative_to")
            pose = (np.eye(4) if rel == "world" else parent) @ pose_matrix(pose_el, f"{file}: include {uri} pose")
            self.model(model, pose, model_file.parent, model_file, prefix, static, name=name, posed=True)
        else:
            self.model(model, parent, model_file.parent, model_file, prefix, static, name=name)

    def model(
        self,
        el: ET.Element,
        parent: np.ndarray,
        base: Path,
        file: Path,
        prefix: str,
        static: bool,
        *,
        name: str = "",
        posed: bool = False,
    ) -> None:
        name = name or el.get("name", "model")
        path = f"{prefix}{name}"
        where = f"{file}: model '{path}'"
        pose_el = el.find("pose")
        if posed:
            pose = parent
        else:
            rel = pose_el.get("relative_to") if pose_el is not None else None
            pose = (np.eye(4) if rel == "world" else parent) @ pose_matrix(pose_el, f"{where} pose")
        static = static or (el.findtext("static") or "").strip().lower() in ("1", "true")
        scope = _Scope(el, pose, where)
        self.count(el)
        has_links = False
        for child in el:
            if child.tag == "link":
                has_links = True
                self.link(child, scope, base, file, path)
            elif child.tag == "model":
                nested = scope.frame(child.get("name", "")) if child.get("name") else pose
                self.model(child, nested, base, file, path + "/", static, posed=True)
            elif child.tag == "include":
                self.include(child, pose, base, file, path + "/", static)
        if has_links and not static:
            self.out.dynamic_models += 1

    def link(self, el: ET.Element, scope: _Scope, base: Path, file: Path, model: str) -> None:
        name = el.get("name", "link")
        link_pose = scope.frame(name)
        self.count(el)
        for vis in el.findall("visual"):
            self.visual_mesh(vis, base, file, f"{model}/{name}")
        for col in el.findall("collision"):
            cname = col.get("name", "collision")
            where = f"{file}: link '{model}/{name}' collision '{cname}'"
            pose_el = col.find("pose")
            rel = pose_el.get("relative_to") if pose_el is not None else None
            frame = link_pose if not rel else scope.relative(rel)
            pose = frame @ pose_matrix(pose_el, f"{where} pose")
            geometry = col.find("geometry")
            if geometry is None or len(geometry) == 0:
                raise ConfigError(f"{where}: no <geometry>")
            if geometry[0].tag == "polyline":  # one solid of every <polyline> of the geometry
                self.polyline(geometry.findall("polyline"), pose, f"{where} <polyline>", f"{model}/{name}/{cname}")
            else:
                self.geometry(geometry[0], pose, base, where, f"{model}/{name}/{cname}")

    def visual_mesh(self, vis: ET.Element, base: Path, file: Path, link: str) -> None:
        uri = (vis.findtext("geometry/mesh/uri") or "").strip()
        if not uri:
            return
        try:
            resolve_uri(uri, base, self.search_paths)
        except ConfigError as exc:
            self.out.warnings.append(f"warning: {file}: link '{link}' visual '{vis.get('name', '')}': {exc}")

    def geometry(self, g: ET.Element, pose: np.ndarray, base: Path, where: str, name: str) -> None:
        rot, pos = pose[:3, :3], pose[:3, 3]
        upright = abs(rot[2, 2]) > 1 - 1e-9
        yaw = math.atan2(rot[1, 0], rot[0, 0])
        what = f"{where} <{g.tag}>"
        if g.tag == "box":
            sx, sy, sz = _floats(g.findtext("size"), 3, f"{what} size")
            size = (sx, sy, sz)
            _positive(size, what)
            if upright:
                self.out.solids.append(Solid(name, "box", _xyz(pos), yaw, size))
            else:
                self.add_mesh(name, *_trimesh_primitive("box", size), pose)
        elif g.tag == "cylinder":
            r = _floats(g.findtext("radius"), 1, f"{what} radius")[0]
            h = _floats(g.findtext("length"), 1, f"{what} length")[0]
            _positive((r, h), what)
            if upright:
                self.out.solids.append(Solid(name, "cylinder", _xyz(pos), 0.0, (2 * r, 2 * r, h)))
            else:
                self.add_mesh(name, *_trimesh_primitive("cylinder", (r, h)), pose)
        elif g.tag in ("sphere", "capsule", "ellipsoid"):
            if g.tag == "sphere":
                dims: tuple[float, ...] = tuple(_floats(g.findtext("radius"), 1, f"{what} radius"))
            elif g.tag == "capsule":
                dims = (
                    _floats(g.findtext("radius"), 1, f"{what} radius")[0],
                    _floats(g.findtext("length"), 1, f"{what} length")[0],
                )
            else:
                dims = tuple(_floats(g.findtext("radii"), 3, f"{what} radii"))
            _positive(dims, what, allow_zero=g.tag == "capsule")
            self.add_mesh(name, *_trimesh_primitive(g.tag, dims), pose)
        elif g.tag == "plane":
            normal = rot @ np.asarray(_floats(g.findtext("normal") or "0 0 1", 3, f"{what} normal"))
            if normal[2] > 1 - 1e-6 and abs(pos[2]) < 1e-6:
                self.out.ground = True
            else:
                self.out.ignored["plane (not the ground)"] += 1
        elif g.tag == "mesh":
            uri = (g.findtext("uri") or "").strip()
            sx, sy, sz = _floats(g.findtext("scale") or "1 1 1", 3, f"{what} scale")
            scale = (sx, sy, sz)
            if not all(v != 0 and math.isfinite(v) for v in scale):  # (0 flattened it away without a word)
                raise ConfigError(f"{what} scale: each factor must be non-zero and finite, got {sx:g} {sy:g} {sz:g}")
            try:
                path = resolve_uri(uri, base, self.search_paths)
            except ConfigError as exc:
                raise ConfigError(f"{where}: collision mesh missing: {exc}") from None
            if g.find("submesh") is not None:
                self.out.ignored["submesh (whole mesh used)"] += 1
            key = (path.resolve(), scale)
            if key not in self.meshes:
                from navlog.recorder.meshes import read_mesh_file

                self.meshes[key] = read_mesh_file(path, scale)
            self.add_mesh(name, *self.meshes[key], pose)
        else:
            self.out.ignored[f"<{g.tag}> geometry"] += 1

    def polyline(self, lines: list[ET.Element], pose: np.ndarray, what: str, name: str) -> None:
        """``<polyline>`` (SDF 1.6+): the paths of the geometry's ``<polyline>`` elements extruded from its
        frame's z = 0 to the first one's ``<height>``, a path inside another a hole, as gz-sim builds it."""
        from navlog.recorder.meshes import extruded_polygons

        paths = []
        for k, line in enumerate(lines):
            points = [_floats(p.text, 2, f"{what} {k + 1} <point>") for p in line.findall("point")]
            if len(points) < 3:
                raise ConfigError(
                    f"{what}: a polyline needs at least 3 <point> elements, got {len(points)}; add points"
                )
            paths.append(np.asarray(points))
        height = _floats(lines[0].findtext("height") or "1", 1, f"{what} height")[0]
        _positive((height,), what)
        vertices, faces = extruded_polygons(paths, height)
        self.add_mesh(name, vertices, faces, pose)

    def add_mesh(self, name: str, vertices: np.ndarray, faces: np.ndarray, pose: np.ndarray) -> None:
        from navlog.recorder.meshes import split_components

        world_vertices = vertices @ pose[:3, :3].T + pose[:3, 3]
        pieces = split_components(world_vertices, faces)
        for k, (v, f) in enumerate(pieces):
            self.out.solids.append(mesh_solid(name if len(pieces) == 1 else f"{name}#{k}", v, f))


def _positive(values: Sequence[float], what: str, allow_zero: bool = False) -> None:
    if any(v < 0 or (v == 0 and not allow_zero) for v in values):
        raise ConfigError(f"{what}: sizes must be positive, got {' '.join(f'{v:g}' for v in values)}")


def _trimesh_primitive(kind: str, dims: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The triangles of an SDF primitive in its own frame (centred, axis along z)."""
    import trimesh

    if kind == "box":
        m = trimesh.creation.box(extents=dims)
    elif kind == "cylinder":
        m = trimesh.creation.cylinder(radius=dims[0], height=dims[1], sections=ROUND_SECTIONS)
    elif kind == "capsule":
        m = trimesh.creation.capsule(height=dims[1], radius=dims[0], count=[ROUND_SECTIONS, ROUND_SECTIONS])
    else:
        m = trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=1.0)
        m.vertices = m.vertices * (np.asarray(dims) if kind == "ellipsoid" else dims[0])
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64)


def _parse(path: Path, args: Mapping[str, str] | None = None, search_paths: Sequence[Path | str] = ()) -> ET.Element:
    text = read_description(path, args, search_paths)
    try:
        return ET.fromstring(text)
    except ET.ParseError as exc:
        raise ConfigError(f"{path}: not valid XML ({exc})") from None


def model_sdf_file(folder: Path) -> Path:
    """The SDF file of a model folder: the ``<sdf>`` of highest version its ``model.config`` names."""
    config = folder / "model.config"
    try:
        root = ET.parse(config).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ConfigError(f"{config}: cannot read the model's config ({exc})") from None

    def version(el: ET.Element) -> tuple[int, ...]:
        try:
            return tuple(int(v) for v in el.get("version", "0").split("."))
        except ValueError:
            return (0,)

    files = sorted(root.findall("sdf"), key=version)
    if not files or not (files[-1].text or "").strip():
        raise ConfigError(f"{config}: names no <sdf> file")
    path = folder / (files[-1].text or "").strip()
    if not path.is_file():
        raise ConfigError(f"{config}: names {path.name}, which is not in {folder}")
    return path


def read_sdf_world(
    path: Path, search_paths: Sequence[Path | str] = (), args: Mapping[str, str] | None = None
) -> SdfWorld:
    """The solids of the SDF world file ``path`` (module docstring); ConfigError when it has none."""
    root = _parse(path, args, search_paths)
    reader = _Reader(search_paths)
    if root.tag != "sdf":
        raise ConfigError(f"{path}: not an SDF file (its root element is <{root.tag}>, not <sdf>)")
    worlds = root.findall("world")
    if worlds:
        for world in worlds[:1]:
            reader.world(world, path.parent, path)
    else:  # a model file: the model alone is the world
        for model in root.findall("model"):
            reader.model(model, np.eye(4), path.parent, path, "", True)
    if not reader.out.solids:
        raise ConfigError(
            f"{path}: no collision geometry besides the ground plane: nothing for the robot to meet "
            "(a world needs models with <collision> elements)"
        )
    return reader.out


def _xyz(v: np.ndarray) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])
