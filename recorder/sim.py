"""The simulator as a node: MuJoCo physics, the robot's drive, and every sensor, on sim time.

``SimNode`` is a source node (rank 0) on the executor. Every 5 ms tick it applies the latest
``/cmd_vel`` (zero after ``cmd_vel_timeout``), steps the physics, and publishes whatever sensors are
due: ``/clock``, ``/tf_static`` (once, at t = 0), ``/tf``, ``/odom``, ``/odom/ground_truth``,
``/imu/data``, the 2D scan and the 3D LiDAR. All randomness comes from one seed, one stream per
purpose (odometry, IMU, laser, LiDAR), so changing one sensor never changes another's noise.

Contacts: after every tick the simulator looks at MuJoCo's contacts between the robot's geoms and
the world's (the floor excepted). When the robot starts touching a world geom it publishes a navlog
event ``collision`` (source ``sim``, detail the geom's name, value the deepest penetration in metres)
on ``/navlog/events``, and ``collision_end`` once it has not touched it for 0.1 s: once per contact
episode (a robot pressing on a wall touches it on most ticks, not all).
A legged robot's trunk does not collide (its geoms have no contact type), so only wheeled robots report.

The messages (clock, IMU, odometry, TF, scan, cloud) of a topic no node subscribes to are published as
their CDR bytes, encoded directly from the values (``navlog.replay.io.cdr``): the recorder writes
the same bytes the message objects would serialize to, without building them.

The 2D laser and the 3D LiDAR (ray casting, sensor models, noise, CDR) are a ``RangeSensors``
(``navlog.recorder.range_sensors``), in this process or in a worker process beside it
(``SimOptions.sensor_worker``). When a node subscribes to their topic, the simulator waits for the
result and publishes it at its tick, as every other sensor. When only sinks see it, the worker's
result is not waited for: its place is taken at the tick (``Node.defer``), and filled with the CDR
bytes at a later tick, once they have come (at the latest when ``MAX_AHEAD`` newer requests of that
sensor wait, or when the run finishes), while the simulation went on; the executor writes every
message to the sinks in the order published, holding those behind a place until it is filled. So
the file does not depend on when a result came: it is the same with or without the worker, however
fast it was.

IMU: MuJoCo's gyro and accelerometer at the IMU site, instantaneous, or, with ``imu.bandwidth`` set,
averaged over the tick's physics steps and low-passed (``ImuLowPass``), as a real IMU's filter gives
them: a diff drive's caster touching the floor is resolved in one physics step, a spike of several g raw.

Odometry model (documented in the README):
- legged: the true body-frame velocity, scaled by ``1 + linear_scale_error``, plus ``yaw_rate_bias``
  and white noise, integrated at the odometry rate: it drifts like CHAMP's leg odometry.
- diff_drive: wheel joint speeds times the nominal wheel radius (the true radius differs by
  ``wheel_radius_error``), integrated: wheel slip and the radius error make it drift.
- ``use_ground_truth_odom``: /odom relays the true pose instead (as the Go2 setup does).
With no footprint frame (``frames.base_footprint: ""``), ``odom -> base`` carries the odometry's x, y
and yaw with the true height and tilt, on /odom and /tf alike (one pose for one edge).
``map -> odom`` is published as the correction that makes ``map -> base_footprint`` the true pose
(a perfect localiser); with ground-truth odometry it stays the identity. With ``localization="none"``
it is not published at all, as on a real robot with no localiser running: /tf then holds only
odom -> base (the drifting odometry), for a SLAM or localisation node to correct.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np

from navlog.errors import ConfigError, SimulationError
from navlog.recorder import sensors
from navlog.recorder.range_sensors import (
    LIDAR,
    SCAN,
    InProcessSensors,
    RangeSensorsLike,
    start_range_sensors,
)
from navlog.recorder.robot import RobotSpec, add_to_spec
from navlog.recorder.world import World, build_spec, import_mujoco
from navlog.replay import messages
from navlog.replay.geometry import (
    planar_matrix,
    quat_from_rpy,
    quat_from_yaw,
    rotate_planar,
    wrap_angle,
    yaw_from_matrix,
)
from navlog.replay.io.cdr import layout
from navlog.replay.pointcloud import make_cloud
from navlog.replay.runtime.executor import Deferred, Node

mujoco = import_mujoco()
# the warnings on which MuJoCo resets the state (the physics diverged), with what each found not finite or huge;
# the last one's count survives the reset it makes
_DIVERGED = {
    int(mujoco.mjtWarning.mjWARN_BADQACC): "an acceleration",
    int(mujoco.mjtWarning.mjWARN_BADQVEL): "a velocity",
    int(mujoco.mjtWarning.mjWARN_BADQPOS): "a position",
}
_QPOS = int(mujoco.mjtWarning.mjWARN_BADQPOS)  # its index is into qpos, the others' into the velocities

TICK_NS = 5_000_000  # 200 Hz
EVENTS_TOPIC = "/navlog/events"
CONTACT_GAP_NS = 100_000_000  # a contact episode ends after this long without touching (pressing on a wall flickers)
CLOCK_PERIOD_NS = 10_000_000  # /clock at 100 Hz
# raw scans or sweeps of a sensor the simulation may have asked the worker for and not received (module
# docstring): 50 s of sim time at 10 Hz, so that the simulation runs on while the worker starts (it imports
# Open3D: about 0.35 s, in which the simulation alone covers 30-40 s of sim time) or falls behind for a while.
# What that holds is bounded by it: the messages published behind the oldest pending one (about 500 a second
# of sim time, 0.12 MB of CDR, with the IMU at 200 Hz: at most 25000 and 6 MB; measured on the mapping tour:
# up to 24000, 6 MB; the peak RSS of `navlog record` stayed at 200 MB, as with 200) and the requests not yet
# read by the worker (3 kB a sweep: at most 2 MB)
MAX_AHEAD = 500
_ZEROS36 = (0.0,) * 36  # the covariances of the simulator's odometry
_HOMOGENEOUS_ROW = np.array([0.0, 0.0, 0.0, 1.0])


@dataclass(frozen=True)
class SimOptions:
    seed: int = 0
    noise: bool = True
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    localization: Literal["perfect", "none"] = "perfect"  # none: no map -> odom on /tf
    sensor_worker: bool = False  # the laser and the LiDAR in a worker process (module docstring)


def mat_to_quat(mat: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) quaternion (w >= 0) of a rotation matrix (3x3, or its 9 numbers row-major), by MuJoCo's
    ``mju_mat2Quat``: fast enough for every tick, and the recorded quaternions are MuJoCo's to the last bit
    (``navlog.replay.geometry.matrix_to_quat``, SciPy, differs there)."""
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(mat, dtype=np.float64).ravel())
    w, x, y, z = q.tolist()
    if w < 0:
        return (-x, -y, -z, -w)
    return (x, y, z, w)


