"""Robots from description files: URDF, SDF and their xacro sources, as navlog's ``RobotSpec``.

``describe(path, ...)`` reads a ``.urdf``, ``.sdf``, ``.urdf.xacro`` or ``.sdf.xacro`` file (xacro is
expanded by the ``xacro`` package, with ``args`` as ``ros2 launch`` passes them and ``$(find PKG)``
along the package path of ``navlog.recorder.resources``) and returns the robot:

- the kinematic tree (``RobotModel``): links, joints, collision geometry (primitives; meshes with their
  scale, checked to exist: a missing collision mesh is an error naming the file and the link, a missing
  visual mesh a warning), masses and inertias. The simulator builds its bodies from them
  (``navlog.recorder.robot_bodies``).
- the drive, from the Gazebo plugin the file declares (``DRIVE_PLUGINS``): gz-sim ``DiffDrive``, classic
  ``libgazebo_ros_diff_drive.so`` (ROS 1 and ROS 2 spellings), the planar move plugins (an omni base):
  wheel joints, separation and radius, velocity and acceleration limits, command and odometry topics,
  odom and base frames, odometry rate. A file without one takes ``drive`` (``diff_drive``: the two
  wheels are the revolute joints whose links carry a cylinder, left the one at positive y, their
  separation and radius measured from the geometry; ``omni``); without either it is an error naming
  the plugins understood.
- the sensors of its ``<sensor>`` tags: the first one-row ``gpu_lidar``/``ray``/``gpu_ray``/``lidar``
  becomes the 2D laser (``LaserConfig``: samples, angles with Gazebo's increment
  ``(max - min) / (samples - 1)``, range, gaussian noise, rate, topic, frame), the first with several
  vertical samples the 3D LiDAR (``LidarConfig``, a Velodyne pattern over the vertical angles), the first
  ``imu`` the IMU (``ImuConfig``, the gaussian noise of its x axes); every other sensor is named in
  ``RobotModel.other_sensors``. A sensor with zero samples is an error.
- frames: the link names. ``/tf_static`` holds every joint but the wheels' (joints navlog does not move,
  such as casters' ball joints, at their rest pose), ``/joint_states`` and ``/tf`` the wheels'. A sensor
  whose frame is its own link but which sits at a pose within the link (as gz_waffle's lidar) is cast
  from that pose and its frame published there, so that its data and ``/tf`` agree (Gazebo casts from
  the sensor's pose while robot_state_publisher puts the frame at the link's). A sensor frame that is
  no link is published as a child of its link.

The odometry is published on the plugin's topic (``odom_topic``, ``<odometry_topic>``) in its frame
(``frame_id``, ``<odometry_frame>``). It carries the root link, ``odom -> ROOT`` on ``/tf``, unless the
plugin's ``child_frame_id``/``<robot_base_frame>`` names a frame that is no link (gz_waffle's
``base_footprint`` over a root ``base_link``): then ``odom -> CHILD`` (planar) and ``CHILD -> ROOT``
(height and tilt) as navlog's own robots publish ``base_footprint``. The
odometry is noiseless (as Gazebo's plugins compute it from the wheel joints) unless the robot YAML
adds noise. Topics without a leading ``/`` are made absolute.
"""

from __future__ import annotations

import logging
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.resources import resolve_uri
from navlog.recorder.robot import (
    BodyConfig,
    DriveConfig,
    FramesConfig,
    GaitConfig,
    ImuConfig,
    LaserConfig,
    LidarConfig,
    OdomConfig,
    RobotSpec,
)
from navlog.recorder.robot_model import (
    IDENTITY,
    Collision,
    Geometry,
    Inertial,
    Link,
    Pose,
    RobotModel,
    StaticFrame,
    pose_matrix,
)
from navlog.recorder.xacro_files import read_description
from navlog.replay.config import from_mapping, load_config, load_yaml, named_config, suggest, to_mapping
from navlog.replay.geometry import make_transform, matrix_to_quat, quat_from_rpy, rigid_inverse

log = logging.getLogger("navlog")

SUFFIXES = (".urdf", ".sdf", ".urdf.xacro", ".sdf.xacro", ".xacro")
DRIVE_PLUGINS = {
    "gz-sim-diff-drive-system (gz::sim::systems::DiffDrive)": "diff_drive",
    "libgazebo_ros_diff_drive.so": "diff_drive",
    "libgazebo_ros_planar_move.so": "omni",
    "gz-sim-velocity-control-system (gz::sim::systems::VelocityControl)": "omni",
}
DRIVES = ("diff_drive", "omni")
LIDAR_TYPES = ("gpu_lidar", "ray", "gpu_ray", "lidar")
DESCRIBED_TIMESTEP = 0.0025  # physics step of a described robot (s): small wheels need it
NO_LIMIT = math.inf  # a velocity or acceleration the plugin does not bound


def is_description(name: str) -> bool:
    """Whether ``name`` is a description file's name (by its suffix)."""
    return name.lower().endswith(SUFFIXES)


# ---------------------------------------------------------------- poses and numbers


def _floats(text: str | None, n: int, where: str, default: Sequence[float] | None = None) -> list[float]:
    if text is None or not text.strip():
        if default is None:
            raise ConfigError(f"{where}: missing value")
        return list(default)
    try:
        out = [float(v) for v in text.split()]
    except ValueError:
        raise ConfigError(f"{where}: expected {n} numbers, got '{text.strip()}'") from None
    if len(out) != n or not all(math.isfinite(v) for v in out):
        raise ConfigError(f"{where}: expected {n} finite numbers, got '{text.strip()}'")
    return out


def _matrix(xyz: Sequence[float], rpy: Sequence[float]) -> np.ndarray:
    return make_transform(xyz, quat_from_rpy(*rpy))


def _pose(t: np.ndarray) -> Pose:
    qx, qy, qz, qw = matrix_to_quat(t[:3, :3])
    x, y, z = (float(v) for v in t[:3, 3])
    return (x, y, z, float(qx), float(qy), float(qz), float(qw))


