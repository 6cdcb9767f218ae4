"""Robots from YAML (description files: ``navlog.recorder.description``): body, drive, frames and
sensor set, and their MuJoCo model.

Two drives:
- ``legged``: a legged-base stand-in (legs are not simulated). The trunk rides on planar joints
  (x, y, yaw) driven by velocity actuators, plus height, roll and pitch joints on position actuators
  that follow the body sway of a trotting gait (stride frequency 1 / (2 * stance_duration)), scaled
  with speed. Commands pass through a first-order response (``response_time``) within the limits.
- ``diff_drive``: a real differential drive: a free chassis on two velocity-driven wheel joints and
  two frictionless casters, the rear one on the floor and the front one 5 mm above it (the chassis'
  mass sits over the axle: without it the robot would tip onto its nose when braking); wheel
  odometry is integrated from the wheel joint speeds with the nominal wheel radius and separation,
  so wheel slip makes it drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from navlog.recorder.robot_bodies import ROBOT_GROUP
from navlog.recorder.robot_model import RobotModel
from navlog.replay.config import load_config, named_config, param
from navlog.replay.geometry import quat_from_rpy, quat_to_wxyz
from navlog.replay.limits import MAX_RATE_HZ, MAX_SENSOR_POINTS, budget

Vec3 = tuple[float, float, float]
Mount = tuple[float, float, float, float, float, float]  # x, y, z, roll, pitch, yaw (rad)
ZERO_MOUNT: Mount = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
CMD_VEL_TOPIC = "/cmd_vel"  # every robot drives on the velocity commands of this topic
DEFAULT_ODOMETRY = ("/odom", "odom")  # (topic, frame) of the odometry unless a drive plugin names others


@dataclass(frozen=True)
class LaserConfig:
    """A horizontal 2D laser (sensor_msgs/LaserScan)."""

    topic: str = "/scan"
    frame: str = "front_laser"
    mount: Mount = ZERO_MOUNT
    rate: float = param(10.0, le=MAX_RATE_HZ)  # Hz
    samples: int = param(720, le=MAX_SENSOR_POINTS)  # beams per scan
    angle_min: float = -math.pi
    angle_max: float = math.pi  # exclusive: increment = (max - min) / samples
    range_min: float = 0.12
    range_max: float = 6.0
    noise_std: float = 0.01

    def __post_init__(self) -> None:
        if self.rate <= 0 or self.samples <= 0 or not (0 <= self.range_min < self.range_max):
            raise ValueError("laser needs rate > 0, samples > 0 and 0 <= range_min < range_max")


@dataclass(frozen=True)
class LidarConfig:
    """A 3D LiDAR (sensor_msgs/PointCloud2 with x, y, z, intensity, ring, time)."""

    topic: str = "/livox/lidar"
    frame: str = "livox_frame"
    mount: Mount = (0.2, 0.0, 0.08, 0.0, 0.0, 0.0)
    rate: float = param(10.0, le=MAX_RATE_HZ)  # Hz
    pattern: Literal["velodyne", "livox_mid360"] = "velodyne"
    lines: int = param(16, le=MAX_SENSOR_POINTS)  # velodyne: rings
    columns: int = param(720, le=MAX_SENSOR_POINTS)  # velodyne: azimuth steps per revolution
    points: int = param(20000, le=MAX_SENSOR_POINTS)  # livox_mid360: points per frame
    vertical_fov: tuple[float, float] = (-15.0, 15.0)  # degrees
    range_min: float = 0.1
    range_max: float = 30.0
    noise_std: float = 0.005

    def __post_init__(self) -> None:
        if self.rate <= 0 or self.lines <= 0 or self.columns <= 0 or self.points <= 0:
            raise ValueError("lidar needs positive rate, lines, columns and points")
        budget(
            "columns",
            f"lines x columns ({self.lines} x {self.columns})",
            self.lines * self.columns,
            MAX_SENSOR_POINTS,
            " points",
        )
        if self.vertical_fov[0] >= self.vertical_fov[1]:
            raise ValueError("lidar vertical_fov must be [low, high] degrees with low < high")


@dataclass(frozen=True)
class ImuConfig:
    topic: str = "/imu/data"
    frame: str = "imu_link"
    mount: Mount = ZERO_MOUNT
    rate: float = param(200.0, le=MAX_RATE_HZ)  # Hz
    gyro_noise: float = 0.002  # rad/s, white
    accel_noise: float = 0.02  # m/s^2, white
    gyro_bias: float = 0.001  # rad/s, constant per run, drawn from the seed
    accel_bias: float = 0.01  # m/s^2
    orientation_noise: float = 0.001  # rad
    # Hz: the IMU's low-pass filter, as a real IMU's digital filter and driver give (e.g. 20 Hz): rates and
    # accelerations averaged over each physics tick, then filtered (first order); 0: the physics'
    # instantaneous values (a contact resolved in one physics step is then a spike of several g)
    bandwidth: float = 0.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.bandwidth <= 1000.0:
            raise ValueError("imu.bandwidth must be between 0 (no filter) and 1000 Hz")


@dataclass(frozen=True)
class OdomConfig:
    """The robot's own odometry and the ground-truth relay."""

    topic: str = "/odom"
    ground_truth_topic: str = "/odom/ground_truth"
    rate: float = param(50.0, le=MAX_RATE_HZ)  # Hz
    use_ground_truth_odom: bool = False
    linear_scale_error: float = 0.03  # legged: fraction of the true body speed
    yaw_rate_bias: float = 0.004  # legged: rad/s added to the true yaw rate
    linear_noise: float = 0.01  # m/s, white on each velocity sample
    angular_noise: float = 0.01  # rad/s


