"""A synthetic LiDAR sequence with exact ground truth, for the 3D mapper's tests and benchmark.

A 10 x 10 x 2.5 m room with four boxes is ray cast with Open3D from a Velodyne-like sensor
(rings x columns, one column per time slot of a 10 Hz sweep) that moves during the sweep along a
known trajectory, with a slight body sway. Per-point times are relative to the frame stamp (the
start of the sweep). The IMU (200 Hz, base_link) is the exact body rate and specific force of the
same trajectory, so the data has no error source apart from the range noise asked for.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import open3d as o3d
from scipy.spatial.transform import Rotation

from navlog.replay import messages
from navlog.replay.pointcloud import make_cloud
from navlog.replay.runtime.executor import Envelope

EXTRINSIC_XYZ = (0.2, 0.0, 0.08)  # livox_frame in base_link
SWEEP_S = 0.1
SWEEP_NS_INT = 100_000_000
ROOM = (10.0, 10.0, 2.5)
# (center x, y, size x, y, z, yaw rad)
BOXES = (
    (2.0, 1.5, 0.6, 0.4, 0.5, 0.0),
    (-2.0, 2.0, 0.5, 1.2, 1.4, 0.5),
    (-2.0, -2.0, 0.4, 0.9, 1.8, 0.0),
    (0.5, 3.2, 0.9, 0.5, 0.7, -0.3),
)


def room_mesh() -> o3d.geometry.TriangleMesh:
    """The room (floor, ceiling and walls as one box, seen from inside) and the boxes, in `world`."""
    sx, sy, sz = ROOM
    mesh = o3d.geometry.TriangleMesh.create_box(sx, sy, sz)
    mesh.translate((-sx / 2, -sy / 2, 0.0))
    for cx, cy, bx, by, bz, yaw in BOXES:
        box = o3d.geometry.TriangleMesh.create_box(bx, by, bz)
        box.translate((-bx / 2, -by / 2, 0.0))
        box.rotate(Rotation.from_euler("z", yaw).as_matrix(), center=(0.0, 0.0, 0.0))
        box.translate((cx, cy, 0.0))
        mesh += box
    return mesh


def raycasting_scene(mesh: o3d.geometry.TriangleMesh) -> o3d.t.geometry.RaycastingScene:
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))
    return scene


Trajectory = Callable[[np.ndarray], np.ndarray]  # times (s) -> (N, 4, 4) world <- base_link


def _ramped_distance(t: np.ndarray, speed: float, ramp_s: float) -> np.ndarray:
    """Distance travelled when the speed grows linearly from rest to ``speed`` over ``ramp_s``."""
    if ramp_s <= 0:
        return speed * t
    return np.where(t < ramp_s, speed * t**2 / (2 * ramp_s), speed * (t - ramp_s / 2))


def loop_trajectory(
    speed: float = 0.3, radius: float = 1.0, center=(0.0, -0.5), sway_deg: float = 0.5, ramp_s: float = 1.0
) -> Trajectory:
    """A circle driven counter-clockwise from rest (speed reached after ``ramp_s``), with roll/pitch
    sway (3 and 2.3 Hz) and a 2 Hz bob, as a walking robot's body moves."""

    def poses(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64)
        a = _ramped_distance(t, speed, ramp_s) / radius - np.pi / 2
        out = np.tile(np.eye(4), (len(t), 1, 1))
        out[:, 0, 3] = center[0] + radius * np.cos(a)
        out[:, 1, 3] = center[1] + radius * np.sin(a)
        out[:, 2, 3] = 0.32 + 0.005 * np.sin(2 * np.pi * 2.0 * t)
        sway = np.deg2rad(sway_deg)
        rpy = np.stack(
            [sway * np.sin(2 * np.pi * 3.0 * t), sway * np.sin(2 * np.pi * 2.3 * t + 1.0), a + np.pi / 2], axis=1
        )
        out[:, :3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()
        return out

    return poses


def spin_trajectory(rate: float = 1.5, speed: float = 0.2, start=(0.0, -1.0), ramp_s: float = 0.5) -> Trajectory:
    """Sliding along +x at ``speed`` while spinning at ``rate`` rad/s (a fast-rotating sweep), from rest."""

    def poses(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=np.float64)
        out = np.tile(np.eye(4), (len(t), 1, 1))
        out[:, 0, 3] = start[0] + _ramped_distance(t, speed, ramp_s)
        out[:, 1, 3] = start[1]
        out[:, 2, 3] = 0.32
        out[:, :3, :3] = Rotation.from_euler("z", _ramped_distance(t, rate, ramp_s)[:, None]).as_matrix()
        return out

    return poses


@dataclass
class Frame:
    stamp_ns: int
    points: np.ndarray  # (N, 3) float32 in livox_frame
    times: np.ndarray  # (N,) float32 seconds after the stamp
    rings: np.ndarray  # (N,) uint16


@dataclass
class Sequence:
    frames: list[Frame]
    imu_ns: np.ndarray  # (M,) int64
    gyro: np.ndarray  # (M, 3) base_link angular velocity
    accel: np.ndarray  # (M, 3) specific force in base_link (gravity included)
    trajectory: Trajectory
    extrinsic: np.ndarray  # base_link <- livox_frame

    def ground_truth(self, stamps_ns) -> np.ndarray:
        return self.trajectory(np.asarray(stamps_ns, dtype=np.float64) * 1e-9)


def extrinsic() -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = EXTRINSIC_XYZ
    return m


def make_sequence(
    trajectory: Trajectory,
    n_frames: int,
    *,
    rings: int = 16,
    columns: int = 900,
    fov_deg: tuple[float, float] = (-15.0, 15.0),
    max_range: float = 30.0,
    noise_m: float = 0.01,
    seed: int = 7,
    scene: o3d.t.geometry.RaycastingScene | None = None,
) -> Sequence:
    """Frames at 10 Hz from t = 0 (stamp = sweep start), each column cast from the pose at its time."""
    scene = scene or raycasting_scene(room_mesh())
    rng = np.random.default_rng(seed)
    ext = extrinsic()
    elev = np.deg2rad(np.linspace(fov_deg[0], fov_deg[1], rings))
    az = 2 * np.pi * np.arange(columns) / columns
    # sensor-frame directions, column-major: (columns, rings, 3)
    dirs = np.stack(
        [
            np.cos(elev)[None, :] * np.cos(az)[:, None],
            np.cos(elev)[None, :] * np.sin(az)[:, None],
            np.broadcast_to(np.sin(elev), (columns, rings)),
        ],
        axis=2,
    )
    col_t = SWEEP_S * np.arange(columns) / columns
    frames = []
    for k in range(n_frames):
        t0 = k * SWEEP_S
        world_sensor = trajectory(t0 + col_t) @ ext  # (columns, 4, 4)
        d_world = np.einsum("cij,crj->cri", world_sensor[:, :3, :3], dirs)
        o_world = np.broadcast_to(world_sensor[:, None, :3, 3], d_world.shape)
        rays = np.concatenate([o_world, d_world], axis=2).reshape(-1, 6).astype(np.float32)
        hit = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(np.float64)
        r = hit + rng.normal(0.0, noise_m, hit.shape) if noise_m > 0 else hit
        ok = np.isfinite(hit) & (hit < max_range)
        pts = (dirs.reshape(-1, 3) * r[:, None])[ok]
        times = np.repeat(col_t, rings)[ok]
        ring = np.tile(np.arange(rings), columns)[ok]
        frames.append(
            Frame(int(round(t0 * 1e9)), pts.astype(np.float32), times.astype(np.float32), ring.astype(np.uint16))
        )
    # IMU at 200 Hz from central differences of the exact trajectory
    imu_t = np.arange(0.0, n_frames * SWEEP_S + 0.05, 0.005)
    h = 1e-4
    pm, p0, pp = trajectory(imu_t - h), trajectory(imu_t), trajectory(imu_t + h)
    rel = np.einsum("nji,njk->nik", pm[:, :3, :3], pp[:, :3, :3])
    gyro = Rotation.from_matrix(rel).as_rotvec() / (2 * h)
    acc_w = (pp[:, :3, 3] - 2 * p0[:, :3, 3] + pm[:, :3, 3]) / h**2 + np.array([0.0, 0.0, 9.81])
    accel = np.einsum("nji,nj->ni", p0[:, :3, :3], acc_w)
    return Sequence(frames, np.round(imu_t * 1e9).astype(np.int64), gyro, accel, trajectory, ext)


# ---------------------------------------------------------------- as ROS 2 messages


def imu_msg(t_ns: int, gyro, accel):
    Imu = messages.msg_class(messages.IMU)
    return Imu(
        header=messages.header(t_ns, "base_link"),
        orientation=messages.quaternion((0.0, 0.0, 0.0, 1.0)),
        orientation_covariance=np.full(9, -1.0),
        angular_velocity=messages.vector3(*gyro),
        angular_velocity_covariance=np.zeros(9),
        linear_acceleration=messages.vector3(*accel),
        linear_acceleration_covariance=np.zeros(9),
    )


def cloud_msg(frame: Frame, frame_id: str = "livox_frame"):
    p = frame.points
    cols = {
        "x": p[:, 0],
        "y": p[:, 1],
        "z": p[:, 2],
        "intensity": np.ones(len(p), np.float32),
        "ring": frame.rings,
        "time": frame.times,
    }
    return make_cloud(frame.stamp_ns, frame_id, cols)


def tf_static_msg():
    return messages.tf_message(
        [messages.transform_stamped(0, "base_link", "livox_frame", EXTRINSIC_XYZ, (0.0, 0.0, 0.0, 1.0))]
    )


def envelopes(seq: Sequence, extra: list[Envelope] = ()) -> list[Envelope]:
    """The log a recorder would write: /tf_static first, IMU at 200 Hz, each cloud at the end of its sweep."""
    out = [Envelope("/tf_static", messages.TF_MESSAGE, 0, tf_static_msg())]
    for t, g, a in zip(seq.imu_ns, seq.gyro, seq.accel):
        out.append(Envelope("/imu/data", messages.IMU, int(t), imu_msg(int(t), g, a)))
    for f in seq.frames:
        out.append(Envelope("/livox/lidar", messages.POINT_CLOUD2, f.stamp_ns + SWEEP_NS_INT, cloud_msg(f)))
    out.extend(extra)
    return sorted(out, key=lambda e: e.time_ns)  # stable: ties keep the order above