def mount_of(t: np.ndarray) -> tuple[float, float, float, float, float, float]:
    """(x, y, z, roll, pitch, yaw) of a transform, as navlog's sensor mounts give it."""
    from scipy.spatial.transform import Rotation

    roll, pitch, yaw = Rotation.from_matrix(t[:3, :3]).as_euler("xyz")
    x, y, z = (float(v) for v in t[:3, 3])
    return (x, y, z, float(roll), float(pitch), float(yaw))


def _text(el: ET.Element | None, tag: str, default: str | None = None) -> str | None:
    if el is None:
        return default
    child = el.find(tag)
    return child.text.strip() if child is not None and child.text is not None else default


INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")


def _inertial(mass: float, pose: Pose, inertia: tuple[float, ...], where: str) -> Inertial:
    """A link's inertial, checked: a mass of zero or more, a positive semi-definite inertia."""
    if mass < 0:
        raise ConfigError(f"{where}: <mass> must be zero or more, got {mass:g}")
    out = Inertial(mass, pose, inertia)  # type: ignore[arg-type]
    smallest = float(out.principal_moments()[0])
    if mass > 0 and smallest < -1e-9 * max(abs(v) for v in inertia):
        values = " ".join(f'{k}="{v:g}"' for k, v in zip(INERTIA_KEYS, inertia, strict=True))
        raise ConfigError(
            f"{where}: <inertia {values}> is no rigid body's (a principal moment of {smallest:.3g}); "
            "give the link's inertia about its centre of mass, ixx iyy izz positive"
        )
    return out


def _number(el: ET.Element | None, tags: Sequence[str], where: str, default: float | None = None) -> float | None:
    """The first of ``tags`` under ``el`` as a number."""
    for tag in tags:
        value = _text(el, tag)
        if value is not None:
            try:
                out = float(value)
            except ValueError:
                raise ConfigError(f"{where}: <{tag}> must be a number, got '{value}'") from None
            if not math.isfinite(out):
                raise ConfigError(f"{where}: <{tag}> must be finite, got '{value}'")
            return out
    return default


def _topic(name: str) -> str:
    name = re.sub("/+", "/", name.strip())
    return name if name.startswith("/") else "/" + name


# ---------------------------------------------------------------- the parsed file


@dataclass
class _Sensor:
    element: ET.Element
    link: str
    pose: np.ndarray  # in the link's frame


@dataclass
class _Parsed:
    """What both formats give: the tree, the sensors and the plugins of a file."""

    name: str
    links: dict[str, Link]
    sensors: list[_Sensor] = field(default_factory=list)
    plugins: list[ET.Element] = field(default_factory=list)


class _Reader:
    def __init__(self, path: Path, search: Sequence[Path | str]) -> None:
        self.path = path
        self.search = search

    def mesh(self, uri: str, link: str, visual: bool) -> str | None:
        """The file of a mesh URI; a missing visual mesh is a warning (None), a missing collision one an error."""
        try:
            found = resolve_uri(uri, self.path.parent, self.search)
        except ConfigError as exc:
            if visual:
                log.warning("%s: link '%s': visual mesh %s: %s", self.path, link, uri, exc)
                return None
            raise ConfigError(f"{self.path}: link '{link}': collision mesh {uri}: {exc}") from None
        if not found.is_file():
            what = "is not a regular file" if found.exists() else "is missing"  # a FIFO, a device, a folder
            if visual:
                log.warning("%s: link '%s': visual mesh %s %s (%s)", self.path, link, uri, what, found)
                return None
            raise ConfigError(f"{self.path}: link '{link}': collision mesh {uri} {what} ({found})")
        return str(found)

    def geometry(self, g: ET.Element | None, link: str, where: str, urdf: bool) -> Geometry | None:
        """A collision's geometry (None for a kind navlog does not simulate, e.g. a plane, with a warning)."""
        if g is None or len(g) == 0:
            raise ConfigError(f"{where}: <geometry> is empty")
        shape = g[0]
        kind = shape.tag
        if urdf:
            a = shape.attrib
            if kind == "box":
                return Geometry("box", size=tuple(_floats(a.get("size"), 3, f"{where} box size")))  # type: ignore[arg-type]
            if kind in ("cylinder", "capsule"):
                r = _floats(a.get("radius"), 1, f"{where} {kind} radius", (math.nan,))[0]
                length = _floats(a.get("length"), 1, f"{where} {kind} length", (math.nan,))[0]
                return Geometry(kind, radius=r, length=length)  # type: ignore[arg-type]
            if kind == "sphere":
                return Geometry("sphere", radius=_floats(a.get("radius"), 1, f"{where} sphere radius", (math.nan,))[0])
            if kind == "mesh":
                uri, scale = a.get("filename", ""), a.get("scale")
                file = self.mesh(uri, link, visual=False)
                return Geometry("mesh", mesh=file or "", scale=tuple(_floats(scale, 3, f"{where} scale", (1, 1, 1))))  # type: ignore[arg-type]
        else:
            if kind == "box":
                return Geometry("box", size=tuple(_floats(_text(shape, "size"), 3, f"{where} box size")))  # type: ignore[arg-type]
            if kind in ("cylinder", "capsule"):
                radius = _number(shape, ["radius"], where, math.nan)
                height = _number(shape, ["length"], where, math.nan)
                return Geometry(kind, radius=float(radius or 0), length=float(height or 0))  # type: ignore[arg-type]
            if kind == "sphere":
                return Geometry("sphere", radius=float(_number(shape, ["radius"], where, math.nan) or 0))
            if kind == "mesh":
                uri = _text(shape, "uri", "") or ""
                file = self.mesh(uri, link, visual=False)
                scales = _floats(_text(shape, "scale"), 3, f"{where} scale", (1, 1, 1))
                return Geometry("mesh", mesh=file or "", scale=tuple(scales))  # type: ignore[arg-type]
        log.warning("%s: %s geometry is not simulated", where, kind)
        return None

    def visual_meshes(self, link_el: ET.Element, link: str, urdf: bool) -> None:
        """Warn about the visual meshes of a link that are missing."""
        for visual in link_el.iter("visual"):
            for mesh in visual.iter("mesh"):
                uri = mesh.get("filename") if urdf else _text(mesh, "uri")
                if uri:
                    self.mesh(uri, link, visual=True)


