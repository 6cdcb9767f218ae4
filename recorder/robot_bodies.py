"""The MuJoCo bodies of a described robot (``RobotModel``), built link by link into a world's MjSpec.

The bodies are built here from the parsed links rather than by MuJoCo's URDF compiler: SDF files
(MuJoCo reads none) and URDF files take the one path, the Gazebo extensions (plugins, sensors) have
to be read anyway, and the drive decides which joints move. Each link is a body placed at its pose in
its parent's; its inertial is taken as the file gives it (mass, centre, full inertia: the collision
geometry adds no mass, as in URDF and SDF); its collision geometry becomes geoms (meshes through
``trimesh``, which reads DAE with ``pycollada``, STL and OBJ; MuJoCo collides with their convex
hulls). A drive wheel's cylinder collides as a sphere of its radius: it touches the floor at one
point, where a cylinder's rim gives MuJoCo several across its width that scrub against each other in
a turn. Only the wheels of a differential drive get joints (hinges with velocity actuators named
``act_wheel_left`` and ``act_wheel_right``); every other joint is held at its rest pose. Geoms that
rest on the floor other than the wheels (casters, skids) are frictionless (with a higher contact
priority than the floor's, whose friction MuJoCo would otherwise take for the pair). The robot's geoms collide
with the world, never with each other.

A differential drive's root link rides on a free joint; an omni base's on the legged drive's planar
carriage (``navlog.recorder.robot.add_carriage``), gravity compensated and without contacts.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any

import numpy as np

from navlog.errors import ConfigError
from navlog.recorder.robot_model import Link, RobotModel, pose_matrix

ROBOT_GROUP = 3  # every robot geom lives in this group
ROBOT_CONTYPE, ROBOT_CONAFFINITY = 2, 1  # collide with the world's geoms (contype 1), not with each other
RESTING = 0.002  # m: a geom whose lowest point is this close to the floor rests on it
MIN_MASS, MIN_INERTIA = 1e-6, 1e-9  # a moving link the file gives no inertial
WHEEL_RESPONSE = 0.002  # s: the wheel servos' time constant for the robot's whole mass


@lru_cache(maxsize=64)
def _mesh(path: str) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    loaded: Any = trimesh.load(path, force="mesh", process=False)
    vertices = np.asarray(loaded.vertices, dtype=np.float64)
    faces = np.asarray(loaded.faces, dtype=np.int32)
    vertices.flags.writeable = False
    faces.flags.writeable = False
    return vertices, faces


def mesh_data(path: str, link: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (unscaled) and triangles of a mesh file; ConfigError naming the file and link if unreadable."""
    try:
        vertices, faces = _mesh(path)
    except Exception as exc:  # trimesh and its readers raise many kinds
        raise ConfigError(f"link '{link}': collision mesh {path} cannot be read: {exc}") from None
    if len(vertices) < 4 or len(faces) == 0:
        raise ConfigError(f"link '{link}': collision mesh {path} has no volume ({len(vertices)} vertices)")
    return vertices, faces


def mesh_vertices(path: str, link: str) -> np.ndarray:
    return mesh_data(path, link)[0]


def _wxyz(q: tuple[float, ...]) -> list[float]:
    return [q[3], q[0], q[1], q[2]]