def _clip(x: float, lo: float, hi: float) -> float:
    """``np.clip`` of one float, with the same comparisons (so the same result, signed zeros included)."""
    x = x if x > lo else lo
    return x if x < hi else hi


class _Normals:
    """Standard normals from a generator, drawn in blocks and handed out one row at a time.

    Row i scaled by ``scale`` equals the i-th call of ``rng.normal(0, scale, width)``: numpy draws the
    same normals in the same order whether they are asked for one row or many rows at a time.
    """

    def __init__(self, rng: np.random.Generator, scale, block: int = 256) -> None:
        self.rng = rng
        self.scale = np.asarray(scale, dtype=np.float64)
        self.block = block
        self._rows = np.empty((0, len(self.scale)))
        self._i = 0

    def next(self) -> np.ndarray:
        if self._i == len(self._rows):
            self._rows = 0.0 + self.scale * self.rng.standard_normal(size=(self.block, len(self.scale)))
            self._i = 0
        row = self._rows[self._i]
        self._i += 1
        return row


def _period_ns(rate: float) -> int:
    """A sensor's period: the multiple of the physics step nearest ``1 / rate`` (one step at least)."""
    return int(round(1e9 / rate / TICK_NS)) * TICK_NS or TICK_NS


def published_rates(robot: RobotSpec) -> dict[str, tuple[float, float]]:
    """Per sensor (odometry, IMU, laser, LiDAR, joint states) whose period is no multiple of the physics step:
    the rate it asks for and the rate it is published at (``_period_ns``)."""
    asked = {"odometry": robot.odom.rate}
    asked.update(
        (name, cfg.rate) for name, cfg in (("IMU", robot.imu), ("laser", robot.scan), ("LiDAR", robot.lidar)) if cfg
    )
    if robot.model is not None and robot.model.wheel_joints is not None:
        asked["joint states"] = robot.model.joint_states_rate
    out = {}
    for name, rate in asked.items():
        got = 1e9 / _period_ns(rate)
        if abs(got - rate) > 1e-6 * rate:
            out[name] = (rate, got)
    return out


def _source(robot: RobotSpec) -> str:
    """Where an error about ``robot``'s build sends the user: its description file, else its name."""
    return robot.model.source if robot.model is not None else f"robot '{robot.name}'"