def _check_geometry(g: Geometry, where: str) -> None:
    values = {"box": g.size, "cylinder": (g.radius, g.length), "capsule": (g.radius, g.length)}
    values.update(sphere=(g.radius,), mesh=g.scale)
    if not all(math.isfinite(v) and v > 0 for v in values[g.shape]):
        raise ConfigError(f"{where}: {g.shape} needs positive sizes")


def _parse_urdf(root: ET.Element, reader: _Reader) -> _Parsed:
    src = reader.path
    joints: dict[str, tuple[ET.Element, str]] = {}  # child link -> (joint, parent link)
    for j in root.findall("joint"):
        parent_el, child_el = j.find("parent"), j.find("child")
        if parent_el is None or child_el is None:
            raise ConfigError(f"{src}: joint '{j.get('name')}' needs <parent link=...> and <child link=...>")
        joints[child_el.get("link", "")] = (j, parent_el.get("link", ""))
    elements = {el.get("name", ""): el for el in root.findall("link")}
    for child, (j, _) in joints.items():
        if child not in elements:
            raise ConfigError(
                f"{src}: joint '{j.get('name')}': child link '{child}' is not in the file{suggest(child, elements)}"
            )
    links: dict[str, Link] = {}
    for name, el in elements.items():
        where = f"{src}: link '{name}'"
        collisions = []
        for i, c in enumerate(el.findall("collision")):
            cw = f"{where} collision {c.get('name') or i}"
            o = c.find("origin")
            pose = _matrix(
                _floats(o.get("xyz") if o is not None else None, 3, cw, (0, 0, 0)),
                _floats(o.get("rpy") if o is not None else None, 3, cw, (0, 0, 0)),
            )
            g = reader.geometry(c.find("geometry"), name, cw, urdf=True)
            if g is not None:
                _check_geometry(g, cw)
                collisions.append(Collision(c.get("name") or f"{name}_collision_{i}", _pose(pose), g))
        reader.visual_meshes(el, name, urdf=True)
        inertial = None
        ie = el.find("inertial")
        if ie is not None:
            o = ie.find("origin")
            pose = _matrix(
                _floats(o.get("xyz") if o is not None else None, 3, where, (0, 0, 0)),
                _floats(o.get("rpy") if o is not None else None, 3, where, (0, 0, 0)),
            )
            mass_el = ie.find("mass")
            i_el = ie.find("inertia")
            ia = i_el.attrib if i_el is not None else {}
            inertia = tuple(_floats(ia.get(k), 1, f"{where}: <inertia {k}>", (0.0,))[0] for k in INERTIA_KEYS)
            mass = _floats(mass_el.get("value") if mass_el is not None else None, 1, f"{where}: <mass>", (0.0,))[0]
            inertial = _inertial(mass, _pose(pose), inertia, where)
        link = Link(name, inertial=inertial, collisions=collisions)
        if name in joints:
            j, parent = joints[name]
            o = j.find("origin")
            pose = _matrix(
                _floats(o.get("xyz") if o is not None else None, 3, where, (0, 0, 0)),
                _floats(o.get("rpy") if o is not None else None, 3, where, (0, 0, 0)),
            )
            axis_el = j.find("axis")
            axis = _floats(axis_el.get("xyz") if axis_el is not None else None, 3, where, (1, 0, 0))
            link = Link(
                name,
                _pose(pose),
                parent,
                j.get("name", ""),
                j.get("type", "fixed"),
                (0.0, 0.0, 0.0),
                tuple(axis),  # type: ignore[arg-type]
                inertial,
                collisions,
            )
        links[name] = link
    parsed = _Parsed(root.get("name", src.stem), links)
    for gz in root.findall("gazebo"):
        ref = gz.get("reference")
        for s in gz.findall("sensor"):
            owner = ref or ""
            if owner not in links:
                raise ConfigError(f"{src}: sensor '{s.get('name')}' refers to link '{owner}', which is not in the file")
            pose = _sdf_pose(s, f"{src}: sensor '{s.get('name')}'")
            parsed.sensors.append(_Sensor(s, owner, pose))
        parsed.plugins += gz.findall("plugin")
    return parsed


def _sdf_pose(el: ET.Element, where: str) -> np.ndarray:
    values = _floats(_text(el, "pose"), 6, f"{where} <pose>", (0, 0, 0, 0, 0, 0))
    return _matrix(values[:3], values[3:])


@dataclass
class _Flat:
    """A robot model's links and joints with nested models and includes flattened: names scoped as gz-sim
    scopes them within the top model (``inner::link``, ``outer::inner::link``), poses in the top model's
    frame."""

    links: dict[str, ET.Element] = field(default_factory=dict)
    poses: dict[str, np.ndarray] = field(default_factory=dict)  # link -> pose in the top model's frame
    frames: dict[str, np.ndarray] = field(default_factory=dict)  # link -> its own model's frame in the top's
    files: dict[str, Path] = field(default_factory=dict)  # link -> the file that declares it
    # (joint, parent, child, file, the frame of the model that declares the joint, in the top model's)
    joints: list[tuple[ET.Element, str, str, Path, np.ndarray]] = field(default_factory=list)
    plugins: list[ET.Element] = field(default_factory=list)


