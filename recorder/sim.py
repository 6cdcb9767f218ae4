"""The simulator as a node: MuJoCo physics, the robot's drive, and every sensor, on sim time.

``SimNode`` is a source node (rank 0) on the executor. Every 5 ms tick it applies the latest
``/cmd_vel`` (zero after ``cmd_vel_timeout``), steps the physics, and publishes whatever sensors are
due: ``/clock``, ``/tf_static`` (once, at t = 0), ``/tf``, ``/odom``, ``/odom/ground_truth``,
``/imu/data``, the 2D scan and the 3D LiDAR. All randomness comes from one seed, one stream per
purpose (odometry, IMU, laser, LiDAR), so changing one sensor never changes another's noise.

Odometry model (documented in the README):
- legged: the true body-frame velocity, scaled by ``1 + linear_scale_error``, plus ``yaw_rate_bias``
  and white noise, integrated at the odometry rate: it drifts like CHAMP's leg odometry.
- diff_drive: wheel joint speeds times the nominal wheel radius (the true radius differs by
  ``wheel_radius_error``), integrated: wheel slip and the radius error make it drift.
- ``use_ground_truth_odom``: /odom relays the true pose instead (as the Go2 setup does).
``map -> odom`` is published as the correction that makes ``map -> base_footprint`` the true pose
(a perfect localiser); with ground-truth odometry it stays the identity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from recorder import sensors
from recorder.robot import RobotSpec, add_to_spec
from recorder.world import World, build_spec, world_mesh
from replay import messages
from replay.executor import Node

TICK_NS = 5_000_000  # 200 Hz
CLOCK_PERIOD_NS = 10_000_000  # /clock at 100 Hz


@dataclass(frozen=True)
class SimOptions:
    seed: int = 0
    noise: bool = True
    start: tuple[float, float, float] = (0.0, 0.0, 0.0)


def mat_to_quat(mat: np.ndarray) -> tuple[float, float, float, float]:
    """(x, y, z, w) quaternion of a rotation matrix, via MuJoCo (fast enough for every tick)."""
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(mat, dtype=np.float64).ravel())
    if q[0] < 0:
        q = -q
    return (q[1], q[2], q[3], q[0])


def planar(x: float, y: float, yaw: float) -> np.ndarray:
    """4x4 transform of a planar pose."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0, x], [s, c, 0.0, y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


def _period_ns(rate: float) -> int:
    return int(round(1e9 / rate / TICK_NS)) * TICK_NS or TICK_NS