class SimNode(Node):
    name = "sim"

    def __init__(
        self, world: World, robot: RobotSpec, options: SimOptions, ranges: RangeSensorsLike | None = None
    ) -> None:
        """``ranges``: the laser and the LiDAR, already started (``start_range_sensors``, for the same
        world, robot, seed and noise); by default they are started here, per ``options.sensor_worker``."""
        super().__init__()
        self.world = world
        self.robot = robot
        self.options = options
        # the laser and the LiDAR first: a worker process builds its scene while MuJoCo compiles here
        if ranges is None:
            ranges = start_range_sensors(world, robot, options.seed, options.noise, worker=options.sensor_worker)
        self._ranges = ranges
        try:
            spec = build_spec(world)
            try:
                add_to_spec(spec, robot, options.start)
                self.model = spec.compile()
            except ValueError as exc:  # MuJoCo's model editing and compiler name the element at fault
                detail = " ".join(str(exc).split())
                raise ConfigError(f"MuJoCo cannot build {_source(robot)} in world '{world.name}': {detail}") from None
        except BaseException:
            self.close()  # the worker ends with the simulator that could not be built
            raise
        self.data = mujoco.MjData(self.model)
        self.substeps = max(1, int(round(TICK_NS / 1e9 / self.model.opt.timestep)))
        streams = np.random.SeedSequence(options.seed).spawn(4)  # odometry, IMU, laser, LiDAR (range_sensors)
        self.rng_odom, self.rng_imu = (np.random.default_rng(s) for s in streams[:2])
        # the places of the worker's raw scans and sweeps whose bytes have not come (module docstring):
        # (ticket, topic, type name, place)
        self._late: dict[str, deque[tuple[int, str, str, Deferred]]] = {SCAN: deque(), LIDAR: deque()}
        self.legged = robot.drive.type == "legged"
        base_body = robot.model.root if robot.model is not None else "base_link"
        self._bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, base_body)
        # contacts: which geoms are the robot's, which are world obstacles (static, not the floor)
        world_geom = self.model.geom_bodyid == 0
        self._robot_geom = ~world_geom
        self._obstacle_geom = world_geom & (self.model.geom_type != mujoco.mjtGeom.mjGEOM_PLANE)
        self._touching: dict[str, int] = {}  # world geom the robot touches -> last tick it touched it
        self._init_state()
        # command state
        self._cmd = (0.0, 0.0, 0.0)
        self._cmd_ns: int | None = None
        self._vel = (0.0, 0.0, 0.0)  # filtered body-frame command (vx, vy, wz)
        self._phase = 0.0
        # odometry state (x, y, yaw in the odom frame)
        self._odom = tuple(float(v) for v in options.start)
        self._odom_twist = (0.0, 0.0, 0.0)
        d = robot.drive
        self._gyro_bias = (
            self.rng_imu.normal(0, robot.imu.gyro_bias, 3) if (robot.imu and options.noise) else np.zeros(3)
        )
        self._accel_bias = (
            self.rng_imu.normal(0, robot.imu.accel_bias, 3) if (robot.imu and options.noise) else np.zeros(3)
        )
        self._lidar_frames = 0
        self._mounts = {}
        for cfg in (robot.scan, robot.lidar, robot.imu):
            if cfg is not None:
                self._mounts[cfg.frame] = sensors.mount_matrix(cfg.mount)
        self._periods = {
            "odom": _period_ns(robot.odom.rate),
            "imu": _period_ns(robot.imu.rate) if robot.imu else 0,
            "scan": _period_ns(robot.scan.rate) if robot.scan else 0,
            "lidar": _period_ns(robot.lidar.rate) if robot.lidar else 0,
        }
        self._Imu = messages.msg_class(messages.IMU)
        if robot.imu is not None:
            self._imu_cov = tuple(
                np.diag([v**2] * 3).ravel()
                for v in (robot.imu.orientation_noise, robot.imu.gyro_noise, robot.imu.accel_noise)
            )
            self._imu_cov_values = tuple(tuple(c.tolist()) for c in self._imu_cov)
        self._cdr_clock, self._cdr_imu = layout(messages.CLOCK), layout(messages.IMU)
        self._cdr_odometry, self._cdr_tf = layout(messages.ODOMETRY), layout(messages.TF_MESSAGE)
        # per-tick constants and noise streams (the same draws, in the same order, as one call per sample)
        keep = self._periods["lidar"] // TICK_NS + 2 if self._periods["lidar"] else 1
        self._pose_history: deque[tuple[int, np.ndarray]] = deque(maxlen=keep)
        min_vx = -d.max_vx if d.min_vx is None else d.min_vx
        self._cmd_lo = (float(min_vx), float(-d.max_vy), float(-d.max_wz))
        self._cmd_hi = (float(d.max_vx), float(d.max_vy), float(d.max_wz))
        dt = TICK_NS / 1e9
        self._gain = min(1.0, dt / max(d.response_time, dt))
        self._acc_lo = tuple(float(-a * dt) for a in d.max_accel)
        self._acc_hi = tuple(float(a * dt) for a in d.max_accel)
        self._imu_adr = tuple(
            int(self.model.sensor_adr[mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, name)])
            for name in ("imu_gyro", "imu_accel")
        )
        self._imu_bias = (self._gyro_bias.tolist(), self._accel_bias.tolist())
        # the IMU's low-pass filter (ImuConfig.bandwidth): gyro and accelerometer (6 values) averaged over the
        # physics steps of each tick, then filtered once a tick; None: instantaneous values
        self._imu_lpf: ImuLowPass | None = None
        if robot.imu is not None and robot.imu.bandwidth > 0:
            g_adr, a_adr = self._imu_adr
            self._imu_lpf = ImuLowPass(robot.imu.bandwidth, TICK_NS / 1e9, g_adr, a_adr)
            self._imu_lpf.start(self.data.sensordata)
        self._imu_rot = np.zeros(9)  # orientation noise as a matrix, overwritten for every sample
        self._imu_frame = robot.frame(robot.imu.frame) if robot.imu else ""
        self._imu_types = tuple(
            messages.msg_class(t)
            for t in (
                "builtin_interfaces/msg/Time",
                "std_msgs/msg/Header",
                "geometry_msgs/msg/Quaternion",
                "geometry_msgs/msg/Vector3",
            )
        )
        o = robot.odom
        self._odom_noise = _Normals(self.rng_odom, [o.linear_noise, o.linear_noise, o.angular_noise])
        if robot.imu is not None:
            i = robot.imu
            self._imu_noise = _Normals(
                self.rng_imu, [i.gyro_noise] * 3 + [i.accel_noise] * 3 + [i.orientation_noise] * 3
            )
        self._joints = WheelJoints(self.model, robot) if robot.model is not None and robot.model.wheel_joints else None
        f = robot.frames
        self._frame_names = {
            "scan": robot.frame(robot.scan.frame) if robot.scan else "",
            "lidar": robot.frame(robot.lidar.frame) if robot.lidar else "",
            "world": f.world,
            "map": f.map,
            "odom": robot.frame(f.odom),
            "base": robot.frame(f.base),
            "footprint": robot.frame(f.base_footprint),
        }

    # ------------------------------------------------------------ state
    def _init_state(self) -> None:
        x, y, yaw = self.options.start
        m, d = self.model, self.data
        if self.robot.drive.type == "legged":
            for name, value in (("base_x", x), ("base_y", y), ("base_yaw", yaw)):
                d.qpos[m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]] = value
            self._act = {
                n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"act_{n}")
                for n in ("x", "y", "yaw", "z", "pitch", "roll")
            }
            self._z0 = self.robot.body.height
        else:
            self._act = {
                n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"act_wheel_{n}") for n in ("left", "right")
            }
            model = self.robot.model
            wheels = model.wheel_joints if model is not None else None
            joints = wheels if wheels is not None else tuple(f"wheel_{n}_joint" for n in ("left", "right"))
            self._wheel_dof = [m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j)] for j in joints]
        mujoco.mj_forward(m, d)

    @property
    def caster(self) -> sensors.RayCaster:
        """The ray caster of the laser and the LiDAR, when they run in this process."""
        if not isinstance(self._ranges, InProcessSensors):
            raise RuntimeError("the laser and the LiDAR run in a worker process (SimOptions.sensor_worker)")
        return self._ranges.caster

    def base_pose(self) -> np.ndarray:
        """True 4x4 pose of base_link in the world frame."""
        t = np.empty((4, 4))  # every element set below: np.eye's values, without its cost on every tick
        t[:3, :3] = self.data.xmat[self._bid].reshape(3, 3)
        t[:3, 3] = self.data.xpos[self._bid]
        t[3] = _HOMOGENEOUS_ROW
        return t

    def base_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """(linear, angular) velocity of base_link in its own frame."""
        v = self._velocity6()
        return v[3:], v[:3]

    def _velocity6(self) -> np.ndarray:
        """(angular, linear) velocity of base_link in its own frame, MuJoCo's order."""
        v = np.zeros(6)
        mujoco.mj_objectVelocity(
            self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, self._bid, v, 1
        )  # body frame, not inertial
        return v

    # ------------------------------------------------------------ node
    def setup(self) -> None:
        self.subscribe(self.robot.cmd_topic, self._on_cmd)
        self.create_timer(TICK_NS, self._tick, start_ns=0)

    def _on_cmd(self, msg, t_ns: int) -> None:
        self._cmd = messages.twist_values(msg)
        self._cmd_ns = t_ns

    def _drive(self, t_ns: int) -> None:
        # plain floats with numpy's clip comparisons: the same numbers as array arithmetic, faster per tick
        d = self.robot.drive
        dt = TICK_NS / 1e9
        fresh = self._cmd_ns is not None and (t_ns - self._cmd_ns) <= d.cmd_vel_timeout * 1e9
        tx, ty, tw = self._cmd if fresh else (0.0, 0.0, 0.0)
        (lx, ly, lw), (hx, hy, hw) = self._cmd_lo, self._cmd_hi
        (ax, ay, aw), (bx, by, bw) = self._acc_lo, self._acc_hi
        vx, vy, wz = self._vel
        k = self._gain
        vx = vx + _clip((_clip(tx, lx, hx) - vx) * k, ax, bx)
        vy = vy + _clip((_clip(ty, ly, hy) - vy) * k, ay, by)
        wz = wz + _clip((_clip(tw, lw, hw) - wz) * k, aw, bw)
        self._vel = (vx, vy, wz)
        ctrl = self.data.ctrl
        if self.legged:
            ctrl[self._act["x"]], ctrl[self._act["y"]] = rotate_planar(vx, vy, self._yaw())
            ctrl[self._act["yaw"]] = wz
            g = d.gait
            self._phase += 2 * math.pi * dt / (2 * g.stance_duration)
            speed = max(abs(vx) / d.max_vx, abs(vy) / d.max_vy if d.max_vy else 0.0, abs(wz) / d.max_wz)
            a = min(1.0, speed)
            ctrl[self._act["z"]] = g.bob_amplitude * a * math.cos(2 * self._phase)
            ctrl[self._act["roll"]] = math.radians(g.roll_amplitude) * a * math.sin(self._phase)
            ctrl[self._act["pitch"]] = math.radians(g.pitch_amplitude) * a * math.sin(2 * self._phase)
        else:
            r_true = d.wheel_radius * (1.0 + d.wheel_radius_error)
            half = d.wheel_separation / 2
            ctrl[self._act["left"]] = (vx - wz * half) / r_true
            ctrl[self._act["right"]] = (vx + wz * half) / r_true

    def _diverged(self) -> int | None:
        """The warning of ``_DIVERGED`` MuJoCo reset the state on in the steps since the last call, or None."""
        return next((w for w in _DIVERGED if self.data.warning[w].number), None)

    def _divergence(self, t_ns: int, warning: int) -> str:
        """What a diverged physics step found, where, and what to check."""
        m = self.model
        index = int(self.data.warning[warning].lastinfo)
        if warning == _QPOS:  # the joint whose coordinates hold that index
            jnt = int(np.searchsorted(m.jnt_qposadr, index, side="right")) - 1
        else:
            jnt = int(m.dof_jntid[index])
        bid = int(m.jnt_bodyid[jnt])
        body = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, bid) or f"body {bid}"
        joint = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, jnt)
        at = f"joint '{joint}' of link '{body}'" if joint else f"the free joint of '{body}'"
        return (
            f"the simulation diverged at t = {t_ns / 1e9:.3f} s (MuJoCo: {_DIVERGED[warning]} of {at} not finite or "
            f"huge): the robot's masses, inertias or drive gains are out of proportion; check the <inertial> of "
            f"'{body}' and of the links beside it in {_source(self.robot)}"
        )

    def _yaw(self) -> float:
        m = self.data.xmat[self._bid]
        return math.atan2(m[3], m[0])

    def _tick(self, t_ns: int) -> None:
        if t_ns > 0:
            self._drive(t_ns)
            lpf = self._imu_lpf
            for _ in range(self.substeps):
                mujoco.mj_step(self.model, self.data)
                if lpf is not None:
                    lpf.add(self.data.sensordata)
            warning = self._diverged()
            if warning is not None:
                raise SimulationError(self._divergence(t_ns, warning))
            if lpf is not None:
                lpf.tick()
            mujoco.mj_kinematics(self.model, self.data)
            self._publish_contacts(t_ns)
        else:
            self._publish_static(t_ns)
        base = self.base_pose()
        self._pose_history.append((t_ns, base))
        p = self._periods
        if t_ns % CLOCK_PERIOD_NS == 0:
            if self._raw("/clock"):
                self.publish("/clock", messages.CLOCK, self._cdr_clock.encode(divmod(t_ns, 1_000_000_000)))
            else:
                self.publish("/clock", messages.CLOCK, messages.clock(t_ns))
        if t_ns % p["odom"] == 0:
            self._publish_odometry(t_ns, base)
        if p["imu"] and t_ns % p["imu"] == 0:
            self._publish_imu(t_ns, base)
        if p["scan"] and t_ns % p["scan"] == 0:
            self._publish_scan(t_ns, base)
        if p["lidar"] and t_ns % p["lidar"] == 0 and t_ns > 0:
            self._publish_lidar(t_ns)
        if self._joints is not None and t_ns % self._joints.period_ns == 0:
            self._joints.publish(self, t_ns)

    def _raw(self, topic: str) -> bool:
        """Publish ``topic`` as CDR bytes: only sinks (the recorder) see it."""
        return not self.executor.has_subscribers(topic)

    def _publish_odometry_msg(self, topic: str, t_ns: int, frame: str, child: str, xyz, q, lin, ang) -> None:
        if self._raw(topic):
            sec, nsec = divmod(t_ns, 1_000_000_000)
            data = self._cdr_odometry.encode((sec, nsec, frame, child, *xyz, *q, *_ZEROS36, *lin, *ang, *_ZEROS36))
            self.publish(topic, messages.ODOMETRY, data)
        else:
            self.publish(topic, messages.ODOMETRY, messages.odometry(t_ns, frame, child, xyz, q, lin, ang))

    def _publish_tf(self, t_ns: int, transforms: list[tuple[str, str, tuple, tuple]]) -> None:
        """/tf of (parent, child, xyz, q_xyzw) transforms at ``t_ns``."""
        if self._raw("/tf"):
            sec, nsec = divmod(t_ns, 1_000_000_000)
            items = [(sec, nsec, parent, child, *xyz, *q) for parent, child, xyz, q in transforms]
            self.publish("/tf", messages.TF_MESSAGE, self._cdr_tf.encode((items,)))
        else:
            tfs = [messages.transform_stamped(t_ns, parent, child, xyz, q) for parent, child, xyz, q in transforms]
            self.publish("/tf", messages.TF_MESSAGE, messages.tf_message(tfs))

    # ------------------------------------------------------------ contacts
    def contacts(self) -> dict[str, float]:
        """World geoms the robot touches now, with the deepest penetration (m, >= 0) of each."""
        n = self.data.ncon
        if n == 0:
            return {}
        c = self.data.contact
        g1, g2 = c.geom1[:n], c.geom2[:n]
        robot, obstacle = self._robot_geom, self._obstacle_geom
        hit = (robot[g1] & obstacle[g2]) | (obstacle[g1] & robot[g2])
        out: dict[str, float] = {}
        for a, b, dist in zip(g1[hit].tolist(), g2[hit].tolist(), c.dist[:n][hit].tolist()):
            geom = b if obstacle[b] else a
            name = mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, geom) or f"geom {geom}"
            out[name] = max(out.get(name, 0.0), -dist)  # dist < 0: penetration
        return out

    def _publish_contacts(self, t_ns: int) -> None:
        now = self.contacts()
        if not now and not self._touching:
            return
        for name in sorted(n for n, last in self._touching.items() if n not in now and t_ns - last > CONTACT_GAP_NS):
            del self._touching[name]
            self.publish(EVENTS_TOPIC, messages.EVENT_TYPE, messages.event(t_ns, "collision_end", self.name, name))
        for name in sorted(now.keys() - self._touching.keys()):
            self.publish(
                EVENTS_TOPIC, messages.EVENT_TYPE, messages.event(t_ns, "collision", self.name, name, now[name])
            )
        for name in now:
            self._touching[name] = t_ns

    # ------------------------------------------------------------ publishers
    def _publish_static(self, t_ns: int) -> None:
        r = self.robot
        f = r.frames
        tfs = [messages.transform_stamped(t_ns, f.world, f.map, (0, 0, 0), (0, 0, 0, 1))]
        if r.model is not None:  # the description's fixed joints and sensor frames
            for s in r.model.static_frames:
                tfs.append(
                    messages.transform_stamped(t_ns, r.frame(s.parent), r.frame(s.child), s.pose[:3], s.pose[3:])
                )
            self.publish("/tf_static", messages.TF_MESSAGE, messages.tf_message(tfs))
            return
        for cfg in (r.scan, r.lidar, r.imu):
            if cfg is None:
                continue
            x, y, z, roll, pitch, yaw = cfg.mount
            tfs.append(
                messages.transform_stamped(
                    t_ns, r.frame(f.base), r.frame(cfg.frame), (x, y, z), quat_from_rpy(roll, pitch, yaw)
                )
            )
        self.publish("/tf_static", messages.TF_MESSAGE, messages.tf_message(tfs))

    def _publish_odometry(self, t_ns: int, base: np.ndarray) -> None:
        o = self.robot.odom
        names = self._frame_names
        wx, wy, wz, vx, vy, vz = self._velocity6().tolist()
        q_base = mat_to_quat(self.data.xmat[self._bid])
        bx, by, bz = self.data.xpos[self._bid].tolist()
        self._publish_odometry_msg(
            o.ground_truth_topic, t_ns, names["world"], names["base"], (bx, by, bz), q_base, (vx, vy, vz), (wx, wy, wz)
        )
        # planar true pose of the footprint
        yaw = yaw_from_matrix(base)
        dt = self._periods["odom"] / 1e9
        if o.use_ground_truth_odom:
            self._odom = (bx, by, yaw)
            self._odom_twist = (vx, vy, wz)
        else:
            if self.legged:
                scale = 1.0 + o.linear_scale_error
                mx, my, mw = vx * scale, vy * scale, wz + o.yaw_rate_bias
            else:
                wl, wr = (float(self.data.qvel[i]) for i in self._wheel_dof)
                rr = self.robot.drive.wheel_radius
                mx, my, mw = rr * (wl + wr) / 2, 0.0, rr * (wr - wl) / self.robot.drive.wheel_separation
            if self.options.noise:
                nx, ny, nw = self._odom_noise.next().tolist()
                mx, my, mw = mx + nx, my + ny, mw + nw
            if not self.legged:
                my = 0.0
            if t_ns > 0:
                x, y, th = self._odom
                mid = th + mw * dt / 2
                dx, dy = rotate_planar(mx, my, mid)
                x += dx * dt
                y += dy * dt
                th = wrap_angle(th + mw * dt)
                self._odom = (x, y, th)
            self._odom_twist = (mx, my, mw)
        ox, oy, oth = self._odom
        tvx, tvy, tw = self._odom_twist
        q_odom = quat_from_yaw(oth)
        t_map_fp = planar_matrix(bx, by, yaw)
        t_odom_fp = planar_matrix(ox, oy, oth)
        # the pose /odom and /tf give the odometry's edge: odom -> footprint (planar), or, with no footprint
        # frame, odom -> base with the true height and tilt (one pose on both, as a ROS odometry node gives)
        if names["footprint"]:
            child, odom_xyz, odom_q = names["footprint"], (ox, oy, 0.0), q_odom
        else:
            t_odom_base = t_odom_fp @ np.linalg.inv(t_map_fp) @ base
            child, odom_xyz, odom_q = names["base"], t_odom_base[:3, 3].tolist(), mat_to_quat(t_odom_base[:3, :3])
        self._publish_odometry_msg(
            o.topic, t_ns, names["odom"], child, odom_xyz, odom_q, (tvx, tvy, 0.0), (0.0, 0.0, tw)
        )
        # TF: map -> odom (correction), odom -> footprint (odometry), footprint -> base (height, tilt)
        t_map_odom = t_map_fp @ np.linalg.inv(t_odom_fp)
        tfs = []
        if self.options.localization == "perfect":
            tfs.append((names["map"], names["odom"], t_map_odom[:3, 3].tolist(), mat_to_quat(t_map_odom[:3, :3])))
        tfs.append((names["odom"], child, odom_xyz, odom_q))
        if names["footprint"]:
            t_fp_base = np.linalg.inv(t_map_fp) @ base
            tfs.append((names["footprint"], names["base"], t_fp_base[:3, 3].tolist(), mat_to_quat(t_fp_base[:3, :3])))
        self._publish_tf(t_ns, tfs)

    def _publish_imu(self, t_ns: int, base: np.ndarray) -> None:
        cfg = self.robot.imu
        assert cfg is not None  # scheduled only for a configured sensor
        if self._imu_lpf is not None:
            gx, gy, gz, ax, ay, az = self._imu_lpf.value
        else:
            sd = self.data.sensordata.tolist()
            g, a = self._imu_adr
            gx, gy, gz = sd[g : g + 3]
            ax, ay, az = sd[a : a + 3]
        if self.options.noise:
            row = self._imu_noise.next()
            n = row.tolist()
            bg, ba = self._imu_bias
            gx, gy, gz = gx + bg[0] + n[0], gy + bg[1] + n[1], gz + bg[2] + n[2]
            ax, ay, az = ax + ba[0] + n[3], ay + ba[1] + n[4], az + ba[2] + n[5]
            dq = row[6:9]
            r = math.sqrt(1 + (dq @ dq) / 4)
            noise = self._imu_rot
            mujoco.mju_quat2Mat(noise, np.array([1.0 / r, n[6] / 2 / r, n[7] / 2 / r, n[8] / 2 / r]))
            q = mat_to_quat((base[:3, :3] @ noise.reshape(3, 3)).ravel())
        else:
            q = mat_to_quat(self.data.xmat[self._bid])
        sec, nsec = divmod(t_ns, 1_000_000_000)
        if self._raw(cfg.topic):
            co, cg, ca = self._imu_cov_values
            data = self._cdr_imu.encode((sec, nsec, self._imu_frame, *q, *co, gx, gy, gz, *cg, ax, ay, az, *ca))
            self.publish(cfg.topic, messages.IMU, data)
            return
        # the builders' work without their conversions: every value here is already a Python float
        cov_o, cov_g, cov_a = self._imu_cov
        Time, Header, Quaternion, Vector3 = self._imu_types
        msg = self._Imu(
            Header(Time(sec, nsec), self._imu_frame),
            Quaternion(*q),
            cov_o,
            Vector3(gx, gy, gz),
            cov_g,
            Vector3(ax, ay, az),
            cov_a,
        )
        self.publish(cfg.topic, messages.IMU, msg)

    def sensor_pose(self, base: np.ndarray, frame: str) -> np.ndarray:
        return base @ self._mounts[frame]

    def _publish_scan(self, t_ns: int, base: np.ndarray) -> None:
        cfg = self.robot.scan
        assert cfg is not None and self._ranges is not None  # scheduled only for a configured sensor
        pose = self.sensor_pose(base, cfg.frame)
        raw = self._raw(cfg.topic)
        ticket = self._ranges.request(SCAN, (t_ns, pose, raw))
        if raw:
            self._publish_raw(SCAN, cfg.topic, messages.LASER_SCAN, ticket)
        else:
            ranges = self._ranges.result(ticket)
            self.publish(
                cfg.topic, messages.LASER_SCAN, sensors.scan_message(t_ns, self._frame_names["scan"], cfg, ranges)
            )

    def _publish_lidar(self, t_ns: int) -> None:
        cfg = self.robot.lidar
        assert cfg is not None and self._ranges is not None  # scheduled only for a configured sensor
        times = tuple((tp - t_ns) / 1e9 for tp, _ in self._pose_history)
        poses = np.stack([self.sensor_pose(b, cfg.frame) for _, b in self._pose_history])
        raw = self._raw(cfg.topic)
        ticket = self._ranges.request(LIDAR, (t_ns, self._lidar_frames, times, poses, raw))
        self._lidar_frames += 1
        if raw:
            self._publish_raw(LIDAR, cfg.topic, messages.POINT_CLOUD2, ticket)
        else:
            cols = self._ranges.result(ticket)
            self.publish(cfg.topic, messages.POINT_CLOUD2, make_cloud(t_ns, self._frame_names["lidar"], cols))

    def _publish_raw(self, kind: str, topic: str, typename: str, ticket: int) -> None:
        """Publish the CDR bytes of request ``ticket`` now (in this process), or take their place, filled
        once they have come (module docstring)."""
        ranges = self._ranges
        if isinstance(ranges, InProcessSensors):
            self.publish(topic, typename, ranges.result(ticket))
            return
        assert ranges is not None
        held = self._late[kind]
        held.append((ticket, topic, typename, self.defer()))
        while held and (len(held) > MAX_AHEAD or ranges.ready(held[0][0])):
            self._fill(*held.popleft())

    def _fill(self, ticket: int, topic: str, typename: str, place: Deferred) -> None:
        assert self._ranges is not None
        place.publish(topic, typename, self._ranges.result(ticket))
        place.close()

    def finish(self) -> None:
        """Fill the raw results still to come, in request order, and end the sensor worker."""
        if self._ranges is not None:
            self._ranges.ending()
            for late in sorted((*self._late[SCAN], *self._late[LIDAR]), key=lambda h: h[0]):
                self._fill(*late)
        for held in self._late.values():
            held.clear()
        self.close()

    def close(self) -> None:
        """End the sensor worker, if any (``finish`` does; call it when a run ends otherwise)."""
        if self._ranges is not None:
            self._ranges.close()