def _flatten(
    model: ET.Element, frame: np.ndarray, prefix: str, file: Path, reader: _Reader, out: _Flat, within: tuple = ()
) -> None:
    """Add ``model``'s links and joints (scoped by ``prefix``), then its nested models' and includes'
    (``within``: the files being included, outermost first; a file that includes itself is an error)."""
    from navlog.recorder.sdf_world import model_sdf_file

    own = {el.get("name", ""): el for el in model.findall("link")}
    for name, el in own.items():
        pose_el = el.find("pose")
        rel = pose_el.get("relative_to", "") if pose_el is not None else ""
        pose = _sdf_pose(el, f"{file}: link '{prefix}{name}'")
        if rel and rel != "__model__":
            if rel not in own:
                raise ConfigError(f"{file}: link '{prefix}{name}': pose relative_to '{rel}', not a link of the model")
            pose = _sdf_pose(own[rel], f"{file}: link '{prefix}{rel}'") @ pose
        scoped = prefix + name
        out.links[scoped], out.poses[scoped], out.frames[scoped], out.files[scoped] = el, frame @ pose, frame, file
    for j in model.findall("joint"):
        parent, child = _text(j, "parent", "") or "", _text(j, "child", "") or ""
        scoped_parent = parent if parent == "world" else prefix + parent
        out.joints.append((j, scoped_parent, prefix + child, file, frame))
    out.plugins += model.findall("plugin")
    for nested in model.findall("model"):
        name = nested.get("name", "")
        where = f"{file}: model '{prefix}{name}'"
        _flatten(nested, frame @ _sdf_pose(nested, where), f"{prefix}{name}::", file, reader, out, within)
    for inc in model.findall("include"):
        uri = _text(inc, "uri", "") or ""
        try:
            target = resolve_uri(uri, file.parent, reader.search)
        except ConfigError as exc:
            raise ConfigError(f"{file}: <include> {uri}: {exc}") from None
        inc_file = model_sdf_file(target) if target.is_dir() else target
        chain = (*within, file)
        if inc_file.resolve() in {f.resolve() for f in chain}:
            names = " -> ".join(str(f) for f in (*chain, inc_file))
            raise ConfigError(f"{file}: <include> {uri}: includes itself ({names}); remove the include")
        text = read_description(inc_file, None, reader.search)
        try:
            inc_root = ET.fromstring(text)
        except ET.ParseError as exc:
            raise ConfigError(f"{inc_file}:{exc.position[0]}: not well-formed XML: {exc}") from None
        inc_model = inc_root.find("model") if inc_root.tag == "sdf" else inc_root
        if inc_model is None or inc_model.tag != "model":
            raise ConfigError(f"{inc_file}: included by {file} ({uri}) but holds no <model>")
        name = _text(inc, "name") or inc_model.get("name") or ""
        where = f"{file}: include {uri}"
        pose = _sdf_pose(inc if inc.find("pose") is not None else inc_model, where)  # the include's replaces
        _flatten(inc_model, frame @ pose, f"{prefix}{name}::", inc_file, reader, out, chain)


def _parse_sdf(root: ET.Element, reader: _Reader) -> _Parsed:
    """An SDF robot: the top model's links and joints, and those of its nested models and ``<include>``d
    models (``model://NAME`` along the resource path, or a file), named and posed as gz-sim scopes them:
    a joint of the top model joins ``base_link`` to ``lidar::link`` of an include named ``lidar``."""
    src = reader.path
    model = root.find("model") if root.tag == "sdf" else root
    if model is None:
        raise ConfigError(f"{src}: no <model> in the SDF file")
    flat = _Flat()
    _flatten(model, np.eye(4), "", src, reader, flat)
    elements, in_model = flat.links, flat.poses
    joints: dict[str, tuple[ET.Element, str, np.ndarray]] = {}
    for j, parent, child, file, model_frame in flat.joints:
        if child not in elements or (parent not in elements and parent != "world"):
            raise ConfigError(
                f"{file}: joint '{j.get('name')}' joins '{parent}' to '{child}': not links of the model "
                "(a nested model's link is named MODEL::LINK)"
            )
        joints[child] = (j, parent, model_frame)
    links: dict[str, Link] = {}
    sensors: list[_Sensor] = []
    for name, el in elements.items():
        file = flat.files[name]
        where = f"{file}: link '{name}'"
        sensors += [_Sensor(s, name, _sdf_pose(s, f"{file}: sensor '{s.get('name')}'")) for s in el.findall("sensor")]
        collisions = []
        for i, c in enumerate(el.findall("collision")):
            cw = f"{where} collision {c.get('name') or i}"
            g = reader.geometry(c.find("geometry"), name, cw, urdf=False)
            if g is not None:
                _check_geometry(g, cw)
                collisions.append(Collision(c.get("name") or f"{name}_collision_{i}", _pose(_sdf_pose(c, cw)), g))
        reader.visual_meshes(el, name, urdf=False)
        inertial = None
        ie = el.find("inertial")
        if ie is not None:
            i_el = ie.find("inertia")
            inertia = tuple(float(_number(i_el, [k], where, 0.0) or 0.0) for k in INERTIA_KEYS)
            mass = float(_number(ie, ["mass"], where, 0.0) or 0.0)
            inertial = _inertial(mass, _pose(_sdf_pose(ie, where)), inertia, where)
        link = Link(name, _pose(in_model[name]), inertial=inertial, collisions=collisions)
        if name in joints and joints[name][1] in elements:
            j, parent, model_frame = joints[name]
            child_in_parent = rigid_inverse(in_model[parent]) @ in_model[name]
            joint_pose = _sdf_pose(j, f"{file}: joint '{j.get('name')}'")  # in the child link's frame
            axis_el = j.find("axis")
            axis = np.array(_floats(_text(axis_el, "xyz"), 3, f"{file}: joint '{j.get('name')}' axis", (0, 0, 1)))
            xyz_el = axis_el.find("xyz") if axis_el is not None else None
            expressed = xyz_el.get("expressed_in", "") if xyz_el is not None else ""
            if _text(axis_el, "use_parent_model_frame", "false") in ("true", "1") or expressed == "__model__":
                axis = in_model[name][:3, :3].T @ model_frame[:3, :3] @ axis  # the frame of the joint's model
            elif not expressed:
                axis = joint_pose[:3, :3] @ axis  # the joint's frame
            link = Link(
                name,
                _pose(child_in_parent),
                parent,
                j.get("name", ""),
                j.get("type", "fixed"),
                tuple(float(v) for v in joint_pose[:3, 3]),  # type: ignore[arg-type]
                tuple(float(v) for v in axis),  # type: ignore[arg-type]
                inertial,
                collisions,
            )
        links[name] = link
    return _Parsed(model.get("name", src.stem), links, sensors, flat.plugins)