@dataclass(frozen=True)
class FramesConfig:
    map: str = "map"
    world: str = "world"
    odom: str = "odom"
    base_footprint: str = "base_footprint"  # "" for robots without one
    base: str = "base_link"


@dataclass(frozen=True)
class GaitConfig:
    stance_duration: float = 0.25
    roll_amplitude: float = 0.6  # degrees at full speed
    pitch_amplitude: float = 0.4  # degrees
    bob_amplitude: float = 0.004  # metres


@dataclass(frozen=True)
class DriveConfig:
    type: Literal["legged", "diff_drive"]
    max_vx: float
    max_wz: float
    max_vy: float = 0.0
    min_vx: float | None = None  # default: -max_vx
    cmd_vel_timeout: float = 0.5
    response_time: float = 0.25  # first-order time constant of the velocity response (s)
    max_accel: tuple[float, float, float] = (1.0, 1.0, 2.0)
    gait: GaitConfig = field(default_factory=GaitConfig)
    wheel_radius: float = 0.1
    wheel_separation: float = 0.4
    wheel_radius_error: float = 0.0  # actual radius = nominal * (1 + error): odometry scale drift

    def __post_init__(self) -> None:
        if self.max_vx <= 0 or self.max_wz <= 0 or self.max_vy < 0:
            raise ValueError("drive limits must be positive")
        if self.type == "diff_drive" and self.max_vy != 0:
            raise ValueError("a diff_drive cannot move sideways: set max_vy to 0")
        if self.type == "diff_drive" and not (self.wheel_radius > 0 and self.wheel_separation != 0):
            raise ValueError(
                f"the diff drive's wheel radius ({self.wheel_radius:g} m) must be positive and its separation "
                f"({self.wheel_separation:g} m) not zero"
            )
        if not self.wheel_radius_error > -1:
            raise ValueError("wheel_radius_error must be above -1 (the true radius is nominal x (1 + error))")


@dataclass(frozen=True)
class BodyConfig:
    size: Vec3  # trunk box, full edge lengths
    mass: float
    height: float  # base_link above the floor (legged); chassis centre height follows from wheels