class ImuLowPass:
    """A real IMU's output filter: the gyro and accelerometer (MuJoCo's values at every physics step)
    averaged over each tick, the anti-aliasing of a sensor that integrates between samples, then a
    first-order low-pass at ``bandwidth_hz`` once a tick (an IMU's digital low-pass, as drivers set it)."""

    def __init__(self, bandwidth_hz: float, tick_s: float, gyro_adr: int, accel_adr: int) -> None:
        self.alpha = 1.0 - math.exp(-2.0 * math.pi * bandwidth_hz * tick_s)
        self._index = np.r_[gyro_adr : gyro_adr + 3, accel_adr : accel_adr + 3]
        self._sum = np.zeros(6)
        self._n = 0
        self._state = np.zeros(6)
        self.value: tuple[float, ...] = (0.0,) * 6

    def start(self, sensordata: np.ndarray) -> None:
        """The filter at rest on the sensors' first values (no start-up transient)."""
        self._state = sensordata[self._index].astype(np.float64)
        self.value = tuple(self._state.tolist())

    def add(self, sensordata: np.ndarray) -> None:
        """One physics step's values."""
        self._sum += sensordata[self._index]
        self._n += 1

    def tick(self) -> None:
        """The tick's mean into the filter."""
        mean = self._sum / self._n
        self._state = self._state + self.alpha * (mean - self._state)
        self.value = tuple(self._state.tolist())
        self._sum[:] = 0.0
        self._n = 0