# ---------------------------------------------------------------- the tree


def _ordered(parsed: _Parsed, src: Path) -> list[Link]:
    """The links parents first, the root's pose the identity; ConfigError for a forest or a cycle."""
    links = parsed.links
    if not links:
        raise ConfigError(f"{src}: the file has no link")
    roots = [n for n, link in links.items() if not link.parent]
    if len(roots) != 1:
        raise ConfigError(f"{src}: a robot needs exactly one root link (one not a joint's child), found {roots}")
    children: dict[str, list[str]] = {}
    for name, link in links.items():
        if link.parent:
            if link.parent not in links:
                raise ConfigError(f"{src}: joint '{link.joint}': parent link '{link.parent}' is not in the file")
            children.setdefault(link.parent, []).append(name)
    root = links[roots[0]]
    out = [Link(root.name, IDENTITY, inertial=root.inertial, collisions=root.collisions)]
    todo = list(children.get(root.name, []))
    while todo:
        name = todo.pop(0)
        out.append(links[name])
        todo += children.get(name, [])
    if len(out) != len(links):
        missing = sorted(set(links) - {link.name for link in out})
        raise ConfigError(f"{src}: links {missing} are not connected to the root '{root.name}' (a joint cycle?)")
    return out


def _in_root(links: Sequence[Link]) -> dict[str, np.ndarray]:
    """Every link's pose in the root's frame."""
    out: dict[str, np.ndarray] = {}
    for link in links:
        local = pose_matrix(link.pose)
        out[link.name] = out[link.parent] @ local if link.parent else local
    return out


def _lowest_point(links: Sequence[Link], in_root: Mapping[str, np.ndarray]) -> float:
    """The lowest z of the collision geometry in the root's frame."""
    from navlog.recorder.robot_bodies import mesh_vertices

    low = math.inf
    for link in links:
        for c in link.collisions:
            t = in_root[link.name] @ pose_matrix(c.pose)
            g, rz, z = c.geometry, t[2, :3], float(t[2, 3])
            if g.shape == "mesh":
                v = mesh_vertices(g.mesh, link.name) * np.asarray(g.scale)
                low = min(low, float((v @ rz).min()) + z)
            elif g.shape == "box":
                low = min(low, z - float(np.abs(rz) @ np.asarray(g.size)) / 2)
            elif g.shape == "sphere":
                low = min(low, z - g.radius)
            else:  # cylinder, capsule: axis along the geometry's z
                along = abs(float(rz[2])) * g.length / 2
                across = math.sqrt(max(0.0, 1.0 - float(rz[2]) ** 2)) * g.radius
                low = min(low, z - along - across - (g.radius * abs(float(rz[2])) if g.shape == "capsule" else 0.0))
    return low if math.isfinite(low) else 0.0


def _footprint(links: Sequence[Link], in_root: Mapping[str, np.ndarray]) -> tuple[tuple[float, float, float], float]:
    """The box around the collision geometry (full sizes) and the largest horizontal distance of it from the
    root, from the corners of each geometry's bounding box."""
    from navlog.recorder.robot_bodies import mesh_vertices

    points = []
    for link in links:
        for c in link.collisions:
            t = in_root[link.name] @ pose_matrix(c.pose)
            g = c.geometry
            if g.shape == "mesh":
                v = mesh_vertices(g.mesh, link.name) * np.asarray(g.scale)
                lo, hi = v.min(axis=0), v.max(axis=0)
            else:
                half = np.asarray(g.size) / 2 if g.shape == "box" else np.array([g.radius, g.radius, g.length / 2])
                if g.shape == "sphere":
                    half = np.full(3, g.radius)
                lo, hi = -half, half
            corners = np.array([[a, b, c_] for a in (lo[0], hi[0]) for b in (lo[1], hi[1]) for c_ in (lo[2], hi[2])])
            points.append(corners @ t[:3, :3].T + t[:3, 3])
    if not points:
        return (0.1, 0.1, 0.1), 0.1
    p = np.concatenate(points)
    size = tuple(float(v) for v in p.max(axis=0) - p.min(axis=0))
    return size, float(np.hypot(p[:, 0], p[:, 1]).max())  # type: ignore[return-value]


# ---------------------------------------------------------------- plugins: the drive


def _plugin_kind(plugin: ET.Element) -> str | None:
    text = f"{plugin.get('filename', '')} {plugin.get('name', '')}".lower()
    if "diff-drive-system" in text or "diffdrive" in text.replace("_", "") or "gazebo_ros_diff_drive" in text:
        return "diff_drive"
    if "planar_move" in text or "velocity-control-system" in text or "velocitycontrol" in text:
        return "omni"
    return None


def _joint_state_plugin(plugins: Sequence[ET.Element]) -> ET.Element | None:
    for p in plugins:
        text = f"{p.get('filename', '')} {p.get('name', '')}".lower()
        if "joint-state-publisher" in text or "joint_state_publisher" in text or "jointstatepublisher" in text:
            return p
    return None


def _ros_remap(plugin: ET.Element, name: str) -> str | None:
    """A ROS 2 gazebo_ros plugin's ``<ros><remapping>NAME:=TOPIC</remapping>``."""
    for r in plugin.iter("remapping"):
        text = (r.text or "").strip()
        for prefix in (f"{name}:=", f"~/{name}:=", f"/{name}:="):
            if text.startswith(prefix):
                return text[len(prefix) :]
    return None


