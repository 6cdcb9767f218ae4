"""A robot's kinematic tree as a description file gives it: links, joints, collision geometry, inertia.

``RobotModel`` is what ``navlog.recorder.description`` reads from a URDF or SDF file and what the
simulator builds its MuJoCo bodies from (``navlog.recorder.robot_bodies``). Poses are
``(x, y, z, qx, qy, qz, qw)``. Every link's pose is given in its parent link's frame (the root's is
the identity), as URDF's joint origins give it; an SDF model's poses are converted to that form.
Links are listed parents first.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from navlog.replay.geometry import make_transform

Pose = tuple[float, float, float, float, float, float, float]  # x, y, z, qx, qy, qz, qw
IDENTITY: Pose = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def pose_matrix(p: Pose) -> np.ndarray:
    """The 4x4 transform of a ``Pose``."""
    return make_transform(p[:3], p[3:])


@dataclass(frozen=True)
class Geometry:
    shape: Literal["box", "cylinder", "sphere", "capsule", "mesh"]
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)  # box: full edge lengths
    radius: float = 0.0  # cylinder, sphere, capsule
    length: float = 0.0  # cylinder, capsule: along the geometry's z
    mesh: str = ""  # mesh: the file, resolved
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  # mesh


@dataclass(frozen=True)
class Collision:
    name: str
    pose: Pose  # in the link's frame
    geometry: Geometry


@dataclass(frozen=True)
class Inertial:
    mass: float
    pose: Pose  # the centre of mass and the inertia's axes, in the link's frame
    inertia: tuple[float, float, float, float, float, float]  # ixx, iyy, izz, ixy, ixz, iyz

    def principal_moments(self) -> np.ndarray:
        """The inertia's principal moments, smallest first."""
        ixx, iyy, izz, ixy, ixz, iyz = self.inertia
        return np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))

    @property
    def unbalanced(self) -> bool:
        """The largest principal moment exceeds the sum of the other two (no rigid body has such an inertia;
        the simulator evens it out, as MuJoCo's ``balanceinertia`` does)."""
        a, b, c = self.principal_moments()
        return bool(a + b < c * (1 - 1e-9))


@dataclass(frozen=True)
class Link:
    name: str
    pose: Pose = IDENTITY  # in the parent link's frame
    parent: str = ""  # "" for the root
    joint: str = ""  # the joint to the parent
    joint_type: str = "fixed"  # the file's joint type (fixed, revolute, continuous, ball, prismatic, ...)
    joint_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)  # where the joint's axis passes, in the link's frame
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)  # in the link's frame
    inertial: Inertial | None = None
    collisions: list[Collision] = field(default_factory=list)


@dataclass(frozen=True)
class StaticFrame:
    """A transform of ``/tf_static``: a fixed joint's, or a sensor frame that is not a link."""

    parent: str
    child: str
    pose: Pose


@dataclass(frozen=True)
class RobotModel:
    source: str  # the description file
    links: list[Link]
    static_frames: list[StaticFrame] = field(default_factory=list)
    wheel_joints: tuple[str, str] | None = None  # (left, right) of a differential drive
    cmd_topic: str = "/cmd_vel"
    joint_states_topic: str = "/joint_states"
    joint_states_rate: float = 30.0
    drive_plugin: str = ""  # the plugin the drive comes from ("" when given by --drive or the robot YAML)
    other_sensors: list[str] = field(default_factory=list)  # "name (type)" of sensors navlog does not simulate
    height: float = 0.0  # the root link's height above the floor when the robot stands on it

    @property
    def root(self) -> str:
        return self.links[0].name

    def link(self, name: str) -> Link:
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(name)
