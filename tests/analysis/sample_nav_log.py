"""A small navlog-style log with known geometry, for the view and export tests (and the benchmark).

The robot drives along +x at ``speed`` m/s from x=0 in a corridor whose wall is the line x = WALL_X
in the map frame. TF: map -> odom (static, +1 m in x), odom -> base_footprint (dynamic),
base_footprint -> base_link -> front_laser (static). A 2D laser in ``front_laser`` (0.1 m ahead of
base_link) sees the wall; every beam that hits it lands exactly on x = WALL_X in the map frame.
/odom drifts sideways by ``DRIFT`` m per second against /odom/ground_truth.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from navlog.replay import messages as m
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.pointcloud import make_cloud

WALL_X = 4.0  # map frame
MAP_TO_ODOM_X = 1.0
LASER_X = 0.1  # front_laser ahead of base_link (base_link = base_footprint + 0.2 z)
DRIFT = 0.01  # m/s sideways drift of /odom
GRID_RES = 0.05
GRID_ORIGIN = (-1.0, -2.0)
GRID_SIZE = (140, 80)  # width (x), height (y) cells: x -1..6, y -2..2


def robot_x_map(t_s: float, speed: float) -> float:
    return MAP_TO_ODOM_X + speed * t_s


def write_sample_log(
    path: Path,
    *,
    seconds: float = 2.0,
    speed: float = 0.5,
    scan_hz: float = 10.0,
    beams: int = 360,
    cloud_hz: float = 10.0,
    cloud_points: int = 200,
    odom_hz: float = 50.0,
    imu_hz: float = 50.0,
    with_events: bool = True,
    chunk_size: int = 4 << 20,
    frame_prefix: str = "",
    twist_stamped: bool = False,
    robot: str = "test",
    costmap_hz: float = 0.0,
) -> Path:
    """Write the sample log; returns its path. Deterministic (seeded)."""
    rng = np.random.default_rng(7)
    cloud_points = int(cloud_points)
    step_ns = 1_000_000  # 1 ms simulation step
    end_ns = int(seconds * 1e9)

    def every(hz: float):
        return int(round(1e9 / hz))

    writer = McapLogWriter(path, metadata={"navlog": {"world": "corridor", "robot": robot}}, chunk_size=chunk_size)

    def emit(item) -> None:
        t, topic, typename, msg = item
        if frame_prefix:
            _prefix_frames(msg, frame_prefix)
        if twist_stamped and typename == m.TWIST:
            msg = m.msg_class(m.TWIST_STAMPED)(header=m.header(t, "base_link"), twist=msg)
            typename = m.TWIST_STAMPED
        writer.write_raw(topic, typename, t, m.serialize(msg, typename))

    # static TF and map at t=0
    emit(
        (
            0,
            "/tf_static",
            m.TF_MESSAGE,
            m.tf_message(
                [
                    m.transform_stamped(0, "map", "odom", (MAP_TO_ODOM_X, 0, 0), (0, 0, 0, 1)),
                    m.transform_stamped(0, "base_footprint", "base_link", (0, 0, 0.2), (0, 0, 0, 1)),
                    m.transform_stamped(0, "base_link", "front_laser", (LASER_X, 0, 0.0), (0, 0, 0, 1)),
                    m.transform_stamped(0, "base_link", "livox_frame", (0.2, 0, 0.08), (0, 0, 0, 1)),
                ]
            ),
        )
    )
    emit((0, "/map", m.OCCUPANCY_GRID, occupancy_grid(0)))
    emit((0, "/plan", m.PATH, path_msg(0, [(MAP_TO_ODOM_X + 0.25 * i, 0.0) for i in range(9)])))
    emit((0, "/goal_pose", m.POSE_STAMPED, pose_stamped(0, "map", (3.0, 0.0, 0.0), m.quat_from_yaw(0.0))))
    if with_events:
        emit((0, "/events", m.EVENT_TYPE, m.event(0, "goal_accepted", "navigator", "corridor_end")))
    period = {
        "odom": every(odom_hz),
        "scan": every(scan_hz),
        "cloud": every(cloud_hz),
        "imu": every(imu_hz),
        "cmd": every(20.0),
    }
    for t in range(0, end_ns + 1, step_ns):
        ts = t / 1e9
        x_odom = speed * ts
        if t % period["odom"] == 0:
            emit(
                (
                    t,
                    "/tf",
                    m.TF_MESSAGE,
                    m.tf_message([m.transform_stamped(t, "odom", "base_footprint", (x_odom, 0, 0), (0, 0, 0, 1))]),
                )
            )
            emit(
                (
                    t,
                    "/odom/ground_truth",
                    m.ODOMETRY,
                    m.odometry(t, "world", "base_link", (x_odom, 0, 0.2), (0, 0, 0, 1), (speed, 0, 0), (0, 0, 0)),
                )
            )
            emit(
                (
                    t,
                    "/odom",
                    m.ODOMETRY,
                    m.odometry(
                        t, "odom", "base_footprint", (x_odom, DRIFT * ts, 0), (0, 0, 0, 1), (speed, 0, 0), (0, 0, 0)
                    ),
                )
            )
        if t % period["scan"] == 0 and t > 0:
            emit((t, "/scan", m.LASER_SCAN, laser_scan(t, robot_x_map(ts, speed), beams)))
        if t % period["cloud"] == 0 and t > 0:
            pts = rng.uniform(-3, 3, size=(cloud_points, 3)).astype(np.float32)
            cols = {
                "x": pts[:, 0],
                "y": pts[:, 1],
                "z": pts[:, 2],
                "intensity": np.full(cloud_points, 10.0, np.float32),
                "ring": (np.arange(cloud_points) % 16).astype(np.uint16),
                "time": np.zeros(cloud_points, np.float32),
            }
            emit((t, "/livox/lidar", m.POINT_CLOUD2, make_cloud(t, "livox_frame", cols)))
        if costmap_hz and t % every(costmap_hz) == 0:
            emit((t, "/global_costmap/costmap", m.OCCUPANCY_GRID, occupancy_grid(t)))
        if t % period["imu"] == 0:
            emit((t, "/imu/data", m.IMU, imu(t)))
        if t % period["cmd"] == 0:
            emit((t, "/cmd_vel_nav", m.TWIST, m.twist(0.6, 0.0, 0.1)))
            emit((t, "/cmd_vel_smoothed", m.TWIST, m.twist(0.55, 0.0, 0.05)))
            emit((t, "/cmd_vel", m.TWIST, m.twist(speed, 0.0, 0.0)))
    if with_events:
        emit((end_ns, "/events", m.EVENT_TYPE, m.event(end_ns, "goal_reached", "navigator", "corridor_end", 0.12)))
    writer.close()
    return path


def _prefix_frames(msg, prefix: str) -> None:
    """Prefix every frame id of a message in place (the `simple_robot/` convention)."""
    if hasattr(msg, "header") and msg.header.frame_id:
        msg.header.frame_id = prefix + msg.header.frame_id
    if hasattr(msg, "child_frame_id") and msg.child_frame_id:
        msg.child_frame_id = prefix + msg.child_frame_id
    for sub in getattr(msg, "transforms", []):
        _prefix_frames(sub, prefix)
    for sub in getattr(msg, "poses", []):
        _prefix_frames(sub, prefix)


def laser_scan(t_ns: int, robot_x: float, beams: int):
    """A 360-degree scan from front_laser seeing only the wall x = WALL_X (others: inf)."""
    laser_x = robot_x + LASER_X
    angles = -math.pi + (2 * math.pi / beams) * np.arange(beams)
    c = np.cos(angles)
    with np.errstate(divide="ignore"):
        r = np.where(c > 1e-6, (WALL_X - laser_x) / np.where(c > 1e-6, c, 1.0), np.inf)
    r = np.where(r <= 6.0, r, np.inf).astype(np.float32)
    return m.msg_class(m.LASER_SCAN)(
        header=m.header(t_ns, "front_laser"),
        angle_min=-math.pi,
        angle_max=math.pi - 2 * math.pi / beams,
        angle_increment=2 * math.pi / beams,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.12,
        range_max=6.0,
        ranges=r,
        intensities=np.zeros(0, np.float32),
    )


def occupancy_grid(t_ns: int):
    w, h = GRID_SIZE
    cells = np.zeros((h, w), dtype=np.int8)
    wall_col = int(round((WALL_X - GRID_ORIGIN[0]) / GRID_RES))
    cells[:, wall_col] = 100
    cells[:, wall_col + 1 :] = -1
    MapMetaData = m.msg_class("nav_msgs/msg/MapMetaData")
    info = MapMetaData(
        map_load_time=m.stamp(t_ns),
        resolution=GRID_RES,
        width=w,
        height=h,
        origin=m.pose((GRID_ORIGIN[0], GRID_ORIGIN[1], 0.0), (0, 0, 0, 1)),
    )
    return m.msg_class(m.OCCUPANCY_GRID)(header=m.header(t_ns, "map"), info=info, data=cells.reshape(-1))


def pose_stamped(t_ns: int, frame: str, xyz, q):
    return m.msg_class(m.POSE_STAMPED)(header=m.header(t_ns, frame), pose=m.pose(xyz, q))


def path_msg(t_ns: int, xy):
    return m.msg_class(m.PATH)(
        header=m.header(t_ns, "map"), poses=[pose_stamped(t_ns, "map", (x, y, 0.0), (0, 0, 0, 1)) for x, y in xy]
    )


def imu(t_ns: int):
    Imu = m.msg_class(m.IMU)
    return Imu(
        header=m.header(t_ns, "base_link"),
        orientation=m.quaternion((0, 0, 0, 1)),
        orientation_covariance=np.zeros(9),
        angular_velocity=m.vector3(0, 0, 0.02),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=m.vector3(0.1, 0, 9.81),
        linear_acceleration_covariance=np.zeros(9),
    )