@dataclass
class _Drive:
    kind: str  # diff_drive | omni
    plugin: str = ""
    wheels: tuple[str, str] | None = None
    separation: float | None = None
    radius: float | None = None
    limits: tuple[float, float, float, float, float] = (NO_LIMIT, -NO_LIMIT, NO_LIMIT, NO_LIMIT, NO_LIMIT)
    cmd_topic: str = "/cmd_vel"
    odom_topic: str = "/odom"
    odom_frame: str = "odom"
    base_frame: str = ""
    odom_rate: float = 50.0


def _plugin_drive(p: ET.Element, kind: str, src: Path) -> _Drive:
    where = f"{src}: plugin {p.get('filename')}"

    def num(*tags: str) -> float | None:
        return _number(p, tags, where)

    def txt(*tags: str) -> str | None:
        for tag in tags:
            value = _text(p, tag)
            if value:
                return value
        return None

    d = _Drive(kind, plugin=p.get("filename", "") or p.get("name", ""))
    left, right = txt("left_joint", "leftJoint"), txt("right_joint", "rightJoint")
    if kind == "diff_drive":
        if not left or not right:
            raise ConfigError(f"{where}: needs <left_joint> and <right_joint>")
        d.wheels = (left, right)
        d.separation = num("wheel_separation", "wheelSeparation")
        radius = num("wheel_radius")
        diameter = num("wheel_diameter", "wheelDiameter")
        d.radius = radius if radius is not None else (diameter / 2 if diameter is not None else None)
    max_v, min_v = num("max_linear_velocity", "max_velocity"), num("min_linear_velocity")
    max_w = num("max_angular_velocity")
    acc_v, acc_w = num("max_linear_acceleration", "max_acceleration"), num("max_angular_acceleration")
    max_v = abs(max_v) if max_v else NO_LIMIT
    d.limits = (
        max_v,
        min_v if min_v is not None else -max_v,
        abs(max_w) if max_w else NO_LIMIT,
        abs(acc_v) if acc_v else NO_LIMIT,
        abs(acc_w) if acc_w else NO_LIMIT,
    )
    cmd = txt("topic", "command_topic", "commandTopic") or _ros_remap(p, "cmd_vel")
    odom = txt("odom_topic", "odometry_topic", "odometryTopic") or _ros_remap(p, "odom")
    d.cmd_topic, d.odom_topic = _topic(cmd or "cmd_vel"), _topic(odom or "odom")
    d.odom_frame = txt("frame_id", "odometry_frame", "odometryFrame") or "odom"
    d.base_frame = txt("child_frame_id", "robot_base_frame", "robotBaseFrame") or ""
    rate = num("odom_publish_frequency", "publish_rate", "odometry_rate", "odometryRate", "update_rate", "updateRate")
    d.odom_rate = rate if rate and rate > 0 else 50.0
    return d


def _wheels_from_geometry(links: Sequence[Link], in_root: Mapping[str, np.ndarray], src: Path) -> _Drive:
    """The two wheels of a file without a drive plugin: revolute joints whose links carry a cylinder."""
    wheels = []
    for link in links:
        if link.joint_type in ("revolute", "continuous") and any(
            c.geometry.shape == "cylinder" for c in link.collisions
        ):
            cyl = next(c for c in link.collisions if c.geometry.shape == "cylinder")
            wheels.append((float(in_root[link.name][1, 3]), link.joint, cyl.geometry.radius))
    if len(wheels) != 2:
        names = [w[1] for w in wheels]
        raise ConfigError(
            f"{src}: --drive diff_drive needs two wheel joints (revolute joints of links with a cylinder), found {names}"
        )
    (yr, right, rr), (yl, left, rl) = sorted(wheels)
    return _Drive("diff_drive", wheels=(left, right), separation=yl - yr, radius=(rl + rr) / 2)


# ---------------------------------------------------------------- sensors


def _noise_std(el: ET.Element | None) -> float:
    """The stddev of a gaussian ``<noise>`` under ``el`` (0 without one)."""
    if el is None:
        return 0.0
    noise = el.find("noise")
    if noise is None:
        return 0.0
    return float(_number(noise, ["stddev"], "noise", 0.0) or 0.0)


def _sensor_topic_frame(s: ET.Element, link: str, default_topic: str) -> tuple[str, str]:
    topic = _text(s, "topic")
    frame = _text(s, "frame_id") or _text(s, "gz_frame_id") or _text(s, "ignition_frame_id")
    for plugin in s.findall("plugin"):
        topic = topic or _text(plugin, "topicName") or _ros_remap(plugin, "out")
        frame = frame or _text(plugin, "frame_name") or _text(plugin, "frameName")
    return _topic(topic or default_topic), frame or link


@dataclass
class _Sensors:
    scan: LaserConfig | None = None
    lidar: LidarConfig | None = None
    imu: ImuConfig | None = None
    frames: dict[str, tuple[str, np.ndarray]] = field(default_factory=dict)  # frame -> (link, pose in link)
    other: list[str] = field(default_factory=list)