class SimNode(Node):
    name = "sim"

    def __init__(self, world: World, robot: RobotSpec, options: SimOptions) -> None:
        super().__init__()
        self.world = world
        self.robot = robot
        self.options = options
        spec = build_spec(world)
        add_to_spec(spec, robot, options.start)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.substeps = max(1, int(round(TICK_NS / 1e9 / self.model.opt.timestep)))
        self.caster = sensors.RayCaster(world_mesh(world))
        streams = np.random.SeedSequence(options.seed).spawn(4)
        self.rng_odom, self.rng_imu, self.rng_scan, self.rng_lidar = (np.random.default_rng(s) for s in streams)
        self.legged = robot.drive.type == "legged"
        self._bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "base_link")
        self._init_state()
        # command state
        self._cmd = np.zeros(3)
        self._cmd_ns: int | None = None
        self._vel = np.zeros(3)  # filtered body-frame command (vx, vy, wz)
        self._phase = 0.0
        # odometry state (x, y, yaw in the odom frame)
        self._odom = np.array(options.start, dtype=np.float64)
        self._odom_twist = np.zeros(3)
        d = robot.drive
        self._gyro_bias = self.rng_imu.normal(0, robot.imu.gyro_bias, 3) if (robot.imu and options.noise) else np.zeros(3)
        self._accel_bias = self.rng_imu.normal(0, robot.imu.accel_bias, 3) if (robot.imu and options.noise) else np.zeros(3)
        self._lidar_frames = 0
        self._pose_history: list[tuple[int, np.ndarray]] = []
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
                np.diag([v**2] * 3).ravel() for v in (robot.imu.orientation_noise, robot.imu.gyro_noise, robot.imu.accel_noise)
            )

    # ------------------------------------------------------------ state
    def _init_state(self) -> None:
        x, y, yaw = self.options.start
        m, d = self.model, self.data
        if self.robot.drive.type == "legged":
            for name, value in (("base_x", x), ("base_y", y), ("base_yaw", yaw)):
                d.qpos[m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]] = value
            self._act = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"act_{n}") for n in ("x", "y", "yaw", "z", "pitch", "roll")}
            self._z0 = self.robot.body.height
        else:
            self._act = {n: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_ACTUATOR, f"act_wheel_{n}") for n in ("left", "right")}
            self._wheel_dof = [m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"wheel_{n}_joint")] for n in ("left", "right")]
        mujoco.mj_forward(m, d)

    def base_pose(self) -> np.ndarray:
        """True 4x4 pose of base_link in the world frame."""
        t = np.eye(4)
        t[:3, :3] = self.data.xmat[self._bid].reshape(3, 3)
        t[:3, 3] = self.data.xpos[self._bid]
        return t

    def base_velocity(self) -> tuple[np.ndarray, np.ndarray]:
        """(linear, angular) velocity of base_link in its own frame."""
        v = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, self.data, mujoco.mjtObj.mjOBJ_XBODY, self._bid, v, 1)  # body frame, not inertial
        return v[3:], v[:3]

    # ------------------------------------------------------------ node
    def setup(self) -> None:
        r = self.robot
        self.subscribe("/cmd_vel", self._on_cmd)
        self.create_timer(TICK_NS, self._tick, start_ns=0)

    def _on_cmd(self, msg, t_ns: int) -> None:
        self._cmd = np.array(messages.twist_values(msg))
        self._cmd_ns = t_ns

    def _drive(self, t_ns: int) -> None:
        r, d = self.robot, self.robot.drive
        dt = TICK_NS / 1e9
        fresh = self._cmd_ns is not None and (t_ns - self._cmd_ns) <= d.cmd_vel_timeout * 1e9
        target = self._cmd.copy() if fresh else np.zeros(3)
        min_vx = -d.max_vx if d.min_vx is None else d.min_vx
        target = np.clip(target, [min_vx, -d.max_vy, -d.max_wz], [d.max_vx, d.max_vy, d.max_wz])
        step = (target - self._vel) * min(1.0, dt / max(d.response_time, dt))
        step = np.clip(step, -np.asarray(d.max_accel) * dt, np.asarray(d.max_accel) * dt)
        self._vel = self._vel + step
        vx, vy, wz = self._vel
        ctrl = self.data.ctrl
        if self.legged:
            yaw = self._yaw()
            c, s = math.cos(yaw), math.sin(yaw)
            ctrl[self._act["x"]] = c * vx - s * vy
            ctrl[self._act["y"]] = s * vx + c * vy
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

    def _yaw(self) -> float:
        m = self.data.xmat[self._bid]
        return math.atan2(m[3], m[0])

    def _tick(self, t_ns: int) -> None:
        if t_ns > 0:
            self._drive(t_ns)
            for _ in range(self.substeps):
                mujoco.mj_step(self.model, self.data)
            mujoco.mj_kinematics(self.model, self.data)
        else:
            self._publish_static(t_ns)
        base = self.base_pose()
        self._pose_history.append((t_ns, base))
        keep = self._periods["lidar"] // TICK_NS + 2 if self._periods["lidar"] else 1
        del self._pose_history[:-keep]
        p = self._periods
        if t_ns % CLOCK_PERIOD_NS == 0:
            self.publish("/clock", messages.CLOCK, messages.clock(t_ns))
        if t_ns % p["odom"] == 0:
            self._publish_odometry(t_ns, base)
        if p["imu"] and t_ns % p["imu"] == 0:
            self._publish_imu(t_ns, base)
        if p["scan"] and t_ns % p["scan"] == 0:
            self._publish_scan(t_ns, base)
        if p["lidar"] and t_ns % p["lidar"] == 0 and t_ns > 0:
            self._publish_lidar(t_ns)

    # ------------------------------------------------------------ publishers
    def _publish_static(self, t_ns: int) -> None:
        r = self.robot
        f = r.frames
        tfs = [messages.transform_stamped(t_ns, f.world, f.map, (0, 0, 0), (0, 0, 0, 1))]
        for cfg in (r.scan, r.lidar, r.imu):
            if cfg is None:
                continue
            x, y, z, roll, pitch, yaw = cfg.mount
            tfs.append(messages.transform_stamped(t_ns, r.frame(f.base), r.frame(cfg.frame), (x, y, z), messages.quat_from_rpy(roll, pitch, yaw)))
        self.publish("/tf_static", messages.TF_MESSAGE, messages.tf_message(tfs))

    def _publish_odometry(self, t_ns: int, base: np.ndarray) -> None:
        r, o = self.robot, self.robot.odom
        f = r.frames
        lin, ang = self.base_velocity()
        q_base = mat_to_quat(base[:3, :3])
        gt = messages.odometry(t_ns, f.world, r.frame(f.base), base[:3, 3], q_base, lin, ang)
        self.publish(o.ground_truth_topic, messages.ODOMETRY, gt)
        # planar true pose of the footprint
        yaw = math.atan2(base[1, 0], base[0, 0])
        true_xy = base[:2, 3]
        dt = self._periods["odom"] / 1e9
        if o.use_ground_truth_odom:
            self._odom = np.array([true_xy[0], true_xy[1], yaw])
            self._odom_twist = np.array([lin[0], lin[1], ang[2]])
        else:
            if self.legged:
                meas = np.array([lin[0], lin[1], ang[2]])
                meas[:2] *= 1.0 + o.linear_scale_error
                meas[2] += o.yaw_rate_bias
            else:
                wl, wr = (self.data.qvel[i] for i in self._wheel_dof)
                rr = self.robot.drive.wheel_radius
                meas = np.array([rr * (wl + wr) / 2, 0.0, rr * (wr - wl) / self.robot.drive.wheel_separation])
            if self.options.noise:
                meas += self.rng_odom.normal(0, [o.linear_noise, o.linear_noise, o.angular_noise])
            if not self.legged:
                meas[1] = 0.0
            if t_ns > 0:
                x, y, th = self._odom
                mid = th + meas[2] * dt / 2
                x += (meas[0] * math.cos(mid) - meas[1] * math.sin(mid)) * dt
                y += (meas[0] * math.sin(mid) + meas[1] * math.cos(mid)) * dt
                th = math.atan2(math.sin(th + meas[2] * dt), math.cos(th + meas[2] * dt))
                self._odom = np.array([x, y, th])
            self._odom_twist = meas
        ox, oy, oth = self._odom
        child = r.frame(f.base_footprint) or r.frame(f.base)
        odom_msg = messages.odometry(
            t_ns, r.frame(f.odom), child, (ox, oy, 0.0), messages.quat_from_yaw(oth),
            (self._odom_twist[0], self._odom_twist[1], 0.0), (0.0, 0.0, self._odom_twist[2]),
        )
        self.publish(o.topic, messages.ODOMETRY, odom_msg)
        # TF: map -> odom (correction), odom -> footprint (odometry), footprint -> base (height, tilt)
        t_map_fp = planar(true_xy[0], true_xy[1], yaw)
        t_odom_fp = planar(ox, oy, oth)
        t_map_odom = t_map_fp @ np.linalg.inv(t_odom_fp)
        tfs = [messages.transform_stamped(t_ns, f.map, r.frame(f.odom), t_map_odom[:3, 3], mat_to_quat(t_map_odom[:3, :3]))]
        if f.base_footprint:
            tfs.append(messages.transform_stamped(t_ns, r.frame(f.odom), r.frame(f.base_footprint), (ox, oy, 0.0), messages.quat_from_yaw(oth)))
            t_fp_base = np.linalg.inv(t_map_fp) @ base
            tfs.append(messages.transform_stamped(t_ns, r.frame(f.base_footprint), r.frame(f.base), t_fp_base[:3, 3], mat_to_quat(t_fp_base[:3, :3])))
        else:
            # no footprint frame: odom -> base carries the odometry pose with the true height and tilt
            t_odom_base = t_odom_fp @ np.linalg.inv(t_map_fp) @ base
            tfs.append(messages.transform_stamped(t_ns, r.frame(f.odom), r.frame(f.base), t_odom_base[:3, 3], mat_to_quat(t_odom_base[:3, :3])))
        self.publish("/tf", messages.TF_MESSAGE, messages.tf_message(tfs))

    def _publish_imu(self, t_ns: int, base: np.ndarray) -> None:
        cfg = self.robot.imu
        gyro = np.array(self.data.sensor("imu_gyro").data, dtype=np.float64)
        accel = np.array(self.data.sensor("imu_accel").data, dtype=np.float64)
        if self.options.noise:
            gyro = gyro + self._gyro_bias + self.rng_imu.normal(0, cfg.gyro_noise, 3)
            accel = accel + self._accel_bias + self.rng_imu.normal(0, cfg.accel_noise, 3)
            dq = self.rng_imu.normal(0, cfg.orientation_noise, 3)
            noise = np.zeros(9)
            mujoco.mju_quat2Mat(noise, np.array([1.0, dq[0] / 2, dq[1] / 2, dq[2] / 2]) / math.sqrt(1 + (dq @ dq) / 4))
            q = mat_to_quat(base[:3, :3] @ noise.reshape(3, 3))
        else:
            q = mat_to_quat(base[:3, :3])
        cov_o, cov_g, cov_a = self._imu_cov
        msg = self._Imu(
            header=messages.header(t_ns, self.robot.frame(cfg.frame)),
            orientation=messages.quaternion(q),
            orientation_covariance=cov_o,
            angular_velocity=messages.vector3(*gyro),
            angular_velocity_covariance=cov_g,
            linear_acceleration=messages.vector3(*accel),
            linear_acceleration_covariance=cov_a,
        )
        self.publish(cfg.topic, messages.IMU, msg)

    def sensor_pose(self, base: np.ndarray, frame: str) -> np.ndarray:
        return base @ self._mounts[frame]

    def _publish_scan(self, t_ns: int, base: np.ndarray) -> None:
        cfg = self.robot.scan
        pose = self.sensor_pose(base, cfg.frame)
        ranges = sensors.laser_ranges(self.caster, cfg, pose, self.rng_scan if self.options.noise else None)
        self.publish(cfg.topic, messages.LASER_SCAN, sensors.scan_message(t_ns, self.robot.frame(cfg.frame), cfg, ranges))

    def _publish_lidar(self, t_ns: int) -> None:
        cfg = self.robot.lidar
        window = [((tp - t_ns) / 1e9, self.sensor_pose(b, cfg.frame)) for tp, b in self._pose_history]
        cols = sensors.lidar_sweep(self.caster, cfg, self._lidar_frames, window, self.rng_lidar if self.options.noise else None)
        self._lidar_frames += 1
        from replay.pointcloud import make_cloud

        self.publish(cfg.topic, messages.POINT_CLOUD2, make_cloud(t_ns, self.robot.frame(cfg.frame), cols))