JOINT_STATE = "sensor_msgs/msg/JointState"


class WheelJoints:
    """``/joint_states`` of a described robot's wheel joints, and their links' transforms on ``/tf``, at the
    joint state publisher's rate: what Gazebo's JointStatePublisher and robot_state_publisher publish."""

    def __init__(self, model, robot: RobotSpec) -> None:
        described = robot.model
        assert described is not None and described.wheel_joints is not None
        self.topic = described.joint_states_topic
        self.period_ns = _period_ns(described.joint_states_rate)
        self.names = list(described.wheel_joints)
        ids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in self.names]
        self._qpos = [int(model.jnt_qposadr[i]) for i in ids]
        self._dof = [int(model.jnt_dofadr[i]) for i in ids]
        links = {link.joint: link for link in described.links}
        self._bodies = []
        for j in self.names:
            link = links[j]
            parent = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link.parent)
            child = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link.name)
            self._bodies.append((robot.frame(link.parent), robot.frame(link.name), parent, child))

    def publish(self, node: SimNode, t_ns: int) -> None:
        d = node.data
        state = messages.msg_class(JOINT_STATE)(
            header=messages.header(t_ns, ""),
            name=self.names,
            position=np.array([d.qpos[i] for i in self._qpos], dtype=np.float64),
            velocity=np.array([d.qvel[i] for i in self._dof], dtype=np.float64),
            effort=np.zeros(0, dtype=np.float64),
        )
        node.publish(self.topic, JOINT_STATE, state)
        tfs = []
        for parent_frame, child_frame, parent, child in self._bodies:
            rp, rc = d.xmat[parent].reshape(3, 3), d.xmat[child].reshape(3, 3)
            xyz = rp.T @ (d.xpos[child] - d.xpos[parent])
            tfs.append((parent_frame, child_frame, tuple(xyz.tolist()), mat_to_quat(rp.T @ rc)))
        node._publish_tf(t_ns, tfs)