def _sensors(parsed: _Parsed, in_root: Mapping[str, np.ndarray], src: Path) -> _Sensors:
    out = _Sensors()
    for sensor in parsed.sensors:
        s, kind, name = sensor.element, sensor.element.get("type", ""), sensor.element.get("name", "")
        where = f"{src}: sensor '{name}' (link '{sensor.link}')"
        rate = float(_number(s, ["update_rate", "updateRate"], where, 10.0) or 10.0)
        mount = mount_of(in_root[sensor.link] @ sensor.pose)
        if kind in LIDAR_TYPES:
            ray = s.find("lidar") if s.find("lidar") is not None else s.find("ray")
            scan = ray.find("scan") if ray is not None else None
            h = scan.find("horizontal") if scan is not None else None
            v = scan.find("vertical") if scan is not None else None
            h_samples = int(_number(h, ["samples"], where, 0) or 0)
            v_samples = int(_number(v, ["samples"], where, 1) or 0) if v is not None else 1
            if h_samples <= 0 or v_samples <= 0:
                raise ConfigError(f"{where}: {h_samples} horizontal and {v_samples} vertical samples; both must be > 0")
            a0 = float(_number(h, ["min_angle"], where, 0.0) or 0.0)
            a1 = float(_number(h, ["max_angle"], where, 0.0) or 0.0)
            rng = ray.find("range") if ray is not None else None
            r0 = float(_number(rng, ["min"], where, 0.0) or 0.0)
            r1 = float(_number(rng, ["max"], where, 10.0) or 10.0)
            noise = _noise_std(ray)
            topic, frame = _sensor_topic_frame(s, sensor.link, "scan" if v_samples == 1 else "points")
            try:
                if v_samples == 1 and out.scan is None:
                    inc = (a1 - a0) / (h_samples - 1) if h_samples > 1 else 0.0
                    out.scan = LaserConfig(topic, frame, mount, rate, h_samples, a0, a1 + inc, r0, r1, noise)
                elif v_samples > 1 and out.lidar is None:
                    v0 = math.degrees(float(_number(v, ["min_angle"], where, 0.0) or 0.0))
                    v1 = math.degrees(float(_number(v, ["max_angle"], where, 0.0) or 0.0))
                    out.lidar = LidarConfig(
                        topic, frame, mount, rate, "velodyne", v_samples, h_samples, 20000, (v0, v1), r0, r1, noise
                    )
                else:
                    out.other.append(f"{name} ({kind}, a second {'laser' if v_samples == 1 else 'LiDAR'})")
                    continue
            except ValueError as exc:
                raise ConfigError(f"{where}: {exc}") from None
            out.frames[frame] = (sensor.link, sensor.pose)
        elif kind == "imu" and out.imu is None:
            imu = s.find("imu")
            av = imu.find("angular_velocity") if imu is not None else None
            la = imu.find("linear_acceleration") if imu is not None else None
            gyro = _noise_std(av.find("x") if av is not None else None)
            accel = _noise_std(la.find("x") if la is not None else None)
            topic, frame = _sensor_topic_frame(s, sensor.link, "imu")
            out.imu = ImuConfig(topic, frame, mount, rate, gyro, accel, 0.0, 0.0, 0.0)
            out.frames[frame] = (sensor.link, sensor.pose)
        else:
            out.other.append(f"{name} ({kind})")
    return out


# ---------------------------------------------------------------- the robot


def _static_frames(links: Sequence[Link], wheels: Sequence[str], sensors: _Sensors) -> list[StaticFrame]:
    """``/tf_static``: every joint but the wheels', and the sensor frames (module docstring)."""
    by_name = {link.name: link for link in links}
    out = [StaticFrame(link.parent, link.name, link.pose) for link in links[1:] if link.joint not in wheels]
    for frame, (link, pose) in sensors.frames.items():
        if np.allclose(pose, np.eye(4)):
            if frame != link and frame not in by_name:
                out.append(StaticFrame(link, frame, IDENTITY))
            continue
        if frame in by_name and frame == link and by_name[link].parent:
            out = [
                StaticFrame(f.parent, f.child, _pose(pose_matrix(f.pose) @ pose)) if f.child == frame else f
                for f in out
            ]
        elif frame in by_name and frame == link:  # the root itself: the sensor's frame sits off it
            continue
        else:
            out.append(StaticFrame(link, frame, _pose(pose)))
    return out


def describe(
    path: Path | str,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[Path | str] = (),
    drive: str | None = None,
) -> RobotSpec:
    """The robot of a URDF/SDF (or xacro) file (module docstring); ConfigError for bad input.

    ``args``: xacro arguments; ``package_paths``: folders holding packages (``navlog.recorder.resources``);
    ``drive``: ``diff_drive`` or ``omni`` for a file that declares no drive plugin."""
    src = Path(path)
    if not src.is_file():
        raise ConfigError(f"robot description {src} not found")
    if drive is not None and drive not in DRIVES:
        raise ConfigError(f"--drive '{drive}' is not one of: {', '.join(DRIVES)}")
    search = list(package_paths)
    if args and not src.name.lower().endswith(".xacro"):
        raise ConfigError(f"{src}: --robot-arg is for xacro files; this one is not")
    text = read_description(src, args, search)
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ConfigError(f"{src}:{exc.position[0]}: not well-formed XML: {exc}") from None
    reader = _Reader(src, search)
    if root.tag == "robot":
        parsed = _parse_urdf(root, reader)
    elif root.tag in ("sdf", "model"):
        parsed = _parse_sdf(root, reader)
    else:
        raise ConfigError(f"{src}: expected a URDF <robot> or an SDF <sdf>, found <{root.tag}>")
    links = _ordered(parsed, src)
    in_root = _in_root(links)
    return _robot(parsed, links, in_root, src, drive)