@dataclass(frozen=True)
class RobotSpec:
    name: str
    radius: float  # for clearance checks (Nav2 robot_radius)
    body: BodyConfig
    drive: DriveConfig
    description: str = ""
    frame_prefix: str = ""
    frames: FramesConfig = field(default_factory=FramesConfig)
    scan: LaserConfig | None = None
    lidar: LidarConfig | None = None
    imu: ImuConfig | None = None
    odom: OdomConfig = field(default_factory=OdomConfig)
    timestep: float = 0.005  # physics step (s); the sim ticks every 5 ms
    model: RobotModel | None = None  # the links of a robot from a description file (navlog.recorder.description)

    def frame(self, name: str) -> str:
        """A robot frame with the robot's prefix (map and world are never prefixed)."""
        return f"{self.frame_prefix}{name}" if name else ""

    @property
    def odometry(self) -> tuple[str, str] | None:
        """(topic, frame with the robot's prefix) of the robot's odometry when it names others than /odom and
        ``odom`` (a drive plugin's ``odom_topic`` and ``frame_id``), else None: the Nav2 files of navlog's own
        robots name their (prefixed) frames themselves."""
        if (self.odom.topic, self.frames.odom) == DEFAULT_ODOMETRY:
            return None
        return self.odom.topic, self.frame(self.frames.odom)

    @property
    def cmd_topic(self) -> str:
        """The topic the robot drives on: its drive plugin's, else ``CMD_VEL_TOPIC``."""
        return self.model.cmd_topic if self.model is not None else CMD_VEL_TOPIC


def load_robot(name: str) -> RobotSpec:
    """A robot YAML by name or path (``navlog.recorder.description.load_robot`` also takes description files)."""
    return load_config(RobotSpec, named_config("robots", name))


# ---------------------------------------------------------------- MuJoCo model

# a described robot's wheels: MuJoCo's soft friction lets a wheel creep under load (small, light wheels
# creep most); the no-slip solver's passes remove it
NOSLIP_ITERATIONS = 4


def add_carriage(body) -> None:
    """The planar carriage of a kinematic base on ``body``: x, y, yaw joints driven in velocity (``act_x``,
    ``act_y``, ``act_yaw``); z, pitch, roll held by position actuators (``act_z``, ``act_pitch``, ``act_roll``)."""
    import mujoco

    for name, jtype, axis in (
        ("x", mujoco.mjtJoint.mjJNT_SLIDE, [1, 0, 0]),
        ("y", mujoco.mjtJoint.mjJNT_SLIDE, [0, 1, 0]),
        ("z", mujoco.mjtJoint.mjJNT_SLIDE, [0, 0, 1]),
        ("yaw", mujoco.mjtJoint.mjJNT_HINGE, [0, 0, 1]),
        ("pitch", mujoco.mjtJoint.mjJNT_HINGE, [0, 1, 0]),
        ("roll", mujoco.mjtJoint.mjJNT_HINGE, [1, 0, 0]),
    ):
        body.add_joint(
            name=f"base_{name}", type=jtype, axis=axis, damping=[1.0, 0, 0] if name in "xyz" else [0.2, 0, 0]
        )