def _add_link(
    spec, body, link: Link, model: RobotModel, wheels: tuple[str, ...], resting: set[tuple[str, int]]
) -> None:
    import mujoco

    G = mujoco.mjtGeom
    if link.inertial is not None and link.inertial.mass > 0:
        i = link.inertial
        body.explicitinertial = True
        body.mass = i.mass
        body.ipos = list(i.pose[:3])
        body.iquat = _wxyz(i.pose[3:])
        ixx, iyy, izz, ixy, ixz, iyz = i.inertia
        if ixy == ixz == iyz == 0.0:
            body.inertia = [max(ixx, MIN_INERTIA), max(iyy, MIN_INERTIA), max(izz, MIN_INERTIA)]
        else:
            body.fullinertia = [ixx, iyy, izz, ixy, ixz, iyz]
    elif not link.parent or link.joint in wheels:
        body.explicitinertial = True
        body.mass = MIN_MASS
        body.inertia = [MIN_INERTIA] * 3
    wheel = link.joint in wheels
    # a URDF may name two collisions of a link alike; MuJoCo's geoms and meshes need names of their own: when
    # two are alike, every collision of the link is numbered
    names = [f"{link.name}/{c.name}" for c in link.collisions]
    if len(set(names)) < len(names):
        names = [f"{name}#{k}" for k, name in enumerate(names)]
    for k, c in enumerate(link.collisions):
        g = c.geometry
        kw: dict = dict(
            name=names[k],
            pos=list(c.pose[:3]),
            quat=_wxyz(c.pose[3:]),
            contype=ROBOT_CONTYPE,
            conaffinity=ROBOT_CONAFFINITY,
            group=ROBOT_GROUP,
        )
        if wheel:
            kw["friction"] = [1.0, 0.005, 0.0001]
        elif (link.name, k) in resting:
            # priority: MuJoCo takes the larger condim and friction of a pair; the floor's would win otherwise
            kw.update(friction=[0.0, 0.0, 0.0], condim=1, priority=1)
        if g.shape == "box":
            body.add_geom(type=G.mjGEOM_BOX, size=[v / 2 for v in g.size], **kw)
        elif g.shape == "sphere" or (g.shape == "cylinder" and wheel):  # a wheel: one contact point
            body.add_geom(type=G.mjGEOM_SPHERE, size=[g.radius, 0, 0], **kw)
        elif g.shape == "cylinder":
            body.add_geom(type=G.mjGEOM_CYLINDER, size=[g.radius, g.length / 2, 0], **kw)
        elif g.shape == "capsule":
            body.add_geom(type=G.mjGEOM_CAPSULE, size=[g.radius, g.length / 2, 0], **kw)
        else:
            vertices, faces = mesh_data(g.mesh, link.name)
            mesh_name = f"mesh:{names[k]}"
            spec.add_mesh(
                name=mesh_name,
                uservert=(vertices * np.asarray(g.scale)).ravel().tolist(),
                userface=faces.ravel().tolist(),
            )
            body.add_geom(type=G.mjGEOM_MESH, meshname=mesh_name, **kw)
    if wheel:
        body.add_joint(
            name=link.joint,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            pos=list(link.joint_pos),
            axis=list(link.axis),
            armature=1e-4,
        )


def resting_geoms(model: RobotModel) -> set[tuple[str, int]]:
    """(link, collision index) of the geoms, other than the wheels', whose lowest point is on the floor."""
    wheels = model.wheel_joints or ()
    out = set()
    in_root: dict[str, np.ndarray] = {}
    for link in model.links:
        local = pose_matrix(link.pose)
        in_root[link.name] = in_root[link.parent] @ local if link.parent else local
        if link.joint in wheels:
            continue
        for k, c in enumerate(link.collisions):
            t = in_root[link.name] @ pose_matrix(c.pose)
            g, rz, z = c.geometry, t[2, :3], float(t[2, 3])
            if g.shape == "sphere":
                low = z - g.radius
            elif g.shape == "box":
                low = z - float(np.abs(rz) @ np.asarray(g.size)) / 2
            elif g.shape == "mesh":
                low = z + float(((mesh_vertices(g.mesh, link.name) * np.asarray(g.scale)) @ rz).min())
            else:
                low = z - abs(float(rz[2])) * g.length / 2 - math.sqrt(max(0.0, 1 - float(rz[2]) ** 2)) * g.radius
            if low + model.height < RESTING:
                out.add((link.name, k))
    return out


def add_bodies(spec, model: RobotModel, root_body, wheel_kv: float | None) -> None:
    """The links of ``model`` under ``root_body`` (the root link's body, already placed); the wheels' velocity
    actuators with gain ``wheel_kv`` (a differential drive)."""
    import mujoco

    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.balanceinertia = True  # an inertia no rigid body has (``Inertial.unbalanced``) is evened out
    wheels = model.wheel_joints or ()
    resting = resting_geoms(model)
    bodies = {model.root: root_body}
    for link in model.links:
        if link.parent:
            bodies[link.name] = bodies[link.parent].add_body(
                name=link.name, pos=list(link.pose[:3]), quat=_wxyz(link.pose[3:])
            )
        _add_link(spec, bodies[link.name], link, model, wheels, resting)
    if wheel_kv is not None and model.wheel_joints is not None:
        for side, joint in zip(("left", "right"), model.wheel_joints):
            spec.add_actuator(
                name=f"act_wheel_{side}", target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT
            ).set_to_velocity(kv=wheel_kv)


def wheel_gain(mass: float, radius: float) -> float:
    """The wheel servos' velocity gain (N m s/rad): the robot's mass reaches a new speed in ``WHEEL_RESPONSE``."""
    return max(mass, 0.1) * radius * radius / WHEEL_RESPONSE