def _robot(
    parsed: _Parsed, links: list[Link], in_root: Mapping[str, np.ndarray], src: Path, drive: str | None
) -> RobotSpec:
    plugins = [(p, _plugin_kind(p)) for p in parsed.plugins]
    declared = [(p, k) for p, k in plugins if k is not None]
    if declared:
        d = _plugin_drive(declared[0][0], declared[0][1], src)  # type: ignore[arg-type]
    elif drive == "diff_drive":
        d = _wheels_from_geometry(links, in_root, src)
    elif drive == "omni":
        d = _Drive("omni")
    else:
        understood = "; ".join(DRIVE_PLUGINS)
        raise ConfigError(
            f"{src}: no drive plugin navlog understands (understood: {understood}); "
            "give one with --drive diff_drive|omni (or 'drive:' in a robot YAML)"
        )
    by_joint = {link.joint: link for link in links if link.joint}
    if d.wheels is not None:
        for joint in d.wheels:
            if joint not in by_joint or by_joint[joint].joint_type not in ("revolute", "continuous"):
                raise ConfigError(f"{src}: the drive's wheel joint '{joint}' is not a revolute joint of the file")
        left, right = (in_root[by_joint[j].name] for j in d.wheels)
        if d.separation is None:
            d.separation = abs(float(left[1, 3] - right[1, 3]))
        if d.radius is None:
            cylinders = [
                c.geometry.radius for j in d.wheels for c in by_joint[j].collisions if c.geometry.shape == "cylinder"
            ]
            if not cylinders:
                raise ConfigError(f"{src}: the drive gives no wheel radius and its wheels carry no cylinder")
            d.radius = sum(cylinders) / len(cylinders)
    sensors = _sensors(parsed, in_root, src)
    height = -_lowest_point(links, in_root)
    size, reach = _footprint(links, in_root)
    mass = sum(link.inertial.mass for link in links if link.inertial is not None)
    max_v, min_v, max_w, acc_v, acc_w = d.limits
    if d.kind == "diff_drive":
        assert d.wheels is not None and d.radius is not None and d.separation is not None
        try:
            drive_cfg = DriveConfig(
                "diff_drive",
                max_vx=max_v,
                max_wz=max_w,
                min_vx=min_v,
                response_time=0.0,
                max_accel=(acc_v, 0.0, acc_w),
                wheel_radius=d.radius,
                wheel_separation=d.separation,
            )
        except ValueError as exc:  # the drive's own checks (wheels of no size)
            raise ConfigError(f"{src}: {exc} (from {d.plugin or 'the wheel joints'})") from None
    else:
        no_gait = GaitConfig(0.25, 0.0, 0.0, 0.0)
        drive_cfg = DriveConfig(
            "legged",
            max_v,
            max_w,
            max_vy=max_v,
            min_vx=min_v,
            response_time=0.0,
            max_accel=(acc_v, acc_v, acc_w),
            gait=no_gait,
        )
    names = {link.name for link in links}
    footprint = d.base_frame if d.base_frame and d.base_frame not in names else ""
    if d.base_frame in names and d.base_frame != links[0].name:
        log.warning(
            "%s: the drive's base frame '%s' is a link below the root '%s'; the odometry carries the root "
            "(name a frame that is no link, e.g. base_footprint, or the root link in <child_frame_id>)",
            src,
            d.base_frame,
            links[0].name,
        )
    js = _joint_state_plugin(parsed.plugins)
    js_topic = _topic((_text(js, "topic") or "joint_states") if js is not None else "joint_states")
    js_rate = (
        float(_number(js, ["update_rate"], f"{src}: joint state publisher", 30.0) or 30.0) if js is not None else 30.0
    )
    wheels = d.wheels or ()
    model = RobotModel(
        str(src),
        links,
        _static_frames(links, wheels, sensors),
        d.wheels,
        d.cmd_topic,
        js_topic,
        js_rate,
        d.plugin,
        sensors.other,
        height,
    )
    return RobotSpec(
        name=parsed.name,
        radius=reach,
        body=BodyConfig(size, mass, height),
        drive=drive_cfg,
        description=f"from {src}",
        frames=FramesConfig(odom=d.odom_frame, base_footprint=footprint, base=links[0].name),
        scan=sensors.scan,
        lidar=sensors.lidar,
        imu=sensors.imu,
        odom=OdomConfig(
            topic=d.odom_topic,
            rate=d.odom_rate,
            linear_scale_error=0.0,
            yaw_rate_bias=0.0,
            linear_noise=0.0,
            angular_noise=0.0,
        ),
        timestep=DESCRIBED_TIMESTEP,
        model=model,
    )


# ---------------------------------------------------------------- loading by name


def load_robot(
    name: str,
    args: Mapping[str, str] | None = None,
    package_paths: Sequence[Path | str] = (),
    drive: str | None = None,
) -> RobotSpec:
    """A robot by name, YAML path, or description file (``.urdf``, ``.sdf``, ``.urdf.xacro``, ``.sdf.xacro``:
    ``describe`` with the xacro ``args``, ``package_paths`` and ``drive``).

    A robot YAML with ``description_file: PATH`` (relative to the YAML) takes the robot of that file and
    adds what its other keys give (merged key by key: e.g. ``odom`` noise, a ``lidar``); its ``drive``
    ``type`` (``diff_drive``, ``omni``) stands for ``drive`` when the file declares no drive plugin."""
    if is_description(name):
        return describe(name, args, package_paths, drive)
    path = named_config("robots", name)
    data = load_yaml(path)
    if not (isinstance(data, dict) and "description_file" in data):
        given = [f"--robot-arg {k}:={v}" for k, v in (args or {}).items()] + ([f"--drive {drive}"] if drive else [])
        if given:  # (they would be ignored: the YAML is the whole robot)
            raise ConfigError(
                f"{path}: {', '.join(given)}: for a robot from a description file (URDF, SDF, xacro); this robot "
                "YAML has no description_file, its drive is its own 'drive' key"
            )
        return load_config(RobotSpec, path)
    return _described_yaml(path, dict(data), args, package_paths, drive)


def _merged(base: dict, extra: Mapping) -> dict:
    out = dict(base)
    for key, value in extra.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), dict):
            out[key] = _merged(out[key], value)
        else:
            out[key] = value
    return out


def _described_yaml(
    path: Path, data: dict, args: Mapping[str, str] | None, package_paths: Sequence[Path | str], drive: str | None
) -> RobotSpec:
    file = data.pop("description_file")
    if not isinstance(file, str) or not file:
        raise ConfigError(f"{path}: description_file must be a path to a .urdf, .sdf or .xacro file")
    yaml_drive = data.get("drive")
    if isinstance(yaml_drive, Mapping) and drive is None:
        drive = yaml_drive.get("type")
        if drive == "omni":  # an omni base runs on the kinematic carriage of the legged drive
            data["drive"] = {k: v for k, v in yaml_drive.items() if k != "type"}
    try:
        described = describe(path.parent / file, args, package_paths, drive)
        return from_mapping(RobotSpec, _merged(to_mapping(described), data))
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