def _add_carriage_actuators(spec, mass: float) -> None:
    import mujoco

    m = mass
    spec.add_actuator(name="act_x", target="base_x", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_velocity(kv=m / 0.02)
    spec.add_actuator(name="act_y", target="base_y", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_velocity(kv=m / 0.02)
    spec.add_actuator(name="act_yaw", target="base_yaw", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_velocity(kv=20.0)
    spec.add_actuator(name="act_z", target="base_z", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(
        kp=6000.0, kv=400.0
    )
    spec.add_actuator(name="act_pitch", target="base_pitch", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(
        kp=400.0, kv=20.0
    )
    spec.add_actuator(name="act_roll", target="base_roll", trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(
        kp=400.0, kv=20.0
    )


def _add_described(spec, robot: RobotSpec, model: RobotModel, start: tuple[float, float, float]) -> None:
    """A robot from a description file (``navlog.recorder.robot_bodies``)."""
    from navlog.recorder.robot_bodies import add_bodies, wheel_gain

    x, y, yaw = start
    if robot.drive.type == "legged":  # an omni base: the carriage, as the legged drive's, without contacts
        root = spec.worldbody.add_body(name=model.root, pos=[0.0, 0.0, model.height], gravcomp=1.0)
        add_carriage(root)
        add_bodies(spec, model, root, None)
        for geom in spec.geoms:
            if geom.group == ROBOT_GROUP:
                geom.contype = geom.conaffinity = 0
        for body in spec.bodies:
            body.gravcomp = 1.0
        _add_carriage_actuators(spec, robot.body.mass)
    else:
        root = spec.worldbody.add_body(
            name=model.root, pos=[x, y, model.height], quat=list(quat_to_wxyz(quat_from_rpy(0.0, 0.0, yaw)))
        )
        root.add_freejoint(name="base_free")
        spec.option.noslip_iterations = NOSLIP_ITERATIONS
        d = robot.drive
        add_bodies(spec, model, root, wheel_gain(robot.body.mass, d.wheel_radius))
    root.add_site(name="imu", pos=list(robot.imu.mount[:3]) if robot.imu else [0, 0, 0])


def add_to_spec(spec, robot: RobotSpec, start: tuple[float, float, float]) -> None:
    """Add the robot to a world MjSpec at ``start`` = (x, y, yaw)."""
    import mujoco

    x, y, yaw = start
    bx, by, bz = robot.body.size
    G = mujoco.mjtGeom
    spec.option.timestep = robot.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    if robot.model is not None:
        _add_described(spec, robot, robot.model, start)
    elif robot.drive.type == "legged":
        # planar carriage carrying the trunk: x, y, yaw driven in velocity; z, pitch, roll held by
        # position actuators that follow the gait sway; gravity compensated on the trunk.
        # the carriage starts at the origin; the simulator sets the start pose on the x, y, yaw joints
        base = spec.worldbody.add_body(name="base_link", pos=[0.0, 0.0, robot.body.height], gravcomp=1.0)
        add_carriage(base)
        base.add_geom(
            name="trunk",
            type=G.mjGEOM_BOX,
            size=[bx / 2, by / 2, bz / 2],
            mass=robot.body.mass,
            group=ROBOT_GROUP,
            contype=0,
            conaffinity=0,
        )
        _add_carriage_actuators(spec, robot.body.mass)
        base.add_site(name="imu", pos=list(robot.imu.mount[:3]) if robot.imu else [0, 0, 0])
    else:
        d = robot.drive
        r_true = d.wheel_radius * (1.0 + d.wheel_radius_error)
        base = spec.worldbody.add_body(
            name="base_link", pos=[x, y, r_true], quat=list(quat_to_wxyz(quat_from_rpy(0.0, 0.0, yaw)))
        )
        base.add_freejoint(name="base_free")
        base.add_geom(
            name="chassis",
            type=G.mjGEOM_BOX,
            size=[bx / 2, by / 2, bz / 2],
            pos=[0, 0, bz / 2],
            mass=robot.body.mass,
            group=ROBOT_GROUP,
        )
        for side, sy in (("left", 1.0), ("right", -1.0)):
            wheel = base.add_body(name=f"wheel_{side}", pos=[0, sy * d.wheel_separation / 2, 0])
            wheel.add_joint(name=f"wheel_{side}_joint", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], armature=0.01)
            wheel.add_geom(
                name=f"wheel_{side}_geom",
                type=G.mjGEOM_CYLINDER,
                size=[r_true, 0.02, 0],
                quat=list(quat_to_wxyz(quat_from_rpy(math.pi / 2, 0.0, 0.0))),
                mass=0.5,
                friction=[1.0, 0.005, 0.0001],
                group=ROBOT_GROUP,
            )
            spec.add_actuator(
                name=f"act_wheel_{side}", target=f"wheel_{side}_joint", trntype=mujoco.mjtTrn.mjTRN_JOINT
            ).set_to_velocity(kv=8.0)
        caster_r = r_true / 2
        # the front caster rides 5 mm above the floor: it catches the chassis when it pitches forward
        for name, cx, lift in (("caster", -bx / 2 + caster_r, 0.0), ("caster_front", bx / 2 - caster_r, 0.005)):
            base.add_geom(
                name=name,
                type=G.mjGEOM_SPHERE,
                size=[caster_r, 0, 0],
                pos=[cx, 0, caster_r - r_true + lift],
                friction=[0.0, 0.0, 0.0],
                condim=1,
                mass=0.1,
                group=ROBOT_GROUP,
            )
        base.add_site(name="imu", pos=list(robot.imu.mount[:3]) if robot.imu else [0, 0, 0])
    spec.add_sensor(name="imu_gyro", type=mujoco.mjtSensor.mjSENS_GYRO, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu")
    spec.add_sensor(
        name="imu_accel", type=mujoco.mjtSensor.mjSENS_ACCELEROMETER, objtype=mujoco.mjtObj.mjOBJ_SITE, objname="imu"
    )
